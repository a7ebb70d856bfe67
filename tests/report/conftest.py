"""Real stages at smoke size: RWG → metrics → diagnostics → verdict → report, into a temporary directory."""

from __future__ import annotations

from pathlib import Path

import pytest

from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings, study_diagnostics
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.task_artefacts import study_metrics
from taskcomplexity.stages.verdict_stage import run_verdict_stage

SETTINGS = MetricsSettings(bins=1000, resamples=20)
DIAGNOSTICS = DiagnosticsSettings(repeats=4, knn_max_samples=2000)


@pytest.fixture(scope="module")
def run_stages():
    """``run_stages(root, study, requests, *, diagnostics=True, sac_curves=None, registry=..., settings=SETTINGS)``
    → artefacts.

    Returns a dict with ``cache``, ``results``, ``diagnostics`` (or None) and ``verdict`` (the artefact).
    """

    def run(root: Path, study, requests, *, diagnostics=True, sac_curves=None, registry=DEFAULT_REGISTRY,
            settings=SETTINGS):
        cache = Cache(Path(root) / "cache")
        results = study_metrics(cache, list(requests), settings, names=list(study.ids)[: len(requests)],
                                registry=registry)
        found = None
        if diagnostics:
            found = study_diagnostics(cache, {r.task_id: r.rwg for r in results}, settings, DIAGNOSTICS,
                                      registry=registry)
        verdict, _ = run_verdict_stage(cache, study, {r.task_id: r.metrics for r in results}, diagnostics=found,
                                       sac_curves=sac_curves, alpha=settings.alpha, registry=registry)
        return {"cache": cache, "results": results, "diagnostics": found, "verdict": verdict}

    return run


@pytest.fixture(scope="session")
def scored_study():
    """Three gymnasium tasks with a learning algorithm's scores (A_max, A_avg): Score(A), Score(R) and correlations."""
    from taskcomplexity.study_data import study_from_config

    return study_from_config({
        "name": "scored",
        "tasks": [{"id": "cart", "env_id": "CartPole-v1"}, {"id": "pend", "env_id": "Pendulum-v1"},
                  {"id": "car", "env_id": "MountainCarContinuous-v0"}],
        "algorithm_scores": {"cart": {"max": 500.0, "average": 480.0}, "pend": {"max": -130.0, "average": -570.0},
                             "car": {"max": 95.9, "average": 12.9}},
        "published": {"policies": 1000, "episodes": 1000, "bins": 100_000, "source": "a paper", "tables": {
            "printed": {"source": "its table", "values": {"cart": {"pic": 1.2, "score_a": 0.97}, "pend": {"pic": 3.7}},
                        "correlations": {"score_a": {"poic": [0.807, 0.001], "pic": [-0.295, 0.328]}}}}},
    })


@pytest.fixture(scope="session")
def table1_metric_columns():
    """Table 1's columns after the task's, read from the registry: each bootstrapped metric of the metrics stage
    by its label, and beside one with a permutation null (not net of it) its null share."""
    columns = []
    for m in DEFAULT_REGISTRY.of_stage("metrics"):
        if m.bootstrapped:
            columns.append(m.label)
            if m.information is not None and m.information.null and not m.information.net_of_null:
                columns.append(f"{m.short} null share")
    return columns
