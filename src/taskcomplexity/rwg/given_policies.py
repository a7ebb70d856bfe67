"""RWG's episodes for policies that are given, not drawn from a prior (e.g. perturbed SAC actors).

:func:`~taskcomplexity.rwg.simulate_chunk` draws policies ``start … stop−1`` from (network, prior);
:func:`run_policies` runs any :class:`~taskcomplexity.policies.PolicyBatch` on the same backends,
with the same reset states for (seed, policy index n, episode e). It composes the backends' own
functions beside :func:`simulate_chunk` (written so when that function's code was part of every RWG cache
key; keys now follow the stages' numerics versions, :mod:`taskcomplexity.stages.keys`, so the two may be
folded into one dispatch).
"""

from __future__ import annotations

import numpy as np

from taskcomplexity.policies.mlp import PolicyBatch
from taskcomplexity.rwg import ReturnChunk, _simulate_batched, _simulate_pybullet, initial_states, resolve_backend
from taskcomplexity.rwg.gym_backend import GymRollout
from taskcomplexity.tasks.base import Task


def run_policies(task: Task, policies: PolicyBatch, *, seed: int, episodes: int, backend: str = "auto",
                 common_initial_states: bool = False, contacts: str = "pybullet") -> ReturnChunk:
    """Every episode of every policy of ``policies`` (returns (P, M), steps, success).

    Parameters
    ----------
    task : Task
    policies : PolicyBatch
        Their ``indices`` choose the reset streams (seed, n, e) of their episodes.
    seed : int
        Run seed of the reset states.
    episodes : int
        M.
    backend : str
        As ``backend=`` of RWG (``auto``: the task's fastest exact backend).
    common_initial_states : bool
        Episode e of every policy starts from the same state.
    contacts : {'pybullet', 'model'}
        The obstacle task's contact handling on the batched backend.
    """
    backend = resolve_backend(task, backend)
    indices = np.asarray(policies.indices)
    if backend == "kernel":
        from taskcomplexity.rwg.kernel_backend import run_kernel

        return ReturnChunk(indices.copy(), *run_kernel(task, policies, seed, episodes, common_initial_states))
    if backend == "gym":
        with GymRollout(task) as rollout:
            return ReturnChunk(indices.copy(), *rollout.run(policies, seed, episodes, common_initial_states))
    joint_angles, target = initial_states(task, seed, indices, episodes, common_initial_states)
    if backend == "batched":
        return _simulate_batched(task, policies, joint_angles, target, contacts)
    return _simulate_pybullet(task, policies, joint_angles, target)
