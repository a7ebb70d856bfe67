"""The verdict (``taskcomplexity.verdict``) on synthetic measures whose agreement with the known order is known."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics import DEFAULT_REGISTRY, Metric
from taskcomplexity.study_data import Relation, load_study_file, study_from_config
from taskcomplexity.verdict import by_relation, judge, pairwise_welch, summarise
from taskcomplexity.verdict.references import correlations, quantities, reference_scores

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
RELATIONS, TASKS, TOTAL_ORDERS = SEVEN_TASKS.relations, SEVEN_TASKS.ids, SEVEN_TASKS.orders
HARDER = Metric("steps_needed", "steps needed", "steps", "steps", higher_is_easier=False, family="baseline",
                stage="metrics", compute=lambda s: 0.0)
REGISTRY = DEFAULT_REGISTRY.with_metrics(HARDER)

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


def measures(metric: str, centre: dict[str, float], *, spread: float, draws: int = 5):
    """Point values and ``draws`` samples per task at ``centre`` ± ``spread`` (symmetric offsets, sd ∝ spread)."""
    values = pd.DataFrame({"task": list(centre), "metric": metric, "value": list(centre.values())})
    offsets = spread * np.linspace(-2.0, 2.0, draws) if draws > 1 else np.zeros(1)
    samples = pd.DataFrame([{"task": t, "metric": metric, "value": c + o} for t, c in centre.items() for o in offsets])
    return values, samples


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
    present = SEVEN_TASKS.relations_among(["two_link-dense", "two_link-sparse", "one_link_1m0-dense"])
    assert present == (
        Relation("one_link_1m0-dense", "two_link-dense", "degrees_of_freedom"),
        Relation("two_link-dense", "two_link-sparse", "reward"),
    )


def test_a_metric_that_falls_with_difficulty_agrees_everywhere():
    # Spread 0.01 around means one unit apart: every Welch p is far below 0.005.
    values, samples = measures("pic", {t: 10.0 - d for t, d in DIFFICULTY.items()}, spread=0.01)
    table = judge(values, samples, RELATIONS, registry=REGISTRY)
    assert len(table) == 10
    assert (table["outcome"] == "agree").all() and (table["pvalue"] < 1e-6).all()
    assert (table["samples_easier"] == 5).all()
    summary = summarise(table, values, registry=REGISTRY, orders=TOTAL_ORDERS).set_index("metric")
    assert summary.loc["pic", ["relations", "agreements", "contradictions", "not_significant", "undefined"]].tolist() \
        == [10, 10, 0, 0, 0]
    assert summary.loc["pic", "kendall_tau_dense"] == pytest.approx(1.0)
    assert summary.loc["pic", "kendall_tau_sparse"] == pytest.approx(1.0)


def test_a_reversed_metric_contradicts_everywhere():
    values, samples = measures("poic", {t: float(d) for t, d in DIFFICULTY.items()}, spread=0.01)
    table = judge(values, samples, RELATIONS, registry=REGISTRY)
    assert (table["outcome"] == "contradict").all()
    summary = summarise(table, values, registry=REGISTRY, orders=TOTAL_ORDERS).set_index("metric")
    assert summary.loc["poic", "contradictions"] == 10
    assert summary.loc["poic", "kendall_tau_dense"] == pytest.approx(-1.0)


def test_a_metric_where_higher_means_harder_is_oriented_by_the_registry():
    values, samples = measures("steps_needed", {t: float(d) for t, d in DIFFICULTY.items()}, spread=0.01)
    table = judge(values, samples, RELATIONS, registry=REGISTRY)
    assert (table["outcome"] == "agree").all() and not table["higher_is_easier"].any()
    assert summarise(table, values, registry=REGISTRY, orders=TOTAL_ORDERS)["kendall_tau_dense"][0] == 1.0


def test_differences_within_the_noise_are_not_significant():
    # Spread 10 (sd ≈ 16) around means at most 6 apart, 5 samples each: every p is far above 0.005.
    values, samples = measures("pic", {t: 10.0 - d for t, d in DIFFICULTY.items()}, spread=10.0)
    table = judge(values, samples, RELATIONS, registry=REGISTRY)
    assert (table["outcome"] == "not significant").all() and (table["pvalue"] > 0.005).all()
    assert table["agrees"].all()  # the direction is still reported


def test_a_single_sample_is_never_significant():
    values, samples = measures("sac_final", {t: 1.0 - 0.1 * d for t, d in DIFFICULTY.items()}, spread=0.0, draws=1)
    table = judge(values, samples, RELATIONS, registry=REGISTRY)
    assert table["pvalue"].isna().all() and (table["outcome"] == "not significant").all()


def test_a_missing_or_non_finite_value_is_undefined_in_the_library_verdict():
    centre = {t: 1.0 - 0.1 * d for t, d in DIFFICULTY.items()}
    centre["two_link-sparse"] = float("nan")  # e.g. score_R when every return is equal
    values, samples = measures("score", centre, spread=0.001)
    values = values[values["task"] != "two_link_obstacle-dense"]  # and a task the metric has no value for
    table = judge(values, samples, RELATIONS, registry=REGISTRY)
    assert len(table) == len(RELATIONS)
    undefined = table[table["outcome"] == "undefined"]
    involved = {(r.easier, r.harder) for r in RELATIONS
                if {"two_link-sparse", "two_link_obstacle-dense"} & {r.easier, r.harder}}
    assert set(zip(undefined["easier"], undefined["harder"], strict=True)) == involved
    assert undefined["pvalue"].isna().all() and not undefined["significant"].any()
    summary = summarise(table, values, registry=REGISTRY, orders=TOTAL_ORDERS)
    assert int(summary["undefined"].iloc[0]) == len(involved) == 4
    assert int(summary["agreements"].iloc[0]) == len(RELATIONS) - 4


def test_each_metric_is_tested_on_its_own_samples_in_registry_order():
    pic = measures("pic", {t: 10.0 - d for t, d in DIFFICULTY.items()}, spread=0.01)
    poic = measures("poic", {t: 10.0 - d for t, d in DIFFICULTY.items()}, spread=50.0)
    table = judge(pd.concat([poic[0], pic[0]]), pd.concat([poic[1], pic[1]]), RELATIONS, registry=REGISTRY)
    assert list(dict.fromkeys(table["metric"])) == ["pic", "poic"]
    outcomes = table.groupby("metric")["outcome"].unique()
    assert list(outcomes["pic"]) == ["agree"] and list(outcomes["poic"]) == ["not significant"]


def test_mixed_outcomes_on_a_synthetic_metric():
    # The metric agrees on link length (5 > 3), contradicts on reward (dense 5 < sparse 5.5).
    centres = {"one_link_1m0-dense": 5.0, "one_link_1m65-dense": 3.0, "one_link_1m0-sparse": 5.5}
    values, samples = measures("poic", centres, spread=0.01)
    table = judge(values, samples, SEVEN_TASKS.relations_among(centres), registry=REGISTRY)
    assert dict(zip(table["kind"], table["outcome"], strict=True)) == {"link_length": "agree", "reward": "contradict"}
    assert table["difference"].tolist() == [2.0, -0.5]


def test_every_metric_must_be_registered():
    values, samples = measures("mystery", {"two_link-dense": 1.0, "two_link-sparse": 0.5}, spread=0.1)
    with pytest.raises(ValueError, match="registry does not know: \\['mystery'\\]"):
        judge(values, samples, RELATIONS, registry=DEFAULT_REGISTRY)


def test_values_need_one_row_per_task_and_metric():
    values, samples = measures("pic", {"two_link-dense": 1.0}, spread=0.1)
    with pytest.raises(ValueError, match="one row per \\(task, metric\\), got several for \\('two_link-dense', 'pic'\\)"):
        judge(pd.concat([values, values]), samples, RELATIONS, registry=REGISTRY)


def test_without_relations_the_summary_still_lists_every_metric():
    values, samples = measures("pic", {t: 10.0 - d for t, d in DIFFICULTY.items()}, spread=0.01)
    table = judge(values, samples, (), registry=REGISTRY)
    assert table.empty and list(table.columns)[:8] == ["metric", "easier", "harder", "kind", "value_easier",
                                                       "value_harder", "pvalue", "outcome"]
    summary = summarise(table, values, registry=REGISTRY, orders=TOTAL_ORDERS)
    assert summary["metric"].tolist() == ["pic"] and summary["relations"].tolist() == [0]
    assert summary["kendall_tau_dense"][0] == pytest.approx(1.0)  # the orders are still judged


def test_kendall_tau_is_nan_with_fewer_than_two_tasks_of_an_order():
    values, samples = measures("pic", {"two_link-dense": 1.0, "two_link-sparse": 0.5}, spread=0.1)
    summary = summarise(judge(values, samples, RELATIONS, registry=REGISTRY), values, registry=REGISTRY,
                        orders=TOTAL_ORDERS)
    assert np.isnan(summary["kendall_tau_dense"][0]) and np.isnan(summary["kendall_tau_sparse"][0])


def test_reference_scores_are_correlated_with_the_metrics_easiness():
    reference = {t: 10.0 - d for t, d in DIFFICULTY.items()}  # higher = easier
    study = dataclasses.replace(SEVEN_TASKS, reference=reference)
    pic = measures("pic", {t: 2 * v + 1 for t, v in reference.items()}, spread=0.01)[0]  # exactly linear in it
    steps = measures("steps_needed", {t: float(d) ** 2 for t, d in DIFFICULTY.items()}, spread=0.01)[0]  # monotone
    h_r = pd.DataFrame({"task": list(DIFFICULTY), "quantity": "h_r", "metric": "pic",
                        "value": [-float(d) for d in DIFFICULTY.values()]})
    table = correlations(quantities(pd.concat([pic, steps]), h_r, registry=REGISTRY),
                         reference_scores(study, {})).set_index("quantity")
    assert list(table.index) == ["pic", "h_r", "steps_needed"]  # registry order, a metric's details after it
    assert (table["reference"] == "reference").all() and (table["tasks"] == 7).all()
    assert table.loc["pic", "pearson_r"] == pytest.approx(1.0)
    assert table.loc["pic", "spearman_r"] == pytest.approx(1.0)
    assert table.loc["h_r", "pearson_r"] == pytest.approx(1.0)  # a detail is correlated as it is
    # lower steps = easier: the easiness is -d², perfectly rank-correlated, not linearly
    assert table.loc["steps_needed", "spearman_r"] == pytest.approx(1.0)
    assert 0.9 < table.loc["steps_needed", "pearson_r"] < 1.0
    assert table.loc["pic", "pearson_p"] < 1e-6


def test_score_a_and_score_r_put_the_algorithm_and_the_random_mean_on_one_scale():
    study = study_from_config({
        "name": "s", "tasks": [{"task": "cartpole"}, {"task": "pendulum"}, {"task": "acrobot"}],
        "algorithm_scores": {"cartpole": {"max": 200, "average": 194.2},
                             "pendulum": {"max": -128.6, "average": -571.5}}})
    bounds = {"cartpole": {"r_min": 9.0, "r_max": 150.0, "r_mean": 30.0},   # A_max above r_max: it sets the scale
              "pendulum": {"r_min": -1600.0, "r_max": -100.0, "r_mean": -1200.0},  # r_max above A_max
              "acrobot": {"r_min": -500.0, "r_max": -60.0, "r_mean": -499.0}}  # no algorithm score: none
    table = reference_scores(study, bounds).set_index(["task", "reference"])["value"]
    assert table[("cartpole", "score_a")] == pytest.approx((194.2 - 9.0) / (200.0 - 9.0))
    assert table[("cartpole", "score_r")] == pytest.approx((30.0 - 9.0) / (200.0 - 9.0))
    assert table[("pendulum", "score_a")] == pytest.approx((-571.5 + 1600.0) / 1500.0)
    assert table[("pendulum", "score_r")] == pytest.approx(400.0 / 1500.0)
    assert "acrobot" not in table.index.get_level_values("task")
    empty = {"cartpole": {"r_min": 200.0, "r_max": 200.0, "r_mean": 200.0}}  # every return equal to A_max
    assert np.isnan(reference_scores(study, empty)["value"]).all()


@pytest.mark.parametrize(("scores", "message"), [
    ({"mountain_car": {"max": 1.0, "average": 0.5}}, r"study\.algorithm_scores=mountain_car is not a task"),
    ({"cartpole": {"max": 1.0}}, r"study\.algorithm_scores\.cartpole must be \{max: A_max, average: A_avg\}"),
    ({"cartpole": {"max": "high", "average": 0.5}}, r"study\.algorithm_scores\.cartpole\.max must be a finite"),
    ({"cartpole": {"max": 1.0, "average": 2.0}}, r"average 2\.0 exceeds max 1\.0"),
])
def test_algorithm_scores_are_checked_against_the_study(scores, message):
    with pytest.raises(ConfigError, match=message):
        study_from_config({"name": "s", "tasks": [{"task": "cartpole"}], "algorithm_scores": scores})


def test_verdicts_by_relation_show_which_survive_a_change_of_estimator():
    falling = {t: 10.0 - d for t, d in DIFFICULTY.items()}
    pic = measures("pic", falling, spread=0.01)
    knn = measures("pic_knn", {**falling, "two_link-sparse": 100.0}, spread=0.01)
    table = judge(pd.concat([pic[0], knn[0]]), pd.concat([pic[1], knn[1]]), RELATIONS, registry=REGISTRY)
    wide = by_relation(table, ["pic", "pic_knn", "pic_miller_madow"])
    assert list(wide.columns) == ["easier", "harder", "kind", "pic", "pic_knn", "survives"]
    assert len(wide) == 10
    changed = wide[wide["survives"] == "no"]
    assert set(wide["survives"]) == {"yes", "no"}
    # Only the relations with two_link-sparse as the harder task flip under pic_knn.
    assert set(changed["harder"]) == {"two_link-sparse"} and len(changed) == 3
    assert (changed["pic"] == "agree").all() and (changed["pic_knn"] == "contradict").all()
    assert by_relation(table, ["pic", "pic_miller_madow"]).empty  # one estimator present: nothing to compare


def test_pairwise_welch_gives_every_ordered_pair_of_tasks_per_metric():
    _, samples = measures("pic", {"a": 1.0, "b": 2.0, "c": 3.0}, spread=0.1)
    single = pd.DataFrame({"task": ["a", "b"], "metric": "poic", "value": [1.0, 2.0]})  # one sample each: untestable
    tests = pairwise_welch(pd.concat([samples, single]), registry=REGISTRY)
    assert set(tests["metric"]) == {"pic"} and len(tests) == 6
    row = tests[(tests["task_a"] == "c") & (tests["task_b"] == "a")].iloc[0]
    assert row["statistic"] > 0 and row["significant"]


@pytest.mark.parametrize(("outcomes", "expected"), [
    (["agree", "agree", "agree"], "yes"),
    (["agree", "contradict", "agree"], "no"),
    (["agree", "not significant"], "no"),
    # An uninformative estimator measures its bias: left out, the other two agree.
    (["uninformative", "agree", "agree"], "yes"),
    (["uninformative", "agree", ""], "one informative estimator"),
    (["not significant", "not significant", "uninformative"], "no significant verdict"),
    (["uninformative", "uninformative"], "no significant verdict"),
])
def test_survival_compares_only_the_informative_estimators(outcomes, expected):
    from taskcomplexity.verdict.judge import survival
    assert survival(outcomes) == expected
