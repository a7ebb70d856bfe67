"""Which gymnasium tasks EnvPool simulates: the ids the ``envpool`` RWG backend runs
(:mod:`taskcomplexity.rwg.envpool_backend`)."""

from __future__ import annotations

import functools
import importlib.util
import re

from taskcomplexity.extras import install_command

ENVPOOL_EXTRA = install_command("envpool")


def installed() -> bool:
    """Whether EnvPool can be imported (without importing it: that takes about a second)."""
    return importlib.util.find_spec("envpool") is not None


@functools.cache
def _registered() -> frozenset[str]:
    import envpool

    return frozenset(envpool.list_all_envs())


def envpool_id(task) -> str | None:
    """The EnvPool id that simulates ``task``, or None.

    A :class:`~taskcomplexity.tasks.gym_task.GymTask` with no constructor arguments whose env is one of gymnasium's
    MuJoCo tasks (same id in EnvPool) or one of DM Control's through Shimmy (``dm_control/<domain>-<task>-v0`` →
    ``<Domain><Task>-v1``, e.g. ``ball_in_cup-catch`` → ``BallInCupCatch-v1``), when EnvPool is installed and
    registers that id.
    """
    env_id = getattr(task, "env_id", None)
    if env_id is None or getattr(task, "kwargs", None) or not installed():
        return None
    spec = task.spec
    entry = spec.entry_point if isinstance(spec.entry_point, str) else ""
    name = spec.id
    if name.startswith("dm_control/"):
        match = re.fullmatch(r"dm_control/([a-z_]+)-([a-z_]+)-v0", name)
        if match is None:
            return None
        name = "".join(part.capitalize() for word in match.groups() for part in word.split("_")) + "-v1"
    elif not entry.startswith("gymnasium.envs.mujoco"):
        return None
    return name if name in _registered() else None
