"""The initial states of the reaching arms' episodes, shared by their ``batched`` and ``pybullet`` backends."""

from __future__ import annotations

import numpy as np

from taskcomplexity.seeding import episode_uniforms
from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.spec import TaskSpec


def initial_states(task: TaskSpec, seed: int, policies: np.ndarray, episodes: int, common: bool = False):
    """Reset states of every (policy, episode) pair, drawn from the stream (seed, n, e) (``common``: policy 0's
    for every policy).

    Parameters
    ----------
    task : TaskSpec
        A reaching arm.
    seed : int
        Run seed.
    policies : ndarray (P,) int
        Policy indices n.
    episodes : int
        M.
    common : bool
        Episode e of every policy starts from the same state.

    Returns
    -------
    joint_angles : ndarray (P, M, dof) float64
        Initial joint angles, rad in [0, 2π).
    target : ndarray (P, M, 2) float64
        The target in polar form: radius ρ, m, and angle, rad.
    """
    n = np.asarray(policies)[:, None] * (not common)
    e = np.arange(episodes)[None, :]
    return mechanics.initial_state(task.arm, episode_uniforms(seed, n, e))
