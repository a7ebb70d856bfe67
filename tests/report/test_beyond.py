"""The beyond-the-paper sentences: which relations PIC and POIC leave open, and which proposed metric settles them."""

from __future__ import annotations

from types import SimpleNamespace

import pandas as pd

from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.report.beyond import left_open, open_question_sentences

# Four relations; per relation the outcomes of PIC, POIC and the learning-path PIC (a proposed metric).
OUTCOMES = {
    ("a", "b", "link_length"): ("uninformative", "contradict", "agree"),      # open: no primary agrees
    ("a", "c", "reward"): ("uninformative", "agree", "contradict"),           # answered by POIC
    ("b", "c", "reward"): ("not significant", "uninformative", "not significant"),  # open
    ("c", "d", "obstacle"): ("agree", "contradict", "agree"),                # answered by PIC
}


def verdict_table() -> pd.DataFrame:
    rows = [{"metric": metric, "easier": e, "harder": h, "kind": k, "outcome": outcome}
            for (e, h, k), outcomes in OUTCOMES.items()
            for metric, outcome in zip(("pic", "poic", "path_pic"), outcomes, strict=True)]
    return pd.DataFrame(rows)


def study_data(verdict: pd.DataFrame) -> SimpleNamespace:
    """The three things the sentences read of a study's data: registry, verdict tables, display names."""
    return SimpleNamespace(registry=DEFAULT_REGISTRY, verdict={"verdict": verdict}, name=str.upper)


def test_a_relation_is_left_open_when_no_primary_metric_agrees_with_it():
    open_ = left_open(verdict_table(), ["pic", "poic"])
    assert list(zip(open_["easier"], open_["harder"], strict=True)) == [("a", "b"), ("b", "c")]
    assert list(open_["pic"]) == ["uninformative", "not significant"]
    assert list(open_["poic"]) == ["contradict", "uninformative"]


def test_the_sentences_count_what_a_proposed_metric_settles_among_the_open_relations():
    first, *per_metric = open_question_sentences(study_data(verdict_table()))
    assert first.startswith("PIC and POIC leave 2 of the 4 known relations open (neither agrees): ")
    assert "link length: A < B (PIC uninformative, POIC contradicts)" in first
    assert "reward: B < C (PIC not significant, POIC uninformative)" in first
    path = next(s for s in per_metric if s.startswith("Learning-path PIC"))
    # Two agreements in all (a < b and c < d), one contradiction; of the two open relations it settles a < b.
    assert path == ("Learning-path PIC agrees with 2 of the 4 known relations and contradicts 1; of those left open "
                    "it agrees with 1 of the 2 such relations (link length: A < B).")
    # A proposed metric with no verdict rows is said to be missing, not counted: named once, with the metrics
    # missing for the same reason.
    missing = [s for s in per_metric if "not computed for this report" in s]
    assert sum("W₂ to SAC's policy" in s for s in missing) == 1
    assert not any("Learning-path PIC" in s and "learning-path PIC" in s.lower() for s in missing)


def test_when_every_relation_has_an_agreeing_primary_metric_nothing_is_left_open():
    verdict = verdict_table()
    verdict.loc[verdict["metric"] == "pic", "outcome"] = "agree"
    assert left_open(verdict, ["pic", "poic"]).empty
    first, *_ = open_question_sentences(study_data(verdict))
    assert first.startswith("PIC and POIC leave no known relation open")
