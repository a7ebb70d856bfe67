"""Each ○ cell carries its own reason, and a legend lists only the reasons its cells have."""

from __future__ import annotations

import pytest

from taskcomplexity.report.outcomes import UNINFORMATIVE_REASONS, legend, uninformative_reasons

CHECKED = {("pic", "a"): "equals its permutation null", ("pic", "b"): "",
           ("pic_mm", "a"): "equals its permutation null and sits at its ceiling ln N", ("pic_mm", "b"): "",
           ("poic", "a"): "", ("poic", "b"): "sits at its ceiling ln N"}


def row(metric, outcome, easier_informative=True, harder_informative=True):
    return {"metric": metric, "easier": "a", "harder": "b", "outcome": outcome,
            "informative_easier": easier_informative, "informative_harder": harder_informative}


@pytest.mark.parametrize(("verdict", "expected"), [
    (row("pic", "uninformative", easier_informative=False), ("null",)),
    (row("poic", "uninformative", harder_informative=False), ("ceiling",)),
    (row("pic_mm", "uninformative", easier_informative=False), ("null", "ceiling")),
    # Both values carry information, yet the verdict is uninformative: the difference is the nulls' difference.
    (row("pic", "uninformative"), ("nulls",)),
    (row("pic", "agree"), ()),
    (row("pic", "not significant", easier_informative=False), ()),
])
def test_the_reason_of_a_cell_is_read_from_the_information_check_of_its_two_tasks(verdict, expected):
    assert uninformative_reasons(verdict, CHECKED) == expected


def test_the_legend_of_a_circle_lists_only_the_reasons_present():
    only_null = legend(["agree", "uninformative"], {"null"})
    assert UNINFORMATIVE_REASONS["null"] in only_null
    assert UNINFORMATIVE_REASONS["ceiling"] not in only_null and UNINFORMATIVE_REASONS["nulls"] not in only_null
    both = legend(["uninformative"], {"nulls", "ceiling"})
    assert both == f"○ uninformative: {UNINFORMATIVE_REASONS['ceiling']} or {UNINFORMATIVE_REASONS['nulls']}"
    # Without a ○ cell the reasons are not listed at all.
    assert "uninformative" not in legend(["agree", "contradict"], {"null"})


def test_the_verdict_box_promotes_only_measures_the_headline_ranks():
    """A family's representative in the verdict box is on one scale across tasks and agrees at least once, as
    the headline's "agrees most often" requires; a raw return in task units is never promoted."""
    from types import SimpleNamespace

    import pandas as pd

    from taskcomplexity.metrics.registry import DEFAULT_REGISTRY
    from taskcomplexity.report.verdict_tables import headline_metrics

    outcomes = {"pic": "not significant", "poic": "agree", "variance": "agree", "r_mean": "contradict",
                "score": "not significant", "pic_knn": "not significant", "pic_miller_madow": "contradict"}
    verdict = pd.DataFrame([{"metric": m, "easier": "a", "harder": "b", "outcome": o} for m, o in outcomes.items()])
    chosen, representatives, contradicting = headline_metrics(
        SimpleNamespace(verdict={"verdict": verdict}, registry=DEFAULT_REGISTRY))
    assert "random policies" not in representatives  # variance agrees, but in reward units; score never agrees
    assert "estimator" not in representatives  # no estimator agrees
    assert contradicting == "pic_miller_madow"  # r_mean contradicts too, but is not ranked across tasks
    assert set(chosen) == {"pic", "poic", "pic_miller_madow"}
