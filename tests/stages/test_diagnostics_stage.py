"""The diagnostics stage: settings, cache, and what its tables say on data with a known answer.

The estimators themselves (permutation null, Miller–Madow, k-NN on closed-form cases) are specified in
tests/metrics/test_diagnostics.py; here the stage that runs them per task and writes the report's tables.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics import DEFAULT_REGISTRY, pic_miller_madow
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.diagnostics_stage import (
    FILES,
    DiagnosticsSettings,
    compute_diagnostics,
    diagnostics_key,
    run_diagnostics_stage,
)
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.rwg_stage import RWGRequest, run_rwg_stage
from taskcomplexity.tasks.spec import make_task

METRICS = MetricsSettings(bins=1000, resamples=5)
FAST = DiagnosticsSettings(repeats=4, knn_max_samples=2000)


@pytest.fixture(scope="module")
def independent_returns() -> np.ndarray:
    """(200, 40) i.i.d. Gaussian returns: the policy carries no information, the true MI is 0."""
    return np.random.default_rng(11).normal(-20.0, 4.0, size=(200, 40))


@pytest.fixture(scope="module")
def informative_returns() -> np.ndarray:
    """(200, 40) returns whose policy means spread 10× wider than the episode noise: large true MI."""
    rng = np.random.default_rng(12)
    return rng.normal(-20.0, 10.0, size=(200, 1)) + rng.normal(0.0, 1.0, size=(200, 40))


@pytest.fixture(scope="module")
def tables(independent_returns):
    return compute_diagnostics(independent_returns, METRICS, DiagnosticsSettings(repeats=10))


def test_with_true_mi_zero_the_observed_pic_lies_within_its_permutation_null(tables):
    # Shuffling i.i.d. returns across policies changes nothing in distribution, so the observed PIC is one
    # more draw of the null: it lies within 4 null standard deviations (a 1-in-15 000 event for a normal
    # null), and far from 0 — the histogram bias the null exists to show.
    row = tables["null_summary.parquet"].set_index("metric").loc["pic"]
    assert abs(row["z"]) < 4.0
    assert row["null_mean"] > 0.5
    assert len(tables["null.parquet"]) == 10


def test_with_true_mi_zero_every_estimator_net_of_bias_is_near_zero(tables):
    estimate = tables["estimators.parquet"].iloc[0]
    # k-NN MI of 200 labels from 8 000 i.i.d. samples: over 20 seeds it averaged 0.0006 nats (sd 0.001, max
    # 0.0035); 0.05 nats is a wide margin, and still 20× below the plug-in histogram PIC of the same data.
    assert estimate["pic_knn"] < 0.05
    assert estimate["pic"] > 20 * 0.05
    assert abs(estimate["pic_minus_null"]) < 4 * estimate["pic_null_sd"]
    # Miller–Madow removes part of the plug-in bias, never adds to it (H(R|Θ) gains more than H(R)).
    assert estimate["pic_miller_madow"] < estimate["pic"]


def test_informative_returns_stand_far_above_their_null(informative_returns):
    tables = compute_diagnostics(informative_returns, METRICS, FAST)
    row = tables["null_summary.parquet"].set_index("metric").loc["pic"]
    assert row["z"] > 10
    assert tables["estimators.parquet"]["pic_knn"].iloc[0] > 1.0


def test_every_estimator_of_the_information_has_its_own_null_on_the_same_permutations(tables, independent_returns):
    null, summary = tables["null.parquet"], tables["null_summary.parquet"].set_index("metric")
    assert {"pic", "poic", "pic_miller_madow", "pic_knn"} <= set(null.columns)
    assert set(summary.index) == {"pic", "poic", "pic_miller_madow", "pic_knn"}
    # The null columns the registry's information checks name are all there (nothing checked without a null).
    assert set(DEFAULT_REGISTRY.nulls()) <= set(null.columns)
    # Each null value is its estimator on that repeat's permutation: the permutation keeps the pooled returns,
    # so Miller–Madow's null sits below histogram PIC's on every repeat, as on the observed returns.
    assert (null["pic_miller_madow"] < null["pic"]).all()
    # With the true MI 0 the observed values are draws of their nulls: within 4 null sds (1 in 15 000 for a
    # normal null); k-NN's null is near 0 (scikit-learn clips at 0), Miller–Madow's is not (its bias remains).
    for metric in ("pic_miller_madow", "pic_knn"):
        assert abs(summary.loc[metric, "excess"]) <= 4 * summary.loc[metric, "null_sd"] + 1e-3, metric
    assert summary.loc["pic_knn", "null_mean"] < 0.05
    assert summary.loc["pic_miller_madow", "null_mean"] > 0.5


def test_informative_returns_exceed_every_estimators_null(informative_returns):
    summary = compute_diagnostics(informative_returns, METRICS, FAST)["null_summary.parquet"].set_index("metric")
    for metric in ("pic", "pic_miller_madow", "pic_knn"):
        assert summary.loc[metric, "excess"] > 10 * max(summary.loc[metric, "null_sd"], 1e-3), metric


def test_the_bins_sweep_stops_at_the_metrics_bins_and_includes_them(independent_returns):
    tables = compute_diagnostics(independent_returns, MetricsSettings(bins=500, resamples=5), FAST)
    assert tables["bins_sweep.parquet"]["bins"].tolist() == [10, 100, 500]


def test_subsamples_cover_fractions_of_policies_and_episodes_up_to_the_full_sample(tables):
    sweep = tables["subsample_sweep.parquet"]
    assert sorted(sweep["policies"].unique()) == [25, 50, 100, 200]
    assert sorted(sweep["episodes"].unique()) == [5, 10, 20, 40]


def test_batches_hold_every_registered_diagnostics_metric_on_the_metrics_stage_batches(tables, independent_returns):
    batches = tables["batches.parquet"]
    assert batches["policies"].tolist() == [40] * METRICS.batches
    names = [m.name for m in DEFAULT_REGISTRY.of_stage("diagnostics")]
    assert list(batches.columns) == ["batch", "policies", *names]
    assert np.isfinite(batches[names].to_numpy()).all()
    # batch 0 is policies 0 … 39: its Miller–Madow PIC is the estimator on those rows
    assert batches["pic_miller_madow"][0] == pic_miller_madow(independent_returns[:40], bins=METRICS.bins).pic
    # with i.i.d. returns PIC minus its null is centred on 0, not on PIC's bias (≈ 1 nat here)
    assert abs(batches["pic_minus_null"].mean()) < 0.3


def test_the_estimators_row_holds_every_registered_diagnostics_metric(tables):
    row = tables["estimators.parquet"].iloc[0]
    for metric in DEFAULT_REGISTRY.of_stage("diagnostics"):
        assert np.isfinite(row[metric.name]), metric.name
    assert row["pic_minus_null"] == pytest.approx(row["pic"] - row["pic_null_mean"], rel=1e-12)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"repeats": 1}, "diagnostics.repeats must be an integer >= 2, got 1"),
        ({"bins_sweep": (10, 1)}, r"diagnostics.bins_sweep must be a non-empty list of integers >= 2"),
        ({"subsample_fractions": (0.0, 1.0)}, r"diagnostics.subsample_fractions must be .* in \(0, 1\]"),
        ({"knn_neighbors": 0}, "diagnostics.knn_neighbors must be an integer >= 1, got 0"),
        ({"knn_max_samples": 10}, "diagnostics.knn_max_samples must be an integer >= 100, got 10"),
        ({"knn_episodes_per_policy": 3}, r"diagnostics.knn_episodes_per_policy must be an integer > "),
        ({"seed": -1}, "diagnostics.seed must be a non-negative integer, got -1"),
    ],
)
def test_invalid_settings_name_the_key(change, message):
    with pytest.raises(ConfigError, match=message):
        replace(DiagnosticsSettings(), **change).validate()


def test_the_key_follows_the_returns_the_estimator_settings_and_the_diagnostics_settings():
    base = diagnostics_key("rwg-a", METRICS, FAST)
    assert diagnostics_key("rwg-a", METRICS, FAST) == base
    assert diagnostics_key("rwg-b", METRICS, FAST) != base
    assert diagnostics_key("rwg-a", replace(METRICS, bins=2000), FAST) != base
    assert diagnostics_key("rwg-a", METRICS, replace(FAST, repeats=5)) != base
    # the bootstrap does not enter the diagnostics, so it does not enter their key
    assert diagnostics_key("rwg-a", replace(METRICS, resamples=99), FAST) == base


def test_the_stage_writes_its_tables_once_and_then_hits_the_cache(tmp_path):
    cache = Cache(tmp_path)
    request = RWGRequest(make_task("one_link_1m0", "dense"), NetworkSpec(), PriorSpec(),
                         RWGSettings(policies=20, episodes=6, seed=1))
    rwg, _ = run_rwg_stage(cache, request)
    first, hit_first = run_diagnostics_stage(cache, rwg, METRICS, FAST)
    second, hit_second = run_diagnostics_stage(cache, rwg, METRICS, FAST)
    assert (hit_first, hit_second) == (False, True)
    assert first.path == second.path and first.stage == "diagnostics"
    for name in FILES:
        assert not pd.read_parquet(first.file(name)).empty
    assert first.manifest["inputs"] == {"rwg": rwg.key}
    assert first.manifest["config"]["repeats"] == FAST.repeats
