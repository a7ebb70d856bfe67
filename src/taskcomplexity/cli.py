"""Glue between Hydra entry points and the library: config → dataclasses, errors → one line.

Entry points call :func:`check_overrides` before Hydra parses the command line (so an unknown config
group option is reported in one line, not a traceback) and wrap their task function with
:func:`one_line_errors`.
"""

from __future__ import annotations

import functools
import logging
import sys
from pathlib import Path
from typing import Any

from taskcomplexity.config import build, task_from_config
from taskcomplexity.errors import ConfigError, TaskComplexityError

CONF_DIR = Path(__file__).resolve().parents[2] / "conf"
GROUPS = ("arm", "reward", "prior", "network", "rwg", "metrics", "diagnostics", "sac", "report", "study", "experiment")
EXIT_BAD_INPUT = 2

log = logging.getLogger("taskcomplexity")


def fail(message: str) -> None:
    """Print ``error: message`` on one line to stderr and exit with status 2."""
    print(f"error: {message}", file=sys.stderr, flush=True)
    raise SystemExit(EXIT_BAD_INPUT)


def check_overrides(argv: list[str], conf_dir: Path = CONF_DIR) -> None:
    """Refuse ``group=option`` overrides whose option file does not exist, naming the allowed ones."""
    for arg in argv[1:]:
        if arg.startswith("-") or "=" not in arg:
            continue
        name, _, value = arg.partition("=")
        name = name.lstrip("+~")
        if name == "paths.outputs" and "," not in value and "$" not in value:
            from taskcomplexity.pipeline.cache import ensure_writable

            try:
                ensure_writable(Path(value))
            except TaskComplexityError as err:
                fail(str(err))
        if name not in GROUPS or not (conf_dir / name).is_dir():
            continue
        allowed = sorted(p.stem for p in (conf_dir / name).glob("*.yaml"))
        for option in value.split(","):
            if option in ("", "null") and name == "experiment":
                continue
            if option.startswith(("glob(", "range(", "choice(")):
                continue
            if option not in allowed:
                fail(f"{name}={option} is not a known option (allowed: {', '.join(allowed)})")


def one_line_errors(fn):
    """Turn the library's errors (and bad config values) into one line and exit status 2."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except (TaskComplexityError, ConfigError) as err:
            fail(str(err))
        except ValueError as err:  # estimator input validation (e.g. non-finite returns)
            fail(str(err))

    return wrapper


def sampler_from_config(cfg: Any):
    """(NetworkSpec, PriorSpec) of a composed config."""
    from taskcomplexity.policies import NetworkSpec, PriorSpec

    return build(NetworkSpec, cfg.network, "network"), build(PriorSpec, cfg.prior, "prior")


def rwg_request_from_config(cfg: Any, task=None):
    """The :class:`RWGRequest` of a composed config (for ``task`` if given)."""
    from taskcomplexity.pipeline.rwg_stage import RWGRequest
    from taskcomplexity.rwg import BACKENDS, RWGSettings

    if str(cfg.backend) not in BACKENDS:
        raise ConfigError(f"backend must be one of {list(BACKENDS)}, got {cfg.backend!r}")
    network, prior = sampler_from_config(cfg)
    settings = build(RWGSettings, cfg.rwg, "rwg")
    return RWGRequest(task or task_from_config(cfg), network, prior, settings, str(cfg.backend))


def metrics_settings_from_config(cfg: Any):
    from taskcomplexity.pipeline.metrics_stage import MetricsSettings

    node = {k: v for k, v in dict(cfg.metrics).items() if k != "scope"}
    return build(MetricsSettings, node, "metrics")


def study_tasks(cfg: Any) -> list:
    """The study's tasks, built from the arm/reward config files they name."""
    from omegaconf import OmegaConf

    from taskcomplexity.tasks.spec import ArmSpec, RewardSpec, TaskSpec

    tasks = []
    for i, entry in enumerate(cfg.study.tasks):
        for group in ("arm", "reward"):
            if not (CONF_DIR / group / f"{entry[group]}.yaml").exists():
                allowed = sorted(p.stem for p in (CONF_DIR / group).glob("*.yaml"))
                raise ConfigError(
                    f"study.tasks[{i}].{group}={entry[group]} is not a known option (allowed: {', '.join(allowed)})"
                )
        arm_node = _load_group("arm", entry["arm"])
        reward_node = OmegaConf.load(CONF_DIR / "reward" / f"{entry['reward']}.yaml")
        task = TaskSpec(
            arm=build(ArmSpec, arm_node, f"study.tasks[{i}].arm"),
            reward=build(RewardSpec, reward_node, f"study.tasks[{i}].reward"),
            max_steps=int(cfg.max_steps),
        )
        tasks.append(task.validate())
    return tasks


def _load_group(group: str, name: str):
    """A group option with its own ``defaults`` (e.g. two_link_obstacle extends two_link)."""
    from omegaconf import OmegaConf

    node = OmegaConf.load(CONF_DIR / group / f"{name}.yaml")
    defaults = node.pop("defaults", [])
    base = OmegaConf.create()
    for item in defaults:
        if item != "_self_":
            base = OmegaConf.merge(base, _load_group(group, item))
    return OmegaConf.merge(base, node)


def study_requests(cfg: Any) -> list[tuple[str, Any]]:
    """(name, RWGRequest) for every entry of ``study.tasks``.

    An entry names its ``arm`` and ``reward`` and may name a ``prior``, a ``network`` (defaults: the
    composed ones) and a display ``name`` (default: the task id); ``study.policies`` and
    ``study.episodes``, when set, override N and M for every entry.
    """
    import dataclasses

    from taskcomplexity.policies import NetworkSpec, PriorSpec

    network, prior = sampler_from_config(cfg)
    from taskcomplexity.rwg import RWGSettings

    settings = build(RWGSettings, cfg.rwg, "rwg")
    overrides = {k: cfg.study.get(k) for k in ("policies", "episodes") if cfg.study.get(k) is not None}
    if overrides:
        settings = dataclasses.replace(settings, **{k: int(v) for k, v in overrides.items()})
        settings.validate()
    out = []
    for i, (entry, task) in enumerate(zip(cfg.study.tasks, study_tasks(cfg), strict=True)):
        entry_network, entry_prior = network, prior
        for group, cls in (("network", NetworkSpec), ("prior", PriorSpec)):
            if entry.get(group) is None:
                continue
            if not (CONF_DIR / group / f"{entry[group]}.yaml").exists():
                allowed = sorted(p.stem for p in (CONF_DIR / group).glob("*.yaml"))
                raise ConfigError(
                    f"study.tasks[{i}].{group}={entry[group]} is not a known option (allowed: {', '.join(allowed)})"
                )
            spec = build(cls, _load_group(group, entry[group]), f"study.tasks[{i}].{group}")
            if group == "network":
                entry_network = spec
            else:
                entry_prior = spec
        from taskcomplexity.pipeline.rwg_stage import RWGRequest

        request = RWGRequest(task, entry_network, entry_prior, settings, str(cfg.backend))
        out.append((str(entry.get("name") or task.task_id), request))
    return out


def run_name(cfg: Any) -> str:
    """Directory name of a study's tables and report: ``<study.name>-<tag>`` (e.g. seven_tasks-quick)."""
    tag = cfg.get("tag")
    return f"{cfg.study.name}-{tag}" if tag else str(cfg.study.name)


def cache_from_config(cfg: Any):
    from taskcomplexity.pipeline.cache import Cache, ensure_writable

    root = Path(cfg.paths.outputs)
    ensure_writable(root)
    return Cache(Path(cfg.paths.cache))
