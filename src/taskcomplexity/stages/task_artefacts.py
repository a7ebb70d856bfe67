"""Across tasks: pull every task's RWG and metrics artefacts, in study order."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass

import pandas as pd

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.metrics_stage import MetricsSettings, study_metrics_of
from taskcomplexity.stages.rwg_stage import RWGRequest, study_returns

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

    Stage by stage: the RWG artefacts of every task, then their metrics; with ``progress``, one bar
    per stage (episodes, then tasks) naming the task at work. Each task's outcome is logged at DEBUG
    level (the run log), each stage's summary at INFO. ``names`` are the entries' ids (default: their
    task ids); ``registry`` holds the metrics estimated.
    """
    by_name = dict(zip(names or [r.task.task_id for r in requests], requests, strict=True))
    returns = study_returns(cache, by_name, force=force, progress=progress)
    metrics = study_metrics_of(cache, returns, {n: r.label for n, r in by_name.items()}, settings,
                               registry=registry, force=force, progress=progress)
    return task_metrics(by_name, returns, metrics)


def task_metrics(requests: Mapping[str, RWGRequest], returns: Mapping[str, Artefact],
                 metrics: Mapping[str, Artefact]) -> list[TaskMetrics]:
    """Each task's request, RWG and metrics artefacts together, in the order of ``requests``."""
    return [TaskMetrics(name, request, returns[name], metrics[name]) for name, request in requests.items()]


def metrics_frame(results: list[TaskMetrics]) -> pd.DataFrame:
    """One row per task (``task`` = its id): point estimates, details and bootstrap summaries."""
    return pd.concat([r.table("metrics.parquet").assign(task=r.task_id) for r in results], ignore_index=True)
