"""The report's verdict: every metric against every known relation, on synthetic measures with known answers.

The core rules (direction, significance cut-off, Kendall's τ) are specified in tests/metrics/test_verdict.py;
these tests specify how the report assembles them: its own Welch tests per metric family, untested pairs,
undefined values, the survival of verdicts across estimators, and the headline in words.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.report import verdict as ver
from taskcomplexity.study import load_study_file

PAPER = load_study_file(CONF_DIR / "study" / "paper.yaml")
RELATIONS, TASKS = PAPER.relations, PAPER.ids

# Known difficulty rank of each task (0 = easiest) consistent with every relation of environments.md.
DIFFICULTY = {
    "one_link_1m0-dense": 0,
    "one_link_1m65-dense": 1,
    "two_link-dense": 2,
    "two_link_obstacle-dense": 3,
    "one_link_1m0-sparse": 3,
    "one_link_1m65-sparse": 4,
    "two_link-sparse": 5,
}


def measures(metric: str, centre: dict[str, float], *, spread: float, draws: int = 5, seed: int = 0):
    """Point values and ``draws`` samples per task, normally scattered around ``centre`` with sd ``spread``."""
    rng = np.random.default_rng(seed)
    values = pd.DataFrame({"task": list(centre), "metric": metric, "value": list(centre.values())})
    samples = pd.DataFrame(
        [
            {"task": task, "metric": metric, "value": mean + spread * z}
            for task, mean in centre.items()
            for z in rng.standard_normal(draws)
        ]
    )
    return values, samples


def test_a_metric_that_falls_with_difficulty_agrees_with_every_relation():
    values, samples = measures("pic", {t: 10.0 - 2 * d for t, d in DIFFICULTY.items()}, spread=0.01)
    table = ver.verdict_table(values, samples, relations=RELATIONS)
    assert len(table) == len(RELATIONS)
    assert (table["outcome"] == "agree").all()
    assert (table["pvalue"] < 0.005).all()


def test_a_metric_that_rises_with_difficulty_contradicts_every_relation():
    values, samples = measures("poic", {t: 1.0 + d for t, d in DIFFICULTY.items()}, spread=0.01)
    table = ver.verdict_table(values, samples, relations=RELATIONS)
    assert (table["outcome"] == "contradict").all()


def test_differences_within_the_noise_are_not_significant():
    # sd 5 around means 1 apart, 5 samples each: Welch's p is far above 0.005 for every pair.
    values, samples = measures("score", {t: 1.0 - 0.1 * d for t, d in DIFFICULTY.items()}, spread=5.0)
    table = ver.verdict_table(values, samples, relations=RELATIONS)
    assert (table["outcome"] == "not significant").all()
    assert (table["pvalue"] >= 0.005).all()


def test_each_metric_is_tested_on_its_own_samples():
    pic_values, pic_samples = measures("pic", {t: 10.0 - 2 * d for t, d in DIFFICULTY.items()}, spread=0.01)
    poic_values, poic_samples = measures("poic", {t: 1.0 + d for t, d in DIFFICULTY.items()}, spread=50.0)
    table = ver.verdict_table(pd.concat([pic_values, poic_values]), pd.concat([pic_samples, poic_samples]), relations=RELATIONS)
    outcomes = table.groupby("metric")["outcome"].unique()
    assert list(outcomes["pic"]) == ["agree"]
    assert list(outcomes["poic"]) == ["not significant"]
    assert set(table["samples_easier"]) == {5}


def test_a_single_seed_is_never_significant():
    values, samples = measures("sac_final", {t: 1.0 - 0.1 * d for t, d in DIFFICULTY.items()}, spread=0.0, draws=1)
    table = ver.verdict_table(values, samples, relations=RELATIONS)
    assert table["pvalue"].isna().all()
    assert (table["outcome"] == "not significant").all()
    assert table["agrees"].all()  # the direction is still reported


def test_a_relation_with_an_undefined_value_is_listed_as_undefined():
    centre = {t: 1.0 - 0.1 * d for t, d in DIFFICULTY.items()}
    centre["two_link-sparse"] = float("nan")  # e.g. score_R when every return is equal
    values, samples = measures("score", centre, spread=0.001)
    table = ver.verdict_table(values, samples, relations=RELATIONS)
    assert len(table) == len(RELATIONS)
    undefined = table[table["outcome"] == "undefined"]
    assert set(zip(undefined["easier"], undefined["harder"], strict=True)) == {
        (r.easier, r.harder) for r in RELATIONS if "two_link-sparse" in (r.easier, r.harder)
    }
    summary = ver.summary_table(table, values, PAPER.orders)
    assert int(summary["undefined"].iloc[0]) == len(undefined)


def test_metrics_keep_the_order_of_the_report_and_get_display_labels():
    frames = [measures(m, {t: -d for t, d in DIFFICULTY.items()}, spread=0.01) for m in ("sac_auc", "poic", "pic")]
    table = ver.verdict_table(pd.concat([v for v, _ in frames]), pd.concat([s for _, s in frames]), relations=RELATIONS)
    assert list(dict.fromkeys(table["metric"])) == ["pic", "poic", "sac_auc"]
    assert list(dict.fromkeys(table["label"])) == ["PIC", "POIC", "SAC AUC"]


def test_every_metric_reads_higher_as_easier_with_a_stated_family():
    assert all(info.higher_is_easier for info in ver.METRICS.values())
    assert {info.family for info in ver.METRICS.values()} == {"random policies", "estimator", "SAC"}
    assert set(ver.SURVIVAL_METRICS) <= set(ver.METRICS)


def test_the_summary_counts_outcomes_and_gives_kendall_tau_per_reward_type():
    values, samples = measures("pic", {t: 10.0 - 2 * d for t, d in DIFFICULTY.items()}, spread=0.01)
    summary = ver.summary_table(ver.verdict_table(values, samples, relations=RELATIONS), values, PAPER.orders)
    row = summary.iloc[0]
    assert (row["relations"], row["agreements"], row["contradictions"]) == (len(RELATIONS), len(RELATIONS), 0)
    assert row["kendall_tau_dense"] == pytest.approx(1.0)
    assert row["kendall_tau_sparse"] == pytest.approx(1.0)
    assert row["family"] == "random policies"


def test_a_verdict_survives_only_when_every_estimator_reaches_it():
    falling = {t: 10.0 - 2 * d for t, d in DIFFICULTY.items()}
    frames = [measures(m, falling, spread=0.01, seed=i) for i, m in enumerate(("pic", "pic_miller_madow", "pic_knn"))]
    rising = {t: 1.0 + d for t, d in DIFFICULTY.items()}
    rising["one_link_1m0-dense"] = 10.0  # only the relations with the 1-link L = 1.0 dense arm agree
    frames.append(measures("pic_minus_null", rising, spread=0.01, seed=9))
    table = ver.verdict_table(pd.concat([v for v, _ in frames]), pd.concat([s for _, s in frames]), relations=RELATIONS)
    survival = ver.survival_table(table)
    assert len(survival) == len(RELATIONS)
    assert list(survival.columns[3:]) == ["PIC", "PIC (Miller–Madow)", "PIC (k-NN)", "PIC − null", "survives"]
    expected = [r.easier == "one_link_1m0-dense" for r in RELATIONS]
    assert survival["survives"].tolist() == expected


def test_the_headline_names_the_metric_that_agrees_and_the_one_that_contradicts():
    pic = measures("pic", {t: 1.0 + d for t, d in DIFFICULTY.items()}, spread=0.01)
    poic = measures("poic", {t: 10.0 - 2 * d for t, d in DIFFICULTY.items()}, spread=0.01, seed=1)
    values = pd.concat([pic[0], poic[0]])
    table = ver.verdict_table(values, pd.concat([pic[1], poic[1]]), relations=RELATIONS)
    sentences = ver.headline(table, ver.summary_table(table, values, PAPER.orders))
    assert sentences[0].startswith(f"Against the {len(RELATIONS)} known complexity relations")
    assert "PIC agrees with 0 and contradicts 10" in sentences[0]
    assert "POIC agrees with 10 and contradicts 0" in sentences[0]
    assert "POIC agrees with the known order most often (10 of 10)" in sentences[1]
    assert "PIC contradicts it most often (10 of 10" in sentences[1]
    assert any("SAC curves were not computed" in s for s in sentences)


def test_known_relations_cover_the_seven_tasks():
    assert PAPER.relations_among(TASKS) == RELATIONS
