"""Across tasks: pull every task's RWG and metrics artefacts, in study order."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import pandas as pd

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.cache import Artefact, Cache, outcome
from taskcomplexity.stages.metrics_stage import MetricsSettings, run_metrics_stage
from taskcomplexity.stages.rwg_stage import RWGRequest, run_rwg_stage

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TaskMetrics:
    """One task's artefacts: ``task_id`` is the study entry's id."""

    task_id: str
    request: RWGRequest
    rwg: Artefact
    metrics: Artefact

    def table(self, name: str) -> pd.DataFrame:
        return pd.read_parquet(self.metrics.file(name))


def study_metrics(
    cache: Cache,
    requests: list[RWGRequest],
    settings: MetricsSettings,
    *,
    names: list[str] | None = None,
    registry: Registry = DEFAULT_REGISTRY,
    force: bool = False,
    progress: bool = False,
) -> list[TaskMetrics]:
    """Compute or reuse the RWG and metrics artefacts of every task, in the order given.

    ``names`` are the entries' ids (default: their task ids); ``registry`` holds the metrics estimated.
    """
    names = names or [r.task.task_id for r in requests]
    results = []
    for name, request in zip(names, requests, strict=True):
        started = time.perf_counter()
        rwg, rwg_hit = run_rwg_stage(cache, request, force=force, progress=progress)
        middle = time.perf_counter()
        metrics, hit = run_metrics_stage(cache, rwg, settings, label=request.label, registry=registry, force=force,
                                         progress=progress)
        log.info("%-26s rwg %s, metrics %s", name, outcome(rwg_hit, middle - started),
                 outcome(hit, time.perf_counter() - middle))
        results.append(TaskMetrics(name, request, rwg, metrics))
    return results


def metrics_frame(results: list[TaskMetrics]) -> pd.DataFrame:
    """One row per task (``task`` = its id): point estimates, details and bootstrap summaries."""
    return pd.concat([r.table("metrics.parquet").assign(task=r.task_id) for r in results], ignore_index=True)
