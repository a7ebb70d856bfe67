"""Any registered gymnasium id as a :class:`~taskcomplexity.tasks.base.Task`.

``GymTask("Pendulum-v1")`` measures gymnasium's pendulum; ``GymTask("mypkg.envs:Maze-v0")`` imports
``mypkg.envs`` (which registers ``Maze-v0`` with gymnasium) and measures a researcher's own env, with no
change to this package.
"""

from __future__ import annotations

import contextlib
import difflib
import functools
import importlib
import importlib.util
import inspect
import logging
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium

from taskcomplexity.errors import ConfigError
from taskcomplexity.extras import install_command
from taskcomplexity.tasks.base import check_space, flat_size
from taskcomplexity.tasks.source import source_digest

log = logging.getLogger(__name__)

MUJOCO_EXTRA = install_command("mujoco")
EXTRAS = {"shimmy": install_command("dmc")}
"""Modules of an id's ``module:`` prefix that an optional extra installs → the command that installs it (DM Control's
tasks are ``shimmy:dm_control/<domain>-<task>-v0``)."""


@dataclass(frozen=True, eq=True)
class GymTask:
    """A task made by ``gymnasium.make(env_id, **kwargs)``.

    Attributes
    ----------
    env_id : str
        A registered gymnasium id, or ``"module:Id"`` (gymnasium imports ``module`` first).
    kwargs : mapping
        Keyword arguments of the environment's constructor.
    max_steps : int or None
        Episode length limit, environment steps; None = the limit the id was registered with (resolved
        when the task is made, so both spellings of the same limit are the same task).
    name : str or None
        The task id in tables and logs; None = the env id without its module prefix.
    """

    env_id: str
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    max_steps: int | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.env_id, str) or not self.env_id:
            raise ConfigError(f"task.env_id must be a gymnasium id (e.g. Pendulum-v1), got {self.env_id!r}")
        spec = self.spec  # an unknown id, or one whose extra is missing, is refused here
        if self.max_steps is None:
            limit = spec.max_episode_steps
            if limit is None:
                raise ConfigError(f"task.max_steps must be set for task.env_id={self.env_id} "
                                  "(it registers no time limit)")
            object.__setattr__(self, "max_steps", int(limit))
        elif self.max_steps < 1:
            raise ConfigError(f"task.max_steps must be an integer >= 1 or null (the env's own limit), "
                              f"got {self.max_steps}")

    def __getstate__(self) -> dict:
        """The fields and the spaces, not the spec: a worker process finds the spec again (an id registered by a
        plugin, like Shimmy's DM Control tasks, has an entry point that cannot be pickled), and keeps the spaces,
        which it would otherwise read by making one environment per chunk."""
        return {k: v for k, v in self.__dict__.items() if k != "spec"}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    # -- identity ----------------------------------------------------------------------------
    @property
    def task_id(self) -> str:
        if self.name:
            return self.name
        return re.sub(r"[^A-Za-z0-9_.\-]+", "_", self.env_id.rpartition(":")[2])

    @functools.cached_property
    def environments_in_flight(self) -> int | None:
        """How many of its envs a backend steps together, when the env class declares it (its
        ``environments_in_flight`` attribute; None: the backends' default)."""
        entry = self.spec.entry_point
        if isinstance(entry, str):
            try:
                entry = gymnasium.envs.registration.load_env_creator(entry)
            except (ImportError, AttributeError, ModuleNotFoundError):
                return None
        value = getattr(entry, "environments_in_flight", None)
        return int(value) if isinstance(value, int) and value >= 1 else None

    def identity(self) -> dict:
        """The env id, its constructor arguments, the resolved episode limit and a digest of the source file
        that defines the env (so an edit to a researcher's env is a new task); for an env MuJoCo simulates, the
        versions of MuJoCo (and DM Control, whose models ship with it) that step it: two MuJoCo versions can take
        one state to different next states once bodies touch (gymnasium's Hopper-v5 on MuJoCo 3.3.0 and 3.6.0 part
        at its first contact). Not the display name."""
        identity = {"env_id": self.env_id, "kwargs": dict(sorted(self.kwargs.items())), "max_steps": self.max_steps,
                    "source": _source_digest(self.spec)}
        if _simulates_with_mujoco(self.env_id, self.spec):
            identity["simulator"] = _simulator_versions(dm_control=_is_dm_control(self.env_id, self.spec))
        return identity

    # -- what the env is ---------------------------------------------------------------------
    @functools.cached_property
    def spec(self) -> gymnasium.envs.registration.EnvSpec:
        """The registered spec (imports the id's module first; clear errors for unknown ids)."""
        return _find_spec(self.env_id)

    @functools.cached_property
    def _spaces(self) -> tuple[gymnasium.Space, gymnasium.Space]:
        env = self.make_env()
        try:
            return env.observation_space, env.action_space
        finally:
            env.close()

    @property
    def observation_space(self) -> gymnasium.Space:
        return self._spaces[0]

    @property
    def action_space(self) -> gymnasium.Space:
        return self._spaces[1]

    @property
    def observation_size(self) -> int:
        return flat_size(self.observation_space)

    @property
    def action_size(self) -> int:
        return flat_size(self.action_space)

    def make_env(self, **kwargs: Any) -> gymnasium.Env:
        """``gymnasium.make`` with the task's arguments and episode limit (no env checker); a ``Dict`` or ``Tuple``
        observation space is flattened into one ``Box`` (``gymnasium.wrappers.FlattenObservation``: its parts
        in the space's order, ``Discrete`` parts one-hot), as DM Control's tasks reach gymnasium through Shimmy."""
        arguments = {**self.kwargs, **kwargs}
        env_id = self.env_id if ":" not in self.env_id else self.spec.id
        if _simulates_with_mujoco(self.env_id, self.spec):
            _route_mujoco_warnings(dm_control=_is_dm_control(self.env_id, self.spec))
        try:
            env = gymnasium.make(env_id, max_episode_steps=self.max_steps, disable_env_checker=True, **arguments)
            if isinstance(env.observation_space, (gymnasium.spaces.Dict, gymnasium.spaces.Tuple)):
                env = gymnasium.wrappers.FlattenObservation(env)
            return env
        except ConfigError as err:  # an env of this package refusing an argument's value (it names the argument)
            raise ConfigError(f"task.kwargs of {self.env_id}: {err}") from err
        except gymnasium.error.DependencyNotInstalled as err:
            raise ConfigError(_dependency_message(self.env_id, err)) from err
        except TypeError as err:
            if "argument" not in str(err):
                raise
            unknown = [name for name in self.kwargs if name not in (env_keywords(self.env_id) or (name,))]
            if unknown:
                raise ConfigError(f"task.kwargs.{unknown[0]}={self.kwargs[unknown[0]]!r}: "
                                  f"{keywords_taken(self.env_id)}") from err
            raise ConfigError(f"task.kwargs={dict(self.kwargs)} are not accepted by {self.env_id}: {err}") from err

    def validate(self) -> GymTask:
        """Check both spaces (the id and the episode limit are checked when the task is made); return self."""
        check_space(self.observation_space, "observation", f"task.env_id={self.env_id}")
        check_space(self.action_space, "action", f"task.env_id={self.env_id}")
        return self


def env_keywords(env_id: str) -> tuple[str, ...] | None:
    """The keyword arguments the env of ``env_id`` takes (``task.kwargs``; what its registration passes included),
    or None when its constructor takes any (``**kwargs``)."""
    spec = _find_spec(env_id)
    creator = spec.entry_point
    if isinstance(creator, str):
        creator = gymnasium.envs.registration.load_env_creator(creator)
    try:
        parameters = inspect.signature(creator).parameters.values()
    except (TypeError, ValueError):  # a builtin or C extension without a signature
        return None
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    return tuple(sorted(p.name for p in parameters if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                                  inspect.Parameter.KEYWORD_ONLY)))


def keywords_taken(env_id: str) -> str:
    """What ``task.kwargs`` the env of ``env_id`` takes, in words: none, or the names allowed."""
    names = env_keywords(env_id)
    if names is None:
        return f"{env_id} takes any keyword argument"
    if not names:
        return f"{env_id} takes no keyword arguments"
    return f"{env_id} takes no such keyword argument (allowed: {', '.join(names)})"


def _find_spec(env_id: str) -> gymnasium.envs.registration.EnvSpec:
    module, _, name = env_id.rpartition(":")
    if module:
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as err:
            if module in EXTRAS:
                why = _missing(err, module)
                raise ConfigError(f"task.env_id={env_id} needs {module}, which is not installed{why}: "
                                  f"{EXTRAS[module]}") from err
            raise ConfigError(f"task.env_id={env_id}: cannot import module {module!r} ({err})") from err
    else:
        name = env_id
    if name not in gymnasium.registry:
        close = difflib.get_close_matches(name, list(gymnasium.registry), n=3, cutoff=0.5)
        hint = f" (closest registered: {', '.join(close)})" if close else ""
        raise ConfigError(f"task.env_id={env_id} is not a registered gymnasium id{hint}")
    spec = gymnasium.spec(name)
    entry = spec.entry_point if isinstance(spec.entry_point, str) else ""
    if "mujoco" in entry:  # the env's module and what it imports: MuJoCo, and gymnasium's renderer (imageio, glfw)
        try:
            importlib.import_module(entry.partition(":")[0])
        except (ImportError, gymnasium.error.DependencyNotInstalled) as err:
            raise ConfigError(f"task.env_id={env_id} needs MuJoCo, which is not installed{_missing(err)}: "
                              f"{MUJOCO_EXTRA}") from err
    return spec


def _missing(err: BaseException, needed: str = "mujoco") -> str:
    """`` (no module <name>)`` for the module whose import failed under ``err`` (or its cause) when it is not
    ``needed`` itself (the extra's own module, which the line names already), else ``""``."""
    while err is not None and not isinstance(err, ImportError):
        err = err.__cause__
    name = getattr(err, "name", None)
    return f" (no module {name})" if name and name.partition(".")[0] != needed else ""


def _is_dm_control(env_id: str, spec: gymnasium.envs.registration.EnvSpec) -> bool:
    """Whether the env is one of DM Control's, through Shimmy."""
    entry = spec.entry_point if isinstance(spec.entry_point, str) else ""
    return "dm_control" in entry or "dm_control" in spec.id or env_id.partition(":")[0] == "shimmy"


def _simulates_with_mujoco(env_id: str, spec: gymnasium.envs.registration.EnvSpec) -> bool:
    """Whether the env runs on MuJoCo: gymnasium's MuJoCo tasks, and DM Control's through Shimmy."""
    entry = spec.entry_point if isinstance(spec.entry_point, str) else ""
    return "mujoco" in entry or _is_dm_control(env_id, spec)


def _simulator_versions(*, dm_control: bool) -> str:
    """The installed versions of MuJoCo (and of DM Control) that simulate an env, e.g. ``"mujoco 3.3.0"``."""
    from importlib.metadata import PackageNotFoundError, version

    names = ("mujoco", "dm_control") if dm_control else ("mujoco",)
    found = []
    for name in names:
        try:
            found.append(f"{name} {version(name)}")
        except PackageNotFoundError:
            found.append(f"{name} missing")
    return ", ".join(found)


@functools.cache
def _route_mujoco_warnings(*, dm_control: bool) -> None:
    """Send MuJoCo's warnings to this module's log, each distinct one once, at debug level, instead of standard
    error and ``MUJOCO_LOG.TXT``. DM Control's models use a compiler attribute MuJoCo 3 deprecates, which it would
    otherwise print once for every environment made: hundreds of lines in a run, none of which concern its
    numbers. DM Control sets a handler of its own when imported (to absl's log), so for its tasks it is imported
    first and this one replaces it (once per process for each kind); MuJoCo's errors keep their handler."""
    try:
        import mujoco
    except ImportError:
        return
    if dm_control:
        with contextlib.suppress(ImportError):
            import dm_control.mujoco.wrapper.core  # noqa: F401  (sets its handler on import)
    seen: set[str] = set()

    def warning(message: str) -> None:
        if message not in seen:
            seen.add(message)
            log.debug("MuJoCo: %s", message)

    mujoco.set_mju_user_warning(warning)


def _source_digest(spec: gymnasium.envs.registration.EnvSpec) -> str:
    """The digest of the env's source (:func:`taskcomplexity.tasks.source.source_digest`): the file that defines its
    entry point and the researcher's own modules it imports ("" when there is no file)."""
    entry = spec.entry_point
    try:
        if isinstance(entry, str):
            return source_digest(entry.partition(":")[0])
        return source_digest(getattr(entry, "__module__", None), Path(inspect.getsourcefile(entry)))
    except (TypeError, AttributeError, OSError, ImportError, ValueError):
        return ""


def _dependency_message(env_id: str, err: Exception) -> str:
    from taskcomplexity.tasks.manipulation import METAWORLD_EXTRA

    if "metaworld" in str(err):
        return f"task.env_id={env_id} needs metaworld, which is not installed: {METAWORLD_EXTRA}"
    if "mujoco" in str(err).lower():
        return f"task.env_id={env_id} needs MuJoCo, which is not installed: {MUJOCO_EXTRA}"
    return f"task.env_id={env_id} needs a package that is not installed: {err}"
