"""The configuration read once: Hydra's composed config → a study's typed, checked plan (:func:`read_plan`).

The study entry point turns the composed config into a :class:`StudyPlan` before any work: the study, every
declared stage's typed settings (:data:`taskcomplexity.stages.declared.STAGES`, each read from its config group
and checked against the study's tasks), each task's RWG request, the cache, and what the report needs (its
name, title, directory). This is the one module that reads the raw config: it hands plain data down, to
:mod:`taskcomplexity.study.compose` too, which composes each study entry through Hydra
(:func:`~taskcomplexity.study.compose.entry_base`: what every entry takes from the study's own config). Reading
the plan writes nothing: the chain checks that the cache and the outputs can be written before its first stage.
Below it, the chain (:mod:`taskcomplexity.study.chain`) and the report take the plan.

The single-stage commands read the little they need here too (:func:`metrics_settings_from_config`,
:func:`cache_from_config`, their task's request :func:`rwg_request_from_config`, the study's requests
:func:`study_requests`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from taskcomplexity.cli import job_overrides, sac_command, sweep_job_dir, user_overrides
from taskcomplexity.config import build, plain
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.cache import Cache, check_writable
from taskcomplexity.stages.declared import STAGES, check_registry
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.rwg_stage import STAGE as RWG
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study.compose import check_presets, entry_requests, request_of
from taskcomplexity.study_data import Study, StudyTask, plain_name, study_from_config
from taskcomplexity.tasks.from_config import task_from_config


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
        The artefact store (``paths.cache``; the chain checks it and ``paths.outputs`` writable before any work).
    force : bool
        Recompute every artefact even when its key exists.
    name : str
        The run's name, ``<study.name>[-<tag>]``: its report's directory.
    outputs : pathlib.Path
        ``paths.outputs``: reports go to ``<outputs>/reports/<name>/<run id>/``.
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
    """The plan of the study of a composed config, read once: the run's name and title, then the config as plain
    data (:func:`~taskcomplexity.config.plain`: nothing below reads Hydra's config), every stage's settings read
    and checked, each task composed, the checks that join them (each record's ``check``), and the cache's place;
    any problem is one ConfigError naming the key, before any work. Nothing is written (the cache's directories
    are made by the chain, :func:`taskcomplexity.study.chain.study_artefacts`)."""
    name = run_name(cfg)
    title = report_title(cfg.get("report") or {}, name)
    config = plain(cfg)
    typed = user_overrides()
    study = study_from_config(config["study"])
    settings = {stage.name: stage.settings_from(config[stage.group], study) for stage in STAGES
                if stage.group is not None}
    if settings[RWG].entry is not None:
        raise ConfigError(f"rwg.entry={settings[RWG].entry} is read by pipelines/rwg.py (one study task's RWG, a job "
                          "of a sweep over the ids); a study runs every task of its own")
    entries, requests = zip(*entry_requests(study, settings[RWG], config, typed), strict=True)
    settings[RWG] = requests[0].settings  # at the study's N and M
    for stage in STAGES:  # every stage's settings against the study's tasks, before any work
        if stage.check is not None:
            stage.check(settings[stage.name], study, requests, typed)
    check_registry(registry)
    cache = Cache(Path(config["paths"]["cache"]))
    return StudyPlan(study, entries, requests, settings, cache, force=bool(config["force"]), name=name,
                     outputs=Path(config["paths"]["outputs"]), title=title, sac_command=sac_command(),
                     job_dir=sweep_job_dir(), overrides=job_overrides())


def study_requests(cfg: Any, study: Study | None = None, settings=None, only: str | None = None
                   ) -> list[tuple[StudyTask, RWGRequest]]:
    """(StudyTask, RWGRequest) for every entry of the study of a composed config, in study order
    (:func:`taskcomplexity.study.compose.entry_requests`); ``settings``: the RWG settings (default: read from
    ``cfg.rwg``); ``only``: the id of the one entry to compose."""
    from taskcomplexity.rwg import RWGSettings

    study = study or study_from(cfg)
    settings = settings if settings is not None else build(RWGSettings, cfg.rwg, "rwg")
    return entry_requests(study, settings, plain(cfg), user_overrides(), only)


def report_title(node: Any, name: str) -> str:
    """The report's title: ``report.title`` (a string), else one from the run's name."""
    title = node.get("title")
    if title is not None and not isinstance(title, str):
        raise ConfigError(f"report.title must be a string or null (the study's own title), got {title!r}")
    return title or f"How hard is each task? ({name})"


def study_from(cfg: Any) -> Study:
    """The :class:`~taskcomplexity.study_data.Study` of a composed config (``cfg.study``), each entry's presets
    checked (:func:`~taskcomplexity.study.compose.check_presets`)."""
    study = study_from_config(plain(cfg.study))
    check_presets(study)
    return study


def metrics_settings_from_config(cfg: Any, study: Study | None = None) -> MetricsSettings:
    """The metrics settings of a composed config; with a ``study`` that has a published protocol, its
    (N, M, B) pinned, so that ``metrics.bins=auto`` is its B at its N and M."""
    return MetricsSettings.from_config(cfg.metrics, getattr(study, "published", None))


def run_name(cfg: Any) -> str:
    """Directory name of a study's tables and report: ``<study.name>-<tag>`` (e.g. seven_tasks-quick); both are
    plain names (:func:`~taskcomplexity.study_data.plain_name`), so the report stays under ``paths.outputs``."""
    name = plain_name("study.name", cfg["study"]["name"])
    tag = cfg.get("tag")
    if tag is None or tag == "":
        return name
    if isinstance(tag, int) and not isinstance(tag, bool):  # tag=2 is read as a number
        tag = str(tag)
    return f"{name}-{plain_name('tag', tag)}"


def cache_from_config(cfg: Any) -> Cache:
    """The cache under ``paths.cache``, after checking that it and ``paths.outputs`` can be written."""
    cache = Cache(Path(cfg["paths"]["cache"]))
    check_writable(Path(cfg["paths"]["outputs"]), cache)
    return cache


def rwg_request_from_config(cfg: Any, task=None) -> RWGRequest:
    """The :class:`RWGRequest` of a composed config (for ``task`` if given); ``backend=auto`` resolved."""
    from taskcomplexity.rwg import AUTO, BACKENDS, RWGSettings

    if str(cfg.backend) not in (AUTO, *BACKENDS):
        raise ConfigError(f"backend must be one of {[AUTO, *BACKENDS]}, got {cfg.backend!r}")
    settings = build(RWGSettings, cfg.rwg, "rwg")
    refuse_entry(cfg)
    if task is None:
        task = task_from_config(cfg)
        refuse_unread_overrides(task, user_overrides())
    return request_of(cfg, settings, task)


def refuse_entry(cfg: Any) -> None:
    """Refuse ``rwg.entry`` in a command other than ``pipelines/rwg.py`` (which reads it before anything else)."""
    entry = cfg.rwg.get("entry")
    if entry is not None:
        raise ConfigError(f"rwg.entry={entry} is read by pipelines/rwg.py only (one study task's RWG, a job of a "
                          "sweep over the ids)")


REACHING_ONLY = ("arm", "reward", "max_steps", "rwg.contacts")
"""Keys only the reaching arms read."""


def refuse_unread_overrides(task, typed: list[str]) -> None:
    """Refuse an override that the composed task would ignore (e.g. ``arm=…`` with ``task=gym``)."""
    from taskcomplexity.tasks.spec import TaskSpec

    if isinstance(task, TaskSpec):
        return
    for override in typed:
        key = override.partition("=")[0].lstrip("+~")
        if any(key == k or key.startswith(f"{k}.") for k in REACHING_ONLY):
            raise ConfigError(f"{override} is not read by task {task.task_id} (only the reaching arms read "
                              f"{', '.join(REACHING_ONLY)}; use task.max_steps or task.kwargs for a gymnasium task)")
