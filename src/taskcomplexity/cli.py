"""Glue between Hydra entry points and the library: config → dataclasses, errors → one line.

Entry points call :func:`check_overrides` before Hydra parses the command line (so an unknown config
group option is reported in one line, not a traceback) and wrap their task function with
:func:`one_line_errors`.
"""

from __future__ import annotations

import dataclasses
import errno
import functools
import logging
import os
import re
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf
from omegaconf.errors import InterpolationKeyError

from taskcomplexity.config import build
from taskcomplexity.errors import ConfigError, TaskComplexityError
from taskcomplexity.tasks.from_config import task_from_config

CONF_DIR = Path(str(resources.files("taskcomplexity") / "conf"))
"""The packaged Hydra configs (``taskcomplexity/conf``, shipped as package data): every entry point's
primary config directory, in a source checkout and in an installed package alike."""
GROUPS = ("task", "arm", "reward", "prior", "network", "rwg", "metrics", "diagnostics", "occupancy", "learning_path",
          "primitives", "sac", "report", "study", "experiment")
EXIT_BAD_INPUT = 2
EXIT_DISK_FULL = 3
EXIT_INTERRUPTED = 130

log = logging.getLogger("taskcomplexity")


def fail(message: str) -> None:
    """Print ``error: message`` on one line to stderr and exit with status 2."""
    print(f"error: {message}", file=sys.stderr, flush=True)
    raise SystemExit(EXIT_BAD_INPUT)


def search_dirs(argv: list[str], conf_dir: Path = CONF_DIR) -> list[Path]:
    """The packaged config directory and every ``file://`` directory of a ``hydra.searchpath`` override."""
    dirs = [conf_dir]
    for arg in argv[1:]:
        name, _, value = arg.partition("=")
        if name.lstrip("+~") == "hydra.searchpath":
            for item in value.strip("[]").split(","):
                item = item.strip().strip("'\"")
                if item.startswith("file://"):
                    dirs.append(Path(item[len("file://"):]))
    return dirs


def check_overrides(argv: list[str], conf_dir: Path = CONF_DIR) -> None:
    """Refuse ``group=option`` overrides whose option file does not exist, naming the allowed ones.

    Options are looked up in the packaged configs and in the directories a ``hydra.searchpath``
    override adds (a researcher's own studies and task presets).
    """
    dirs = search_dirs(argv, conf_dir)
    check_output_paths(argv)
    for arg in argv[1:]:
        if arg.startswith("-") or "=" not in arg:
            continue
        name, _, value = arg.partition("=")
        name = name.lstrip("+~")
        if name not in GROUPS or not (conf_dir / name).is_dir():
            continue
        allowed = sorted({p.stem for d in dirs for p in (d / name).glob("*.yaml")})
        for option in value.split(","):
            if option in ("", "null") and name == "experiment":
                continue
            if option.startswith(("glob(", "range(", "choice(")):
                continue
            if option not in allowed:
                fail(f"{name}={option} is not a known option (allowed: {', '.join(allowed)})")
    problem = unknown_keys(argv, dirs)
    if problem:
        fail(problem)


def check_output_paths(argv: list[str]) -> None:
    """Refuse, in one line, output and cache paths that cannot be written, however they are given
    (``paths.outputs=…``, ``paths.cache=…`` or ``TASKCOMPLEXITY_OUTPUTS``), before Hydra creates its run
    directory there."""
    from taskcomplexity.stages.cache import ensure_writable

    given = dict(arg.lstrip("+~").split("=", 1) for arg in argv[1:] if "=" in arg and not arg.startswith("-"))
    outputs = given.get("paths.outputs") or os.environ.get("TASKCOMPLEXITY_OUTPUTS") or "outputs"
    checks = [("paths.outputs", outputs)]
    if "paths.cache" in given:
        checks.append(("paths.cache", given["paths.cache"]))
    for key, value in checks:
        if "," in value or "$" in value:  # a sweep or an interpolation: Hydra resolves it per job
            continue
        try:
            ensure_writable(Path(value), key=key)
        except TaskComplexityError as err:
            fail(str(err))


FREE_FORM = ("task.kwargs", "study.reference", "study.algorithm_scores", "study.orders")
"""Config nodes whose keys are the user's own (``+task.kwargs.noise=0.3``, ``+study.reference.pend=1``): the
study checks its own (every id must be a task of the study)."""


def unknown_keys(argv: list[str], dirs: list[Path]) -> str | None:
    """One line naming the first override that sets a key no stage reads, or None.

    Composes the config with every non-sweep override (what Hydra will do), so an unknown key
    (``rwg.polices=10``) is named with the keys allowed beside it; a ``+key`` that adds a key is
    accepted only inside a free-form node (:data:`FREE_FORM`).
    """
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    lines = [a for a in argv[1:] if "=" in a and not a.startswith("-")]
    try:
        parsed = OverridesParser.create().parse_overrides(lines)
    except HydraException as err:
        return " ".join(str(err).split())
    chosen = [o for o in parsed if not o.is_sweep_override()]
    for override in chosen:
        key = override.key_or_group
        if override.is_add() and not any(key.startswith(f"{node}.") for node in FREE_FORM):
            return (f"{override.input_line}: {key} is not a key any stage reads ('+' adds keys only to "
                    f"{', '.join(FREE_FORM)}; remove it or check its spelling)")
    searchpath = [o.input_line for o in chosen if o.key_or_group == "hydra.searchpath"]
    settings = [o.input_line for o in chosen if not o.key_or_group.startswith("hydra")]
    if GlobalHydra.instance().is_initialized():
        return None
    try:
        with initialize_config_dir(config_dir=str(dirs[0]), version_base="1.3"):
            compose("config", overrides=searchpath + settings)
    except (HydraException, OmegaConfBaseException) as err:
        cause = err.__cause__ if err.__cause__ is not None else err
        full_key = getattr(cause, "full_key", None)
        if full_key and "not in struct" in str(cause):
            parent = full_key.rpartition(".")[0]
            try:
                with initialize_config_dir(config_dir=str(dirs[0]), version_base="1.3"):
                    dotted = re.sub(r"\[(\d+)\]", r".\1", full_key)
                    kept = [o.input_line for o in chosen if not o.key_or_group.startswith("hydra")
                            and o.key_or_group != dotted]
                    base = compose("config", overrides=searchpath + kept)
                node = OmegaConf.select(base, parent) if parent else base
                allowed = ", ".join(sorted(str(k) for k in node.keys()))
            except Exception:  # noqa: BLE001 - the message stays useful without the list
                allowed = "see the config group's file"
            return f"{full_key} is not a known key (allowed: {allowed})"
        return " ".join(str(cause).split())
    return None


def missing_interpolation(err: InterpolationKeyError) -> str:
    """One line for a ``${key}`` the composed config does not hold (the key that asked, what it wanted)."""
    wanted = str(err.msg).split("'")[1] if "'" in str(err.msg) else str(err.msg)
    line = f"{err.full_key} = ${{{wanted}}}, but the config has no {wanted}"
    if wanted.startswith("study.published."):
        line += (" (experiment=published runs at the scale of the study's published table: give the study a "
                 "`published: {policies, episodes, bins}` block, or set rwg.policies, rwg.episodes and metrics.bins)")
    return line


def one_line_errors(fn):
    """Entry points only: the project's input errors become one line and exit status 2.

    Only :class:`~taskcomplexity.errors.TaskComplexityError` (bad config values, unknown ids, damaged
    artefacts) is shortened; anything else is a bug and keeps its traceback (exit status 1).
    ``HYDRA_FULL_ERROR=1`` shows the traceback of input errors too. Two faults are not bugs and end
    in one line too, with the finished work kept for the rerun: Ctrl-C (exit 130) and a full disk
    (exit 3).
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        logging.captureWarnings(True)  # warnings go to the run log (conf/hydra/job_logging), not the console
        try:
            return fn(*args, **kwargs)
        except TaskComplexityError as err:
            if os.environ.get("HYDRA_FULL_ERROR") == "1":
                raise
            fail(str(err))
        except InterpolationKeyError as err:  # a ${…} of the composed config names a key it does not have
            if os.environ.get("HYDRA_FULL_ERROR") == "1":
                raise
            fail(missing_interpolation(err))
        except KeyboardInterrupt:
            print("interrupted; rerun the same command to resume", file=sys.stderr, flush=True)
            raise SystemExit(EXIT_INTERRUPTED) from None
        except OSError as err:
            if err.errno != errno.ENOSPC and "No space left on device" not in str(err):
                raise
            where = err.filename or f"the outputs directory {_outputs_of(args)}"
            print(f"error: disk full while writing {where}; free some space and rerun the same command to resume",
                  file=sys.stderr, flush=True)
            raise SystemExit(EXIT_DISK_FULL) from None

    return wrapper


def _outputs_of(args: tuple) -> str:
    """The absolute ``paths.outputs`` of an entry point's config (its first argument), for messages."""
    try:
        return os.path.abspath(str(OmegaConf.select(args[0], "paths.outputs", throw_on_missing=True)))
    except Exception:  # noqa: BLE001 - no config, or one without a resolvable paths.outputs
        return os.path.abspath(os.environ.get("TASKCOMPLEXITY_OUTPUTS", "outputs"))


def sampler_from_config(cfg: Any):
    """(the network's spec, of its family, and the PriorSpec) of a composed config."""
    from taskcomplexity.policies.families import network_from_config
    from taskcomplexity.policies.mlp import PriorSpec

    return network_from_config(cfg.network), build(PriorSpec, cfg.prior, "prior")


def rwg_request_from_config(cfg: Any, task=None):
    """The :class:`RWGRequest` of a composed config (for ``task`` if given); ``backend=auto`` resolved."""
    from taskcomplexity.rwg import AUTO, BACKENDS, RWGSettings, resolve_backend
    from taskcomplexity.stages.rwg_stage import RWGRequest

    if str(cfg.backend) not in (AUTO, *BACKENDS):
        raise ConfigError(f"backend must be one of {[AUTO, *BACKENDS]}, got {cfg.backend!r}")
    if task is None:
        task = task_from_config(cfg)
        refuse_unread_overrides(task, user_overrides())
    network, prior = sampler_from_config(cfg)
    settings = build(RWGSettings, cfg.rwg, "rwg")
    return RWGRequest(task, network, prior, settings, resolve_backend(task, str(cfg.backend), network))


def refuse_unread_groups(typed: list[str], unread: tuple[str, ...], command: str, instead: str) -> None:
    """Refuse, in one line, a typed override of a config node ``command`` does not read (e.g. ``study.…``
    for the RWG stage of one task), naming the command that reads it."""
    for override in typed:
        key = override.partition("=")[0].lstrip("+~")
        if any(key == node or key.startswith(f"{node}.") for node in unread):
            raise ConfigError(f"{override} is not read by {command} ({instead} reads it)")


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


def metrics_settings_from_config(cfg: Any, study=None):
    """The metrics settings of a composed config; with a ``study`` that has a published protocol, its
    (N, M, B) pinned, so that ``metrics.bins=auto`` is its B at its N and M."""
    from taskcomplexity.stages.metrics_stage import MetricsSettings

    node = {k: v for k, v in dict(cfg.metrics).items() if k != "scope"}
    settings = build(MetricsSettings, node, "metrics")
    published = getattr(study, "published", None)
    if published is not None:
        settings = dataclasses.replace(settings, pinned=(published.policies, published.episodes, published.bins))
    return settings


def study_from(cfg: Any):
    """The :class:`~taskcomplexity.study.Study` of a composed config (``cfg.study``)."""
    from taskcomplexity.study import study_from_config

    return study_from_config(cfg.study)


TASK_GROUPS = ("task", "arm", "reward", "prior", "network")
"""Config groups a study entry may choose for itself."""


def user_overrides() -> list[str]:
    """The overrides typed on the command line of the running Hydra app (none outside an app)."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return []
    overrides = HydraConfig.get().overrides
    return [*overrides.task, *(o for o in overrides.hydra if o.lstrip("+~").startswith("hydra.searchpath"))]


def _typed_groups(typed: list[str]) -> set[str]:
    """The config groups the command line chooses (``network=…``, not ``network.hidden=…``)."""
    return {o.partition("=")[0].lstrip("+~") for o in typed} & set(TASK_GROUPS)


def study_family(study, typed: list[str]) -> dict[str, str]:
    """The study's ``network``/``prior`` options that apply: those the command line does not choose."""
    chosen = _typed_groups(typed)
    return {g: getattr(study, g) for g in ("network", "prior") if getattr(study, g) is not None and g not in chosen}


def _entry_overrides(entry, typed: list[str], where: str, family: dict[str, str] | None = None) -> list[str]:
    """Compose overrides of one study entry: the user's task-level overrides, then the study's policy
    family (``family``: group → option, for the groups neither the entry nor the command line chooses),
    then the entry's choices.

    A group the entry chooses for itself cannot also be chosen on the command line: that override
    would be silently ignored, so it is refused.
    """
    chosen = {g for g in TASK_GROUPS if g in entry.selection}
    if "env_id" in entry.selection:
        chosen.add("task")
    forwarded = []
    for override in typed:
        key = override.partition("=")[0].lstrip("+~")
        if key in chosen:
            raise ConfigError(f"{override} conflicts with {where} ({entry.id}), which chooses its own {key}; "
                              f"drop the override or edit the study")
        forwarded.append(override)
    own = [f"{g}={entry.selection[g]}" for g in TASK_GROUPS if g in entry.selection]
    if "env_id" in entry.selection and "task" not in entry.selection:
        own.insert(0, "task=gym")
    studied = [f"{g}={option}" for g, option in (family or {}).items() if g not in chosen]
    return forwarded + studied + own


def _compose(overrides: list[str], where: str):
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    try:
        if GlobalHydra.instance().is_initialized():
            return compose("config", overrides=overrides)
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            return compose("config", overrides=overrides)
    except (HydraException, OmegaConfBaseException) as err:
        message = " ".join(str(err).split())
        raise ConfigError(f"{where}: {message}") from err


def entry_config(cfg: Any, entry, typed: list[str], where: str, family: dict[str, str] | None = None):
    """The composed config of one study entry: ``typed`` overrides, the study's policy ``family``
    (:func:`study_family`), then the entry's own choices.

    What neither the entry nor the study's family chooses (backend, the reaching arms' max_steps,
    prior and network) comes from the study's own composed config ``cfg``, so values set there, by
    overrides or in code, reach every task.
    """
    from omegaconf import open_dict

    family = family or {}
    node = _compose(_entry_overrides(entry, typed, where, family), where)
    with open_dict(node):
        node.backend, node.max_steps = cfg.backend, cfg.max_steps
        for group in ("prior", "network"):
            if group not in entry.selection and group not in family:
                node[group] = cfg[group]
        for key in ("env_id", "kwargs", "max_steps"):
            if key in entry.selection:
                node.task[key] = entry.selection[key]
    return node


def _rwg_group_value(key: str, typed: list[str]) -> Any:
    """``rwg.<key>`` as the chosen ``rwg`` group file gives it (before experiments and overrides), or None."""
    from hydra.core.hydra_config import HydraConfig

    choice = "default"
    if HydraConfig.initialized():
        choice = HydraConfig.get().runtime.choices.get("rwg", choice)
    choice = next((o.partition("=")[2] for o in typed if o.partition("=")[0].lstrip("+~") == "rwg"), choice)
    for directory in search_dirs(sys.argv):  # the first in Hydra's search path wins
        path = directory / "rwg" / f"{choice}.yaml"
        if path.is_file():
            return OmegaConf.load(path).get(key)
    return None


def study_scale(cfg: Any, study, typed: list[str]) -> dict[str, int]:
    """N and M that replace ``rwg.policies``/``rwg.episodes`` for every entry of ``study`` (logged).

    A study file may give its own N, M (``study.policies``, ``study.episodes``: classic_control's
    1000 × 1000); they apply unless ``rwg.policies``/``rwg.episodes`` is set explicitly, typed on the
    command line or by an experiment overlay (``experiment=smoke``'s 10 × 4) — a value other than the
    ``rwg`` group's own — which then wins, and the log says so. A typed ``study.policies`` always applies;
    typing it beside a different ``rwg.policies`` is refused.
    """
    typed_keys = {o.partition("=")[0].lstrip("+~"): o for o in typed}
    scale = {}
    for key in ("policies", "episodes"):
        own = getattr(study, key)
        if own is None:
            continue
        given = cfg.rwg[key]
        if f"study.{key}" in typed_keys:
            if f"rwg.{key}" in typed_keys and given != own:
                raise ConfigError(f"{typed_keys[f'rwg.{key}']} and {typed_keys[f'study.{key}']} disagree: give one "
                                  f"(study.{key} sets every task of the study, rwg.{key} wins over the study file)")
            scale[key] = own
        elif f"rwg.{key}" in typed_keys or given != _rwg_group_value(key, typed):
            if given != own:
                how = "typed on the command line" if f"rwg.{key}" in typed_keys else "set by the experiment"
                log.info("rwg.%s=%s (%s) wins over study.%s=%s of study %s, for every task", key, given, how, key,
                         own, study.name)
        else:
            scale[key] = own
    return scale


def study_requests(cfg: Any, study=None) -> list[tuple[Any, Any]]:
    """(StudyTask, RWGRequest) for every entry of the study, in study order.

    Each entry is composed with Hydra's compose API from the packaged configs (and the user's search
    path): the entry's own choices (``task``, ``env_id``, ``kwargs``, ``max_steps``, ``arm``,
    ``reward``, ``prior``, ``network``) over the command line's overrides, so an override such as
    ``arm.links.0.mass=7`` reaches every study task. N and M of every entry: :func:`study_scale`.
    """
    import dataclasses

    from taskcomplexity.rwg import RWGSettings, resolve_backend
    from taskcomplexity.stages.rwg_stage import RWGRequest

    study = study or study_from(cfg)
    settings = build(RWGSettings, cfg.rwg, "rwg")
    typed = user_overrides()
    overrides = study_scale(cfg, study, typed)
    if overrides:
        settings = dataclasses.replace(settings, **overrides)
        settings.validate()
    family = study_family(study, typed)
    dirs = search_dirs(sys.argv)
    for group, option in family.items():
        allowed = sorted({p.stem for d in dirs for p in (d / group).glob("*.yaml")})
        if option not in allowed:
            raise ConfigError(f"study.{group}={option} is not a known {group} option (allowed: {', '.join(allowed)})")
    out = []
    for i, entry in enumerate(study.tasks):
        node = entry_config(cfg, entry, typed, f"study.tasks[{i}]", family)
        task = task_from_config(node)
        network, prior = sampler_from_config(node)
        backend = resolve_backend(task, str(node.backend), network)
        out.append((entry, RWGRequest(task, network, prior, settings, backend)))
    return out


def check_study_settings(cfg: Any, study, requests) -> None:
    """Every stage's settings of a study, checked before any work (one ConfigError naming the key).

    Metrics, diagnostics, SAC (its settings, and a budget for every task it will train on) and the
    report: a bad value late in the chain must not cost the work before it.
    """
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings

    metrics = metrics_settings_from_config(cfg)
    for request in requests:
        policies = request.settings.policies
        if metrics.batches > policies // 2:
            raise ConfigError(f"metrics.batches={metrics.batches} needs at least 2 policies per batch, but N = "
                              f"{policies} (rwg.policies or study.policies): allowed metrics.batches <= "
                              f"{max(policies // 2, 2)}, or more policies")
    diagnostics = build(DiagnosticsSettings, cfg.diagnostics, "diagnostics")
    episodes = min(request.settings.episodes for request in requests)
    if episodes <= diagnostics.knn_neighbors:
        raise ConfigError(f"the diagnostics' k-NN estimate needs M > diagnostics.knn_neighbors = "
                          f"{diagnostics.knn_neighbors} episodes per policy, but M = {episodes} (rwg.episodes or "
                          f"study.episodes): allowed M >= {diagnostics.knn_neighbors + 1}")
    from taskcomplexity.stages.learning_path_stage import LearningPathSettings
    from taskcomplexity.stages.occupancy_stage import OccupancySettings
    from taskcomplexity.stages.primitives_stage import PrimitivesSettings

    build(OccupancySettings, cfg.occupancy, "occupancy")
    build(LearningPathSettings, cfg.learning_path, "learning_path")
    primitives = PrimitivesSettings.from_config(cfg.primitives)
    if primitives.enabled and study.kind != "variants":
        for request in requests:
            primitives.request(request)  # N, M and the backend checked before any work
    title = cfg.report.get("title")
    if title is not None and not isinstance(title, str):
        raise ConfigError(f"report.title must be a string or null (the study's own title), got {title!r}")
    if not cfg.sac.get("enabled", True) or study.kind == "variants":
        return
    from taskcomplexity.rl.settings import sac_skip_reason, with_budget
    from taskcomplexity.stages.sac_stage import sac_settings_from_config

    settings = sac_settings_from_config(cfg.sac)
    if not study.has_sac_budgets and settings.total_steps is None:
        typed = [o for o in user_overrides() if o.partition("=")[0].lstrip("+~") == "sac.enabled"]
        if typed:
            raise ConfigError(f"{typed[-1]}: study {study.name} gives no SAC budget (sac_steps) to any task, so it "
                              "has no SAC reference; set sac.total_steps to train SAC on it")
        return
    for entry, request in zip(study.tasks, requests, strict=True):
        if sac_skip_reason(request.task) is None:
            with_budget(settings, entry.sac_steps, task_id=entry.id)


@dataclasses.dataclass(frozen=True)
class StudyPlan:
    """A study composed from a config and checked, before any work: what every stage will run.

    ``entries`` and ``requests`` are in study order (entry i's RWG request is ``requests[i]``).
    """

    study: Any
    entries: tuple
    requests: tuple
    settings: Any
    cache: Any


def study_plan(cfg: Any) -> StudyPlan:
    """The study of ``cfg`` with each task's RWG request, its metrics settings and the cache; every
    stage's settings checked first (:func:`check_study_settings`)."""
    study = study_from(cfg)
    entries, requests = zip(*study_requests(cfg, study), strict=True)
    check_study_settings(cfg, study, requests)
    return StudyPlan(study, entries, requests, metrics_settings_from_config(cfg, study), cache_from_config(cfg))


def sac_command() -> str:
    """The command that trains the SAC curves a run without SAC lacks: its own overrides + sac.enabled=true.

    ``make paper`` is that command for ``make run`` (``experiment=published``). The program is the
    one this process runs as: ``python pipelines/study.py`` in a checkout, else the console script.
    """
    kept = [o for o in user_overrides() if o.split("=", 1)[0].lstrip("+~") not in ("sac.enabled", "force")]
    checkout = Path(sys.argv[0]).parent.name == "pipelines"
    program = "python pipelines/study.py" if checkout else "taskcomplexity-study"
    command = " ".join([program, *kept, "sac.enabled=true"])
    return f"make paper ({command})" if kept == ["experiment=published"] else command


def run_name(cfg: Any) -> str:
    """Directory name of a study's tables and report: ``<study.name>-<tag>`` (e.g. seven_tasks-quick)."""
    tag = cfg.get("tag")
    return f"{cfg.study.name}-{tag}" if tag else str(cfg.study.name)


def cache_from_config(cfg: Any):
    from taskcomplexity.stages.cache import Cache, ensure_writable

    ensure_writable(Path(cfg.paths.outputs))
    ensure_writable(Path(cfg.paths.cache), key="paths.cache")
    return Cache(Path(cfg.paths.cache))
