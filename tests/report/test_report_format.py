"""Counts in words: plurals and "k of n" that read right at 0, 1, 2 and many."""

from __future__ import annotations

from taskcomplexity.report.format import of_total, plural


def test_plural_agrees_with_the_count():
    assert plural(1, "relation") == "1 relation"
    assert plural(0, "relation") == "0 relations"
    assert plural(7, "task") == "7 tasks"
    assert plural(1, "policy", "policies") == "1 policy" and plural(20, "policy", "policies") == "20 policies"
    assert plural(1.0, "cell") == "1 cell"  # counts read from tables may be floats


def test_part_of_total_never_reads_zero_of_one():
    assert of_total(0, 1, "known relation") == "no known relation"
    assert of_total(1, 1, "known relation") == "the one known relation"
    assert of_total(2, 2, "known relation") == "both known relations"
    assert of_total(0, 7, "known relation") == "none of the 7 known relations"
    assert of_total(7, 7, "known relation") == "all 7 known relations"
    assert of_total(2, 7, "known relation") == "2 of the 7 known relations"
    assert of_total(1, 3, "policy", "policies") == "1 of the 3 policies"
