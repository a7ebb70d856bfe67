"""Across tasks: pull every task's RWG and metrics artefacts, in study order."""

from __future__ import annotations

import logging
from contextlib import nullcontext
from dataclasses import dataclass

import pandas as pd

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.progress import stage_bar
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.metrics_stage import MetricsSettings, run_metrics_stage
from taskcomplexity.stages.rwg_stage import STAGE as RWG_STAGE
from taskcomplexity.stages.rwg_stage import RWGRequest, run_rwg_stage
from taskcomplexity.stages.stage_log import StageLog

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
    names = names or [r.task.task_id for r in requests]
    # the bar's total: tasks without an artefact yet (a cheap existence test; run_rwg_stage verifies)
    todo = [r for r in requests if force or not cache.path(RWG_STAGE, r.key).exists()]
    episodes = sum(r.settings.policies * r.settings.episodes for r in todo)
    rwg = StageLog("rwg")
    with stage_bar("rwg", episodes, "ep") if progress else nullcontext() as bar:
        for name, request in zip(names, requests, strict=True):
            if bar is not None:
                bar.set_postfix_str(name)
            with rwg.task(name) as record:
                record.artefact, record.hit = run_rwg_stage(cache, request, force=force, progress=bar or False)
    rwg.summarise()
    metrics = StageLog("metrics")
    with stage_bar("metrics", len(requests), "task") if progress else nullcontext() as bar:
        for name, request, returns in zip(names, requests, rwg.artefacts, strict=True):
            if bar is not None:
                bar.set_postfix_str(name)
            with metrics.task(name) as record:
                record.artefact, record.hit = run_metrics_stage(cache, returns, settings, label=request.label,
                                                                registry=registry, force=force)
            if bar is not None:
                bar.update()
    metrics.summarise()
    return [TaskMetrics(name, request, returns, artefact) for name, request, returns, artefact
            in zip(names, requests, rwg.artefacts, metrics.artefacts, strict=True)]


def metrics_frame(results: list[TaskMetrics]) -> pd.DataFrame:
    """One row per task (``task`` = its id): point estimates, details and bootstrap summaries."""
    return pd.concat([r.table("metrics.parquet").assign(task=r.task_id) for r in results], ignore_index=True)
