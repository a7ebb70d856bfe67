"""The stages a study runs before its verdict, one :class:`~taskcomplexity.stages.stage.Stage` record each, in
the order they run: RWG → metrics → diagnostics → SAC → occupancy → learning path → primitives.

The verdict (:data:`taskcomplexity.stages.verdict_stage.VERDICT`) closes the chain: it judges every record
here that says how (:class:`~taskcomplexity.stages.stage.Judged`), so it is declared in its own module, which
reads this one. A new stage is its module (``stages/<name>_stage.py``: settings, key, artefact, a function
over the study's tasks), its config group (``conf/<name>/default.yaml``, chosen in ``conf/config.yaml``'s
defaults) and one record below (README: "Add a stage").

Each record's ``run`` is a short adapter from the study's :class:`~taskcomplexity.stages.stage.StudyWork` (the
plan and what the stages before it returned) to the stage's own function; its ``check`` holds what the
stage's settings must satisfy given the study's tasks, checked when the plan is read, before any work.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

from taskcomplexity.errors import ConfigError
from taskcomplexity.rl.settings import SACSettings, sac_skip_reason, with_budget
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages import (
    diagnostics_stage,
    learning_path_stage,
    metrics_stage,
    occupancy_stage,
    primitives_stage,
    rwg_stage,
    sac_stage,
)
from taskcomplexity.stages.actor_stages import trained_actors, unavailable_actors
from taskcomplexity.stages.stage import SEEDS, Judged, Stage, StudyWork
from taskcomplexity.stages.task_artefacts import study_metrics_of, study_returns

log = logging.getLogger(__name__)

SAC_NEEDED = ("it needs a trained SAC actor for each task (SAC on: `make beyond`, a fifth of the budgets in about "
              "an hour; `make paper`; or `sac.enabled=true`)")


def _returns(work: StudyWork) -> dict:
    plan = work.plan
    return study_returns(plan.cache, plan.tasks, force=plan.force, progress=work.progress)


def _metrics(work: StudyWork) -> dict:
    plan = work.plan
    labels = {task_id: request.label for task_id, request in plan.tasks.items()}
    return study_metrics_of(plan.cache, work.done[rwg_stage.STAGE], labels, work.settings(metrics_stage.STAGE),
                            registry=work.registry, force=plan.force, progress=work.progress)


def _check_metrics(settings: metrics_stage.MetricsSettings, study, requests, typed) -> None:
    for request in requests:
        policies = request.settings.policies
        if settings.batches > policies // 2:
            raise ConfigError(f"metrics.batches={settings.batches} needs at least 2 policies per batch, but N = "
                              f"{policies} (rwg.policies or study.policies): allowed metrics.batches <= "
                              f"{max(policies // 2, 2)}, or more policies")


def _read_metrics(node: Any, study) -> metrics_stage.MetricsSettings:
    return metrics_stage.MetricsSettings.from_config(node, getattr(study, "published", None))


def _diagnostics(work: StudyWork) -> dict:
    plan = work.plan
    return diagnostics_stage.study_diagnostics(
        plan.cache, work.done[rwg_stage.STAGE], work.settings(metrics_stage.STAGE),
        work.settings(diagnostics_stage.STAGE), registry=work.registry, force=plan.force, progress=work.progress)


def _check_diagnostics(settings: diagnostics_stage.DiagnosticsSettings, study, requests, typed) -> None:
    episodes = min(request.settings.episodes for request in requests)
    if episodes <= settings.knn_neighbors:
        raise ConfigError(f"the diagnostics' k-NN estimate needs M > diagnostics.knn_neighbors = "
                          f"{settings.knn_neighbors} episodes per policy, but M = {episodes} (rwg.episodes or "
                          f"study.episodes): allowed M >= {settings.knn_neighbors + 1}")


def _sac(work: StudyWork):
    """Learning curves of every task (None for a study of variants, and when the study gives no task a SAC
    budget and ``sac.total_steps`` is not set).

    With ``sac.enabled=false`` nothing is trained: the curves the cache holds for these settings are used,
    the tasks it lacks are listed in ``curves.attrs["sac_missing"]`` and the command that trains them in
    ``curves.attrs["sac_command"]``. Tasks SAC skips (discrete actions) are listed in
    ``curves.attrs["sac_skipped"]`` ({id: reason}).
    """
    plan, settings = work.plan, work.settings(sac_stage.STAGE)
    study = plan.study
    if study.kind == "variants":
        return None
    if not study.has_sac_budgets and settings.total_steps is None:
        log.info("SAC: study %s gives no SAC budget (sac_steps) to any task, so it has no SAC reference", study.name)
        return None
    tasks = [(entry, request.task) for entry, request in zip(plan.entries, plan.requests, strict=True)]
    curves = sac_stage.study_sac_curves(plan.cache, tasks, settings, force=plan.force, progress=work.progress,
                                        cached_only=not settings.enabled)
    if not settings.enabled:
        curves.attrs["sac_command"] = plan.sac_command
        missing = curves.attrs.get(sac_stage.MISSING_ATTR) or []
        if missing:
            log.info("SAC not trained (sac.enabled=false); no cached curves for %d of %d tasks: %s",
                     len(missing), len(tasks), plan.sac_command)
    return curves


def _check_sac(settings: SACSettings, study, requests, typed: list[str]) -> None:
    if settings.entry is not None:
        raise ConfigError(f"sac.entry={settings.entry} is read by pipelines/sac.py (one study task's SAC runs, e.g. a "
                          "job of `make paper-jobs`); the study trains every task: drop it")
    if not settings.enabled or study.kind == "variants":
        return
    if not study.has_sac_budgets and settings.total_steps is None:
        enabled = [o for o in typed if o.partition("=")[0].lstrip("+~") == "sac.enabled"]
        if enabled:
            raise ConfigError(f"{enabled[-1]}: study {study.name} gives no SAC budget (sac_steps) to any task, so "
                              "it has no SAC reference; set sac.total_steps to train SAC on it")
        return
    for entry, request in zip(study.tasks, requests, strict=True):
        if sac_skip_reason(request.task) is None:
            with_budget(settings, entry.sac_steps, task_id=entry.id)


def _occupancy(work: StudyWork) -> dict:
    plan, curves = work.plan, work.done[sac_stage.STAGE]
    if curves is None:
        return {}
    return occupancy_stage.study_occupancy(
        plan.cache, plan.tasks, trained_actors(curves), work.settings(occupancy_stage.STAGE), registry=work.registry,
        force=plan.force, progress=work.progress, unavailable=unavailable_actors(curves))


def _learning_path(work: StudyWork) -> dict:
    plan, curves = work.plan, work.done[sac_stage.STAGE]
    if curves is None:
        return {}
    return learning_path_stage.study_learning_paths(
        plan.cache, plan.tasks, trained_actors(curves), work.settings(learning_path_stage.STAGE),
        work.settings(metrics_stage.STAGE), registry=work.registry, force=plan.force, progress=work.progress,
        unavailable=unavailable_actors(curves))


def _primitives(work: StudyWork) -> dict:
    plan = work.plan
    if plan.study.kind == "variants":
        return {}
    return primitives_stage.study_primitives(
        plan.cache, plan.tasks, work.settings(metrics_stage.STAGE), work.settings(primitives_stage.STAGE),
        registry=work.registry, force=plan.force, progress=work.progress)


def _read_primitives(node: Any, study) -> primitives_stage.PrimitivesSettings:
    return primitives_stage.PrimitivesSettings.from_config(node)


def _check_primitives(settings: primitives_stage.PrimitivesSettings, study, requests, typed) -> None:
    if settings.enabled and study.kind != "variants":
        for request in requests:
            settings.request(request)  # N, M and the backend checked before any work


STAGES = (
    Stage(rwg_stage.STAGE, rwg_stage.NUMERICS, (rwg_stage.RETURNS,), _returns, group="rwg", settings=RWGSettings),
    Stage(metrics_stage.STAGE, metrics_stage.NUMERICS, metrics_stage.FILES, _metrics, inputs=(rwg_stage.STAGE,),
          group="metrics", settings=metrics_stage.MetricsSettings, read=_read_metrics, check=_check_metrics,
          judged=Judged("metrics.parquet")),
    Stage(diagnostics_stage.STAGE, diagnostics_stage.NUMERICS, diagnostics_stage.FILES, _diagnostics,
          inputs=(rwg_stage.STAGE,), group="diagnostics", settings=diagnostics_stage.DiagnosticsSettings,
          check=_check_diagnostics, judged=Judged("estimators.parquet")),
    Stage(sac_stage.STAGE, sac_stage.NUMERICS, (sac_stage.CURVES,), _sac, group="sac", settings=SACSettings,
          check=_check_sac, judged=Judged(sac_stage.CURVES, sac_stage.CURVES, on=SEEDS)),
    Stage(occupancy_stage.STAGE, occupancy_stage.NUMERICS, occupancy_stage.FILES, _occupancy,
          inputs=(sac_stage.STAGE,), group="occupancy", settings=occupancy_stage.OccupancySettings,
          judged=Judged("occupancy.parquet"), missing=SAC_NEEDED),
    Stage(learning_path_stage.STAGE, learning_path_stage.NUMERICS, learning_path_stage.FILES, _learning_path,
          inputs=(sac_stage.STAGE,), group="learning_path", settings=learning_path_stage.LearningPathSettings,
          judged=Judged("learning_path.parquet"),
          missing=("it needs the snapshots of a SAC run for each task (SAC on: `make beyond`, a fifth of the budgets "
                   "in about an hour; `make paper`; or `sac.enabled=true`)")),
    Stage(primitives_stage.STAGE, primitives_stage.NUMERICS, primitives_stage.FILES, _primitives,
          inputs=(rwg_stage.STAGE,), group="primitives", settings=primitives_stage.PrimitivesSettings,
          read=_read_primitives, check=_check_primitives, judged=Judged("primitives.parquet"),
          missing="it needs reaching-arm tasks and `primitives.enabled=true`"),
)
"""Every stage before the verdict, in the order a study runs them."""


def judged_stages(stages: tuple[Stage, ...] = STAGES) -> Mapping[str, Judged]:
    """Stage name → how the verdict judges it, for every stage whose metrics it judges, in order."""
    return {stage.name: stage.judged for stage in stages if stage.judged is not None}


def check_registry(registry, stages: tuple[Stage, ...] = STAGES) -> None:
    """Refuse, in one line, a registry metric whose stage is no stage the verdict judges (a typo, or a stage
    that is not declared), naming the stages allowed."""
    judged = judged_stages(stages)
    for metric in registry:
        if metric.stage not in judged:
            raise ConfigError(f"metric {metric.name}: its stage must be one of {list(judged)} (the declared stages "
                              f"that estimate metrics), got {metric.stage!r}")
