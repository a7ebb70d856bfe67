"""The reaching tasks' reward kinds, declared once (:data:`KINDS`): what each kind is and what its consumers branch on.

:mod:`taskcomplexity.tasks.rewards` computes them (numba kernels); the declarations live here, apart from the kernels,
so that reading or checking a config (``reward.kind``, the arm presets, the package's gymnasium ids) compiles and
imports nothing.
"""

from __future__ import annotations

from typing import NamedTuple

from taskcomplexity.errors import ConfigError

DENSE, SPARSE = 0.0, 1.0  # RewardKind.code: what the kernels branch on

TERMS = ("distance", "action", "collision", "proximity")
"""The signed terms of a shaped reward (:func:`taskcomplexity.tasks.rewards.shaped_terms`), in summation order."""
OBSTACLE_TERMS = ("collision", "proximity")
"""The terms that exist only on a task with an obstacle."""


class RewardKind(NamedTuple):
    """One reward kind and the properties its consumers branch on."""

    name: str
    """The ``reward.kind`` of the config."""
    code: float
    """The kernels' code of the kind (:func:`taskcomplexity.tasks.rewards.reward` branches on it)."""
    goal_reward: bool
    """The whole reward is a function of (achieved goal, desired goal): a goal-conditioned view's
    ``compute_reward`` is the task's reward, and relabelling needs nothing else (HER's setting)."""
    obstacle: bool
    """Defined on tasks with an obstacle (the reward has the collision and proximity terms)."""
    terms: tuple[str, ...]
    """The signed terms of :data:`TERMS` the reference env reports (``info["reward_<term>"]``; the
    obstacle's only on a task with one)."""


KINDS: dict[str, RewardKind] = {
    kind.name: kind
    for kind in (
        RewardKind("dense", DENSE, goal_reward=False, obstacle=True, terms=TERMS),
        RewardKind("sparse", SPARSE, goal_reward=True, obstacle=False, terms=()),
    )
}
REWARD_KINDS: tuple[str, ...] = tuple(KINDS)
"""The names ``reward.kind`` may take."""


def reward_kind(name: str) -> RewardKind:
    """The :class:`RewardKind` called ``name``.

    Raises
    ------
    ConfigError
        For an unknown name (the message lists the kinds).
    """
    if name not in KINDS:
        raise ConfigError(f"reward.kind must be one of {list(REWARD_KINDS)}, got {name!r}")
    return KINDS[name]
