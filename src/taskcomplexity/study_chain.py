"""The stages of a study from a composed config: RWG → metrics → diagnostics → SAC → verdict.

The report reads what these produce (:func:`study_artefacts`); it is written by
:func:`taskcomplexity.study_run.run_study`, so that the chain never imports the report. It reads the
Hydra config (through :mod:`taskcomplexity.cli`), so it stands above the stages package, which does not.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import pandas as pd

from taskcomplexity.cli import run_name, sac_command, study_from, study_plan
from taskcomplexity.config import build
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.cache import Artefact
from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings, study_diagnostics
from taskcomplexity.stages.learning_path_stage import LearningPathSettings, study_learning_paths
from taskcomplexity.stages.occupancy_stage import OccupancySettings, study_occupancy
from taskcomplexity.stages.primitives_stage import PrimitivesSettings, study_primitives
from taskcomplexity.stages.stage_log import StageLog, outcome
from taskcomplexity.stages.task_artefacts import TaskMetrics, study_metrics
from taskcomplexity.stages.verdict_stage import run_verdict_stage
from taskcomplexity.study import Study

log = logging.getLogger(__name__)


def _sac_curves(cfg: Any, cache, results):
    """Learning curves of every task of the study (None when the SAC stage is unavailable, or when the
    study gives no task a SAC budget and ``sac.total_steps`` is not set).

    With ``sac.enabled=false`` nothing is trained: the curves the cache holds for these SAC settings
    are used, the tasks it lacks are listed in ``curves.attrs["sac_missing"]`` and the command that
    trains them in ``curves.attrs["sac_command"]``. Tasks SAC skips (discrete actions) are listed in
    ``curves.attrs["sac_skipped"]`` ({id: reason}).
    """
    enabled = bool(cfg.sac.get("enabled", True))
    try:
        from taskcomplexity.stages.sac_stage import study_sac_curves
    except ImportError:  # pragma: no cover - the SAC stage is optional at import time
        log.warning("SAC stage unavailable; the report will say so")
        return None
    study = study_from(cfg)  # each entry carries its SAC budget (sac_steps) and solved_return
    if not study.has_sac_budgets and cfg.sac.get("total_steps") is None:
        log.info("SAC: study %s gives no SAC budget (sac_steps) to any task, so it has no SAC reference", study.name)
        return None
    tasks = [(study.task(r.task_id), r.request.task) for r in results]
    curves = study_sac_curves(cache, tasks, cfg.sac, force=bool(cfg.force), progress=True, cached_only=not enabled)
    if not enabled:
        curves.attrs["sac_command"] = sac_command()
        missing = curves.attrs.get("sac_missing") or []
        if missing:
            log.info("SAC not trained (sac.enabled=false); no cached curves for %d of %d tasks: %s",
                     len(missing), len(tasks), curves.attrs["sac_command"])
    return curves


def _further_stages(cfg: Any, cache, results, sac_curves: pd.DataFrame, settings, registry: Registry,
                    force: bool) -> dict:
    """The stages built on the trained actors of SAC's artefacts: occupancy, learning path."""
    from taskcomplexity.stages.sac_stage import ACTORS_ATTR

    actors = sac_curves.attrs.get(ACTORS_ATTR, {})  # task id → (SAC key, actors.npz)
    tasks = {r.task_id: r.request for r in results}
    why = unavailable_actors(sac_curves)
    return {
        "occupancy": study_occupancy(cache, tasks, actors, build(OccupancySettings, cfg.occupancy, "occupancy"),
                                     registry=registry, force=force, progress=True, unavailable=why),
        "learning_path": study_learning_paths(cache, tasks, actors,
                                              build(LearningPathSettings, cfg.learning_path, "learning_path"),
                                              settings, registry=registry, force=force, progress=True,
                                              unavailable=why),
    }


def unavailable_actors(sac_curves: pd.DataFrame) -> dict[str, str]:
    """Why a task has no SAC actor (task id → reason), from the SAC stage's curves: SAC skips it (discrete
    actions), or it has no cached curves (``sac.enabled=false``)."""
    from taskcomplexity.stages.sac_stage import MISSING_ATTR, SKIPPED_ATTR

    why = {task_id: "SAC is not trained with sac.enabled=false, and the cache holds no SAC curves for it"
           for task_id in sac_curves.attrs.get(MISSING_ATTR) or []}
    for task_id, reason in (sac_curves.attrs.get(SKIPPED_ATTR) or {}).items():
        why[task_id] = f"SAC skips tasks with {reason}"
    return why


@dataclass(frozen=True)
class StudyArtefacts:
    """Every artefact of a study, in study order.

    Attributes
    ----------
    study : Study
        The study (tasks, relations, orders, reference scores).
    name : str
        Run name (``<study.name>-<tag>``): the report's directory.
    results : list of TaskMetrics
        Each task's RWG and metrics artefacts.
    diagnostics : dict of task id to Artefact
        Each task's diagnostics artefact.
    sac_curves : pandas.DataFrame or None
        Tidy SAC curves (None: SAC off, or a study of variants).
    further : dict of stage to dict of task id to Artefact
        The artefacts of the stages beyond the paper: those built on SAC's trained actor (``occupancy``,
        ``learning_path``) and the movement-primitive family's (``primitives``).
    verdict : Artefact
        The verdict stage's artefact.
    alpha : float
        Significance cut-off.
    """

    study: Study
    name: str
    results: list[TaskMetrics]
    diagnostics: dict[str, Artefact]
    sac_curves: pd.DataFrame | None
    verdict: Artefact
    alpha: float
    further: dict[str, dict[str, Artefact]] | None = None


def study_artefacts(cfg: Any, *, registry: Registry = DEFAULT_REGISTRY) -> StudyArtefacts:
    """Compute or reuse every artefact of the study of ``cfg`` (each stage logs its cache hits)."""
    plan = study_plan(cfg)  # every stage's settings checked, before any work
    study, entries, requests, settings, cache = plan.study, plan.entries, plan.requests, plan.settings, plan.cache
    force = bool(cfg.force)
    results = study_metrics(cache, list(requests), settings, names=[e.id for e in entries], registry=registry,
                            force=force, progress=True)
    diagnostics = study_diagnostics(cache, {r.task_id: r.rwg for r in results}, settings,
                                    build(DiagnosticsSettings, cfg.diagnostics, "diagnostics"), registry=registry,
                                    force=force, progress=True)
    sac = None if study.kind == "variants" else _sac_curves(cfg, cache, results)
    further = {} if sac is None else _further_stages(cfg, cache, results, sac, settings, registry, force)
    if study.kind != "variants":
        further["primitives"] = study_primitives(cache, {r.task_id: r.request for r in results}, settings,
                                                 PrimitivesSettings.from_config(cfg.primitives), registry=registry,
                                                 force=force, progress=True)
    stage = StageLog("verdict")
    with stage.task(study.name) as record:
        record.artefact, record.hit = run_verdict_stage(
            cache, study, {r.task_id: r.metrics for r in results}, diagnostics=diagnostics, sac_curves=sac,
            stages=further, alpha=settings.alpha, registry=registry, force=force)
    verdict = record.artefact
    log.info("%-12s %s: %s", "verdict", outcome(record.hit, record.seconds), verdict.file("verdict.parquet"))
    return StudyArtefacts(study, run_name(cfg), results, diagnostics, sac, verdict, settings.alpha, further)


def run_verdict(cfg: Any) -> Artefact:
    """Compute or reuse the study's verdict (and every artefact upstream of it); return its artefact."""
    return study_artefacts(cfg).verdict
