"""The configuration read once: Hydra's composed config → a study's typed, checked plan (:func:`read_plan`).

The study entry point turns the composed config into a :class:`StudyPlan` before any work: the study, each
task's RWG request (each entry composed through Hydra, :mod:`taskcomplexity.study.compose`), every declared
stage's typed settings (:data:`taskcomplexity.stages.declared.STAGES`, each read from its config group and
checked against the study's tasks), the cache, and what the report needs (its name, title, directory).
Below it, nothing reads the raw config: the chain (:mod:`taskcomplexity.study.chain`) and the report take
the plan.

The single-stage commands read the little they need here too (:func:`metrics_settings_from_config`,
:func:`cache_from_config`; their task's request: :func:`taskcomplexity.study.compose.rwg_request_from_config`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from taskcomplexity.cli import job_overrides, sac_command, sweep_job_dir, user_overrides
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.cache import Cache, ensure_writable
from taskcomplexity.stages.declared import STAGES, check_registry
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.rwg_stage import STAGE as RWG
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study.compose import study_requests
from taskcomplexity.study_data import Study, StudyTask, study_from_config


@dataclass(frozen=True)
class StudyPlan:
    """A study read from a composed config and checked, before any work: what every stage will run.

    Attributes
    ----------
    study : Study
        Its tasks, relations, orders, reference scores and budgets.
    entries, requests : tuple
        Each study entry and its task's RWG request, in study order (entry i's request is ``requests[i]``).
    settings : mapping of stage name to settings
        Every declared stage's typed, validated settings (the RWG settings at the study's N and M).
    cache : Cache
        The artefact store (``paths.cache``; it and ``paths.outputs`` checked writable).
    force : bool
        Recompute every artefact even when its key exists.
    name : str
        The run's name, ``<study.name>[-<tag>]``: its report's directory.
    outputs : pathlib.Path
        ``paths.outputs``: reports go to ``<outputs>/reports/<name>/``.
    title : str
        The report's title (``report.title``, else from the run's name).
    sac_command : str
        The command that trains the SAC curves a run without SAC lacks (:func:`taskcomplexity.cli.sac_command`).
    job_dir : pathlib.Path or None
        The job's directory when this run is a job of a multirun (its report goes there), else None.
    overrides : tuple of str
        The job's overrides (a sweep's cell), recorded for the sweep's report.
    """

    study: Study
    entries: tuple[StudyTask, ...]
    requests: tuple[RWGRequest, ...]
    settings: Mapping[str, Any]
    cache: Cache
    force: bool = False
    name: str = ""
    outputs: Path = Path("outputs")
    title: str = ""
    sac_command: str = ""
    job_dir: Path | None = None
    overrides: tuple[str, ...] = ()

    @property
    def tasks(self) -> dict[str, RWGRequest]:
        """Study task id → its RWG request, in study order."""
        return {entry.id: request for entry, request in zip(self.entries, self.requests, strict=True)}


def read_plan(cfg: Any, *, registry: Registry = DEFAULT_REGISTRY) -> StudyPlan:
    """The plan of the study of a composed config: every stage's settings read and checked first, each
    task composed, then the checks that join them (:func:`check_study_settings`); any problem is one
    ConfigError naming the key, before any work."""
    study = study_from(cfg)
    settings = stage_settings(cfg, study)
    entries, requests = zip(*study_requests(cfg, study, settings[RWG]), strict=True)
    settings[RWG] = requests[0].settings  # at the study's N and M
    check_study_settings(study, requests, settings, user_overrides())
    check_registry(registry)
    name = run_name(cfg)
    return StudyPlan(study, entries, requests, settings, cache_from_config(cfg), force=bool(cfg.force), name=name,
                     outputs=Path(cfg.paths.outputs), title=report_title(cfg.report, name), sac_command=sac_command(),
                     job_dir=sweep_job_dir(), overrides=job_overrides())


def stage_settings(cfg: Any, study: Study) -> dict[str, Any]:
    """Every declared stage's typed settings, read from its config group (keys, types, ranges checked)."""
    return {stage.name: stage.settings_from(cfg[stage.group], study) for stage in STAGES if stage.group is not None}


def check_study_settings(study: Study, requests, settings: Mapping[str, Any], typed: list[str]) -> None:
    """Every stage's settings against the study's tasks (each record's ``check``: e.g. the metrics' batches
    against N, the diagnostics' k-NN against M, a SAC budget for every task SAC trains on), before any work:
    a bad value late in the chain must not cost the work before it. ``typed``: the command line's overrides."""
    for stage in STAGES:
        if stage.check is not None:
            stage.check(settings[stage.name], study, requests, typed)


def report_title(node: Any, name: str) -> str:
    """The report's title: ``report.title`` (a string), else one from the run's name."""
    title = node.get("title")
    if title is not None and not isinstance(title, str):
        raise ConfigError(f"report.title must be a string or null (the study's own title), got {title!r}")
    return title or f"How hard is each task? ({name})"


def study_from(cfg: Any) -> Study:
    """The :class:`~taskcomplexity.study_data.Study` of a composed config (``cfg.study``)."""
    return study_from_config(cfg.study)


def metrics_settings_from_config(cfg: Any, study: Study | None = None) -> MetricsSettings:
    """The metrics settings of a composed config; with a ``study`` that has a published protocol, its
    (N, M, B) pinned, so that ``metrics.bins=auto`` is its B at its N and M."""
    return MetricsSettings.from_config(cfg.metrics, getattr(study, "published", None))


def run_name(cfg: Any) -> str:
    """Directory name of a study's tables and report: ``<study.name>-<tag>`` (e.g. seven_tasks-quick)."""
    tag = cfg.get("tag")
    return f"{cfg.study.name}-{tag}" if tag else str(cfg.study.name)


def cache_from_config(cfg: Any) -> Cache:
    """The cache under ``paths.cache``, after checking that it and ``paths.outputs`` can be written."""
    ensure_writable(Path(cfg.paths.outputs))
    ensure_writable(Path(cfg.paths.cache), key="paths.cache")
    return Cache(Path(cfg.paths.cache))
