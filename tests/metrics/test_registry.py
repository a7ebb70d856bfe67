"""The metric registry: every consumer iterates over it, so a metric added through it alone reaches the
metrics artefact, the verdict and the report — and changes the cache keys, so nothing stale is served."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import DEFAULT_REGISTRY, Metric, Registry, bootstrap_indices
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report.build import build_report
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.metrics_stage import MetricsSettings, metrics_key
from taskcomplexity.stages.rwg_stage import RWGRequest, load_returns
from taskcomplexity.stages.task_artefacts import study_metrics
from taskcomplexity.stages.verdict_stage import run_verdict_stage
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.spec import task_from_id

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
TASKS = ("two_link-dense", "two_link-sparse", "one_link_1m0-dense")
SETTINGS = MetricsSettings(bins=500, resamples=12)


def best_mean(sample) -> float:
    """The toy metric: the best policy's mean return (sum of rewards)."""
    return float(sample.returns.mean(axis=1).max())


TOY = Metric("best_mean", "best policy mean", "best Mₙ", "sum of rewards", higher_is_easier=True,
             family="random policies", stage="metrics", compute=best_mean, bootstrapped=True, batched=True)


@pytest.fixture(scope="module")
def toy_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("toy")
    cache = Cache(root / "cache")
    registry = DEFAULT_REGISTRY.with_metrics(TOY)
    requests = [RWGRequest(task_from_id(t), NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=6))
                for t in TASKS]
    results = study_metrics(cache, requests, SETTINGS, names=list(TASKS), registry=registry)
    verdict, _ = run_verdict_stage(cache, SEVEN_TASKS, {r.task_id: r.metrics for r in results}, registry=registry)
    index = build_report(results, study=SEVEN_TASKS, verdict=verdict, diagnostics=None, sac_curves=None,
                         out_dir=root / "report", title="Toy", registry=registry)
    return cache, results, verdict, index


def test_a_toy_metric_reaches_the_metrics_artefact_with_its_bootstrap_and_batches(toy_study):
    _, results, _, _ = toy_study
    returns = load_returns(results[0].rwg)
    row = results[0].table("metrics.parquet").iloc[0]
    assert row["best_mean"] == returns.mean(axis=1).max()
    batches = results[0].table("batches.parquet")
    assert batches["best_mean"].tolist() == [returns[4 * b: 4 * b + 4].mean(axis=1).max() for b in range(5)]
    draws = results[0].table("bootstrap.parquet")["best_mean"].to_numpy()
    expected = [returns[i].mean(axis=1).max() for i in bootstrap_indices(20, resamples=12, seed=SETTINGS.seed)]
    np.testing.assert_array_equal(draws, expected)
    assert row["best_mean_sd"] == pytest.approx(np.std(expected, ddof=1))


def test_a_toy_metric_is_judged_on_every_relation(toy_study):
    _, _, verdict, _ = toy_study
    table = pd.read_parquet(verdict.file("verdict.parquet"))
    relations = SEVEN_TASKS.relations_among(TASKS)
    toy = table[table["metric"] == "best_mean"]
    assert len(toy) == len(relations) == 2
    assert (toy["samples_easier"] == 5).all()  # tested on its own batch estimates
    summary = pd.read_parquet(verdict.file("summary.parquet"))
    assert summary["metric"].tolist()[-1] == "best_mean"


def test_a_toy_metric_is_shown_in_the_report(toy_study):
    _, _, _, index = toy_study
    shown = pd.read_csv(index.parent / "tables" / "verdict.csv")
    assert (shown["Metric"] == "best policy mean").sum() == 2
    assert "best policy mean" in pd.read_csv(index.parent / "tables" / "table1.csv").columns
    assert "best Mₙ" in pd.read_csv(index.parent / "tables" / "verdict_matrix.csv").columns


def test_adding_a_metric_changes_the_stage_keys_so_no_stale_artefact_is_served(toy_study):
    cache, results, _, _ = toy_study
    extended = DEFAULT_REGISTRY.with_metrics(TOY)
    rwg_key = results[0].rwg.key
    assert metrics_key(rwg_key, SETTINGS, extended) == results[0].metrics.key
    assert metrics_key(rwg_key, SETTINGS, DEFAULT_REGISTRY) != results[0].metrics.key
    plain = study_metrics(cache, [results[0].request], SETTINGS, names=[TASKS[0]])
    assert "best_mean" not in plain[0].table("metrics.parquet").columns
    renamed = Metric(**{**TOY.__dict__, "version": 2})
    assert metrics_key(rwg_key, SETTINGS, DEFAULT_REGISTRY.with_metrics(renamed)) != results[0].metrics.key


def test_the_default_registry_is_immutable_and_names_are_unique():
    before = DEFAULT_REGISTRY.names
    extended = DEFAULT_REGISTRY.with_metrics(TOY)
    assert DEFAULT_REGISTRY.names == before and "best_mean" not in DEFAULT_REGISTRY
    assert extended.names == (*before, "best_mean")
    with pytest.raises(ValueError, match="'best_mean' is declared twice"):
        extended.with_metrics(TOY)
    with pytest.raises(ValueError, match="'h_r' is declared twice"):
        DEFAULT_REGISTRY.with_metrics(Metric("h_r", "H", "H", "nats", True, "x", "metrics", compute=best_mean))
    with pytest.raises(AttributeError):
        DEFAULT_REGISTRY.metrics = ()  # frozen


def test_a_metric_declaration_is_checked():
    with pytest.raises(ValueError, match="stage must be a stage's name .* got 'Metrics stage'"):
        Metric("m", "M", "M", "", True, "x", "Metrics stage", compute=best_mean)
    with pytest.raises(ValueError, match="Metric.name must be lower-case .* got 'Bad name'"):
        Metric("Bad name", "M", "M", "", True, "x", "metrics", compute=best_mean)
    with pytest.raises(ValueError, match="a SAC metric has seeds"):
        Metric("m", "M", "M", "", True, "x", "sac", compute=best_mean, batched=True)


def test_a_metric_of_a_stage_the_verdict_does_not_judge_is_refused_when_the_plan_is_read():
    from taskcomplexity.errors import ConfigError
    from taskcomplexity.stages.declared import STAGES, check_registry, judged_stages

    check_registry(DEFAULT_REGISTRY)  # every default metric's stage is declared and judged
    judged = list(judged_stages())
    unjudged = [stage.name for stage in STAGES if stage.judged is None]
    assert judged and unjudged and not set(judged) & set(unjudged)
    for stage in (*unjudged, "metrix"):  # a declared stage that estimates no metric; a typo
        with pytest.raises(ConfigError, match=re.escape(f"metric m: its stage must be one of {judged}") + f".*, got '{stage}'"):
            check_registry(DEFAULT_REGISTRY.with_metrics(Metric("m", "M", "M", "", True, "x", stage, compute=best_mean)))


def test_every_default_metric_states_its_direction_family_stage_and_why():
    assert isinstance(DEFAULT_REGISTRY, Registry) and len(set(DEFAULT_REGISTRY.names)) == len(DEFAULT_REGISTRY)
    for metric in DEFAULT_REGISTRY:
        assert metric.family and metric.why and metric.label and metric.short, metric.name
    assert [m.name for m in DEFAULT_REGISTRY if m.primary] == ["pic", "poic"]
    assert {m.name for m in DEFAULT_REGISTRY if m.quantity} == {"pic", "pic_miller_madow", "pic_knn",
                                                                 "pic_minus_null"}
    from taskcomplexity.stages.declared import judged_stages

    assert {m.stage for m in DEFAULT_REGISTRY} <= set(judged_stages())  # each a declared stage the verdict judges


def test_every_information_estimate_has_a_permutation_null_or_says_why_not():
    # PIC-like values (checked against a ceiling ln N, or of the quantity I(Θ; R)) are information estimates
    informations = [m for m in DEFAULT_REGISTRY if m.information is not None
                    and (m.information.ceiling or m.quantity == "I(Θ; R)")]
    assert {"pic", "pic_miller_madow", "pic_knn", "path_pic", "dmp_pic"} <= {m.name for m in informations}
    for m in informations:
        assert bool(m.information.null) != bool(m.information.no_null), m.name  # one or the other, never both
