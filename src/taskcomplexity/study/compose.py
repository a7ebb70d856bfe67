"""Every study entry composed through Hydra, and its RWG request (:func:`entry_requests`): the entry's own
choices (task, arm, reward, prior, network, env id, …) over the command line's overrides and the study's policy
family, at the N and M that apply to every entry (:func:`study_scale`).

The one module below the plan that uses Hydra: the plan (:func:`taskcomplexity.study.plan.read_plan`) reads the
composed config and hands down plain data (the study, the RWG settings, :class:`EntryBase`, the typed
overrides); each entry's own config is composed here, from the packaged configs, and read into its request
(:func:`request_of`).
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from omegaconf import OmegaConf

from taskcomplexity.cli import CONF_DIR, search_dirs
from taskcomplexity.config import build
from taskcomplexity.errors import ConfigError
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study_data import Study, StudyTask
from taskcomplexity.tasks.from_config import task_from_config

log = logging.getLogger("taskcomplexity")


TASK_GROUPS = ("task", "arm", "reward", "prior", "network")
"""Config groups a study entry may choose for itself."""


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


class Composer:
    """Hydra's composition of the packaged configs (and the search path's), once per distinct list of overrides:
    ``composer(overrides, where)`` → a config of its own (a deep copy), for the caller to change.

    The entries of a study that choose the same config groups compose alike (every id of a gymnasium benchmark is
    ``task=gym``; its env id, kwargs and episode limit are set after composition), and one composition costs
    ~0.1-0.3 CPU-s (Hydra reads and merges every file of the defaults list), so a study of 50 Meta-World tasks
    composes once instead of 50 times. One composer serves one reading of a study (the search path and Hydra's
    state are those of that moment); an error names the first entry (``where``) that composed the overrides.
    """

    def __init__(self) -> None:
        self._composed: dict[tuple[str, ...], Any] = {}

    def __call__(self, overrides: list[str], where: str):
        key = tuple(overrides)
        if key not in self._composed:
            self._composed[key] = _compose(overrides, where)
        return copy.deepcopy(self._composed[key])


@dataclass(frozen=True)
class EntryBase:
    """What every study entry takes from the study's own composed config, as plain data (:func:`entry_base`):
    what neither the entry nor the study's family chooses.

    Attributes
    ----------
    backend : str
        The RWG backend (``auto``, or one of the backends).
    max_steps : int
        The reaching arms' episode length.
    prior, network : mapping
        The ``prior`` and ``network`` groups as composed (an entry or the study's family may choose others).
    """

    backend: str
    max_steps: Any
    prior: Mapping[str, Any]
    network: Mapping[str, Any]


def entry_base(config: Mapping[str, Any]) -> EntryBase:
    """What every study entry takes from the study's own composed config as plain data (``config``,
    :func:`~taskcomplexity.config.plain`): backend, max_steps, prior, network."""
    return EntryBase(str(config["backend"]), config["max_steps"], config["prior"], config["network"])


def entry_config(base: EntryBase, entry, typed: list[str], where: str, family: dict[str, str] | None = None,
                 composer: Composer | None = None):
    """The composed config of one study entry: ``typed`` overrides, the study's policy ``family``
    (:func:`study_family`), then the entry's own choices; ``composer`` (a :class:`Composer`) shares compositions
    between the entries of one study.

    What neither the entry nor the study's family chooses (backend, the reaching arms' max_steps,
    prior and network) comes from ``base``, the study's own composed config as plain data, so values set
    there, by overrides or in code, reach every task.
    """
    from omegaconf import open_dict

    family = family or {}
    node = (composer or Composer())(_entry_overrides(entry, typed, where, family), where)
    with open_dict(node):
        node.backend, node.max_steps = base.backend, base.max_steps
        for group in ("prior", "network"):
            if group not in entry.selection and group not in family:
                node[group] = dict(getattr(base, group))
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


def study_scale(settings, study, typed: list[str]) -> dict[str, int]:
    """N and M that replace ``rwg.policies``/``rwg.episodes`` (as ``settings``, the RWG settings, give them) for
    every entry of ``study`` (logged).

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
        given = getattr(settings, key)
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


def group_options(group: str) -> list[str]:
    """The options of config group ``group``: the packaged ones and those of the search path's directories."""
    return sorted({p.stem for d in search_dirs(sys.argv) for p in (d / group).glob("*.yaml")})


def check_presets(study: Study) -> None:
    """Refuse, in one line naming the study, the entry and the presets allowed, an entry that chooses a preset
    (``task``, ``arm``, ``reward``, ``prior``, ``network``) no config file holds, before Hydra composes it."""
    for i, entry in enumerate(study.tasks):
        for group in TASK_GROUPS:
            option = entry.selection.get(group)
            if option is not None and str(option) not in group_options(group):
                raise ConfigError(f"study {study.name}: study.tasks[{i}] ({entry.id}) names {group}={option}, which is "
                                  f"not a {group} preset (allowed: {', '.join(group_options(group))})")


def entry_requests(study: Study, settings, config: Mapping[str, Any], typed: list[str], only: str | None = None
                   ) -> list[tuple[StudyTask, RWGRequest]]:
    """(StudyTask, RWGRequest) for every entry of the study, in study order; for the entry of id ``only`` alone when
    given (a job of a sweep over ``rwg.entry``: the study's settings are checked, its other entries not composed).

    Each entry is composed with Hydra's compose API from the packaged configs (and the user's search
    path): the entry's own choices (``task``, ``env_id``, ``kwargs``, ``max_steps``, ``arm``,
    ``reward``, ``prior``, ``network``) over the command line's overrides ``typed``, so an override such as
    ``arm.links.0.mass=7`` reaches every study task; what no entry chooses comes from the study's own composed
    config ``config`` (plain data, :func:`entry_base`). ``settings``: the RWG settings; N and M of every entry:
    :func:`study_scale`.
    """
    base = entry_base(config)
    overrides = study_scale(settings, study, typed)
    if overrides:
        settings = dataclasses.replace(settings, **overrides)
        settings.validate()
    family = study_family(study, typed)
    for group, option in family.items():
        if option not in group_options(group):
            raise ConfigError(f"study.{group}={option} is not a known {group} option (allowed: "
                              f"{', '.join(group_options(group))})")
    check_presets(study)
    out, composer = [], Composer()
    for i, entry in enumerate(study.tasks):
        if only is not None and entry.id != only:
            continue
        node = entry_config(base, entry, typed, f"study.tasks[{i}]", family, composer)
        out.append((entry, request_of(node, settings)))
    return out


def request_of(node: Any, settings, task=None) -> RWGRequest:
    """The RWG request of one composed config (a study entry's, or a single-stage command's): its task (``task``
    if given), its policy family and prior, ``settings``, and its backend (``auto`` resolved)."""
    from taskcomplexity.policies.families import network_from_config
    from taskcomplexity.policies.mlp import PriorSpec

    task = task_from_config(node) if task is None else task
    network, prior = network_from_config(node.network), build(PriorSpec, node.prior, "prior")
    return RWGRequest(task, network, prior, settings, str(node.backend))


