"""The verdict on synthetic measures whose agreement with the known task order is known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import (
    Relation,
    verdict,
    verdict_by_relation,
    verdict_summary,
    welch_matrix,
)
from taskcomplexity.study import load_study_file

PAPER = load_study_file(CONF_DIR / "study" / "paper.yaml")
RELATIONS, TASKS, TOTAL_ORDERS = PAPER.relations, PAPER.ids, PAPER.orders

# A difficulty score per task consistent with every known relation (higher = harder).
DIFFICULTY = {
    "one_link_1m0-dense": 0,
    "one_link_1m65-dense": 1,
    "one_link_1m0-sparse": 2,
    "two_link-dense": 3,
    "one_link_1m65-sparse": 4,
    "two_link_obstacle-dense": 5,
    "two_link-sparse": 6,
}


def values_table(values: dict[str, dict[str, float]]) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {"task": task, "metric": metric, "value": v}
            for metric, per_task in values.items()
            for task, v in per_task.items()
        ]
    )


def samples_table(centres: dict[str, float], *, metric: str, spread: float) -> pd.DataFrame:
    """Five values per task, centred on ``centres`` with the given spread."""
    offsets = spread * np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    return pd.DataFrame(
        [{"task": task, "metric": metric, "value": centre + o} for task, centre in centres.items() for o in offsets]
    )


def test_the_paper_study_holds_the_relations_of_environments_md():
    assert set(TASKS) == set(DIFFICULTY)
    assert len(RELATIONS) == 10
    kinds = [r.kind for r in RELATIONS]
    assert kinds.count("link_length") == 2 and kinds.count("degrees_of_freedom") == 4
    assert kinds.count("reward") == 3 and kinds.count("obstacle") == 1
    for relation in RELATIONS:
        assert DIFFICULTY[relation.easier] < DIFFICULTY[relation.harder]
    for order in TOTAL_ORDERS.values():  # each total order is implied by the relations
        assert [DIFFICULTY[t] for t in order] == sorted(DIFFICULTY[t] for t in order)


def test_the_study_keeps_only_relations_whose_tasks_are_present():
    present = PAPER.relations_among(["two_link-dense", "two_link-sparse", "one_link_1m0-dense"])
    assert present == (
        Relation("one_link_1m0-dense", "two_link-dense", "degrees_of_freedom"),
        Relation("two_link-dense", "two_link-sparse", "reward"),
    )


def test_a_metric_that_falls_with_difficulty_agrees_everywhere():
    values = values_table({"pic": {t: 10.0 - d for t, d in DIFFICULTY.items()}})
    table = verdict(values, higher_is_easier={"pic": True}, relations=RELATIONS)
    assert len(table) == 10
    assert (table["outcome"] == "agree").all() and table["significant"].all()
    assert table["pvalue"].isna().all()  # no samples, no p-values: counted as significant
    summary = verdict_summary(table, values, TOTAL_ORDERS).set_index("metric")
    assert summary.loc["pic", ["relations", "agreements", "contradictions", "not_significant"]].tolist() == [
        10,
        10,
        0,
        0,
    ]
    assert summary.loc["pic", "kendall_tau_dense"] == 1.0
    assert summary.loc["pic", "kendall_tau_sparse"] == 1.0


def test_a_reversed_metric_contradicts_everywhere():
    values = values_table({"pic": {t: float(d) for t, d in DIFFICULTY.items()}})
    table = verdict(values, higher_is_easier={"pic": True}, relations=RELATIONS)
    assert (table["outcome"] == "contradict").all()
    summary = verdict_summary(table, values, TOTAL_ORDERS).set_index("metric")
    assert summary.loc["pic", "contradictions"] == 10
    assert summary.loc["pic", "kendall_tau_dense"] == -1.0
    assert summary.loc["pic", "kendall_tau_sparse"] == -1.0


def test_a_metric_where_higher_means_harder_is_oriented():
    values = values_table({"variance": {t: float(d) for t, d in DIFFICULTY.items()}})
    table = verdict(values, higher_is_easier={"variance": False}, relations=RELATIONS)
    assert (table["outcome"] == "agree").all()
    assert verdict_summary(table, values, TOTAL_ORDERS)["kendall_tau_dense"][0] == 1.0


def test_overlapping_samples_are_not_significant_and_separated_ones_decide():
    centres = {t: 10.0 - d for t, d in DIFFICULTY.items()}
    values = values_table({"pic": centres})
    # Spread 0.01: tasks one unit apart are separated by 100 sd, every test is significant.
    tight = verdict(values, higher_is_easier={"pic": True}, relations=RELATIONS, samples=samples_table(centres, metric="pic", spread=0.01))
    assert (tight["outcome"] == "agree").all() and (tight["pvalue"] < 1e-6).all()
    # Spread 10: differences of a few units are far inside the noise, nothing is significant.
    loose = verdict(values, higher_is_easier={"pic": True}, relations=RELATIONS, samples=samples_table(centres, metric="pic", spread=10.0))
    assert (loose["outcome"] == "not significant").all() and (loose["pvalue"] > 0.005).all()
    assert verdict_summary(loose, values, TOTAL_ORDERS)["not_significant"][0] == 10


def test_mixed_outcomes_on_a_synthetic_metric():
    # The metric agrees on link length (5 > 3), contradicts on reward (dense 5 < sparse 5.5),
    # and the samples separate both pairs.
    tasks = ["one_link_1m0-dense", "one_link_1m65-dense", "one_link_1m0-sparse"]
    centres = {"one_link_1m0-dense": 5.0, "one_link_1m65-dense": 3.0, "one_link_1m0-sparse": 5.5}
    samples = samples_table(centres, metric="poic", spread=0.01)
    table = verdict(values_table({"poic": centres}), higher_is_easier={"poic": True}, relations=RELATIONS, samples=samples)
    outcomes = dict(zip(table["kind"], table["outcome"], strict=True))
    assert set(table["easier"]) | set(table["harder"]) == set(tasks)
    assert outcomes == {"link_length": "agree", "reward": "contradict"}


def test_p_values_can_be_supplied_instead_of_samples():
    centres = {"two_link-dense": 2.0, "two_link-sparse": 1.0}
    draws = {"two_link-dense": [2.0, 2.1, 1.9], "two_link-sparse": [1.0, 3.0, -1.0]}
    pvalues = welch_matrix(draws).assign(metric="poic")
    table = verdict(values_table({"poic": centres}), higher_is_easier={"poic": True}, relations=RELATIONS, pvalues=pvalues)
    assert table["outcome"].tolist() == ["not significant"]
    assert table["pvalue"][0] == pytest.approx(pvalues["pvalue"][0], rel=1e-15)


def test_every_metric_needs_a_direction():
    values = values_table({"pic": {"two_link-dense": 1.0, "two_link-sparse": 0.5}})
    with pytest.raises(ValueError, match="higher_is_easier must give a direction for every metric .*\\['pic'\\]"):
        verdict(values, higher_is_easier={}, relations=RELATIONS)


def test_values_need_one_row_per_task_and_metric():
    values = values_table({"pic": {"two_link-dense": 1.0}})
    with pytest.raises(
        ValueError, match="one row per \\(task, metric\\), got several for \\('two_link-dense', 'pic'\\)"
    ):
        verdict(pd.concat([values, values]), higher_is_easier={"pic": True}, relations=RELATIONS)


def test_kendall_tau_is_nan_with_fewer_than_two_tasks_of_a_reward_type():
    values = values_table({"pic": {"two_link-dense": 1.0, "two_link-sparse": 0.5}})
    summary = verdict_summary(verdict(values, higher_is_easier={"pic": True}, relations=RELATIONS), values, TOTAL_ORDERS)
    assert np.isnan(summary["kendall_tau_dense"][0]) and np.isnan(summary["kendall_tau_sparse"][0])


def test_verdicts_by_relation_show_which_survive_a_change_of_estimator():
    falling = {t: 10.0 - d for t, d in DIFFICULTY.items()}
    values = values_table({"pic": falling, "pic_knn": {**falling, "two_link-sparse": 100.0}})
    wide = verdict_by_relation(verdict(values, higher_is_easier={"pic": True, "pic_knn": True}, relations=RELATIONS))
    assert list(wide.columns) == ["pic", "pic_knn", "unanimous"]
    assert len(wide) == 10
    changed = wide[~wide["unanimous"]]
    # Only the relations with two_link-sparse as the harder task flip under pic_knn.
    assert set(changed.index.get_level_values("harder")) == {"two_link-sparse"}
    assert (changed["pic"] == "agree").all() and (changed["pic_knn"] == "contradict").all()


def test_difference_is_the_easier_minus_the_harder_value():
    values = values_table({"pic": {"two_link-dense": 1.0, "two_link-sparse": 0.25}})
    assert verdict(values, higher_is_easier={"pic": True}, relations=RELATIONS)["difference"].tolist() == [0.75]
