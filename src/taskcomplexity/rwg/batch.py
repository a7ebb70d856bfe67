"""One batch of policies on one backend: the dispatch over the backends (:func:`run_batch`) and a chunk of a shard's
policies sampled from their family and run (:func:`simulate_chunk`).

:mod:`taskcomplexity.rwg.run` runs a shard's chunks through :func:`simulate_chunk`, in this process or on the gym
backend's workers (:mod:`taskcomplexity.rwg.workers`), which import it from here: neither imports the other.
"""

from __future__ import annotations

import numpy as np

from taskcomplexity.policies.families import BACKEND_CALLS, FamilyBatch, FamilySpec, missing_calls, sample_family
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.rwg.arm_resets import initial_states
from taskcomplexity.rwg.backends import resolve_backend
from taskcomplexity.rwg.batched_backend import simulate_batched
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.gym_backend import GymRollout
from taskcomplexity.rwg.pybullet_backend import simulate_pybullet
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.tasks.base import Task


def run_batch(task: Task, policies: FamilyBatch, backend: str, *, seed: int, episodes: int,
              common_initial_states: bool = False, contacts: str = "pybullet", precision: str = "float64",
              progress: bool = False, rollout: GymRollout | None = None) -> ReturnChunk:
    """Every episode of every policy of ``policies`` on ``backend`` (resolved: not ``auto``).

    Parameters
    ----------
    task : Task
    policies : FamilyBatch
        P policies; their ``indices`` n choose the reset streams (seed, n, e) of their episodes. A
        :class:`~taskcomplexity.policies.families.SteppedBatch` on ``batched`` and ``pybullet``, an
        :class:`~taskcomplexity.policies.families.ActingBatch` on ``gym``, ``kernel``, ``envpool`` and ``vector``.
    backend : {'batched', 'pybullet', 'gym', 'kernel', 'envpool', 'vector'}
    seed : int
        Run seed of the reset states.
    episodes : int
        M.
    common_initial_states : bool
        Episode e of every policy starts from the same state.
    contacts, precision : str
        ``rwg.contacts`` and ``rwg.precision`` (the batched backend's).
    progress : bool
        A bar over the obstacle task's hand-overs to PyBullet.
    rollout : GymRollout, optional
        The ``gym`` backend's environment pool (made here, and closed, when None).

    Returns
    -------
    ReturnChunk
        Returns (P, M), in the task's reward units, steps and success.
    """
    missing = missing_calls(policies, backend)
    if missing:  # a family whose ``backends`` lists one it does not implement: refused before the episodes
        raise TypeError(f"backend={backend} cannot run a {type(policies).__name__}: it lacks {', '.join(missing)} "
                        f"(the backend's calls: {BACKEND_CALLS[backend].__module__}.{BACKEND_CALLS[backend].__name__})")
    if backend == "kernel":  # gymnasium's classic-control tasks on their batched numba kernels
        from taskcomplexity.rwg.kernel_backend import run_kernel

        return ReturnChunk(policies.indices.copy(), *run_kernel(task, policies, seed, episodes, common_initial_states))
    if backend == "envpool":  # MuJoCo and DM Control tasks on EnvPool's thread pool
        from taskcomplexity.rwg.envpool_backend import run_envpool

        return ReturnChunk(policies.indices.copy(), *run_envpool(task, policies, seed, episodes, common_initial_states))
    if backend == "vector":  # a researcher's vectorised env: one step for every environment of the chunk
        from taskcomplexity.rwg.vector_backend import run_vector

        return ReturnChunk(policies.indices.copy(), *run_vector(task, policies, seed, episodes, common_initial_states))
    if backend == "gym":
        if rollout is not None:
            return ReturnChunk(policies.indices.copy(), *rollout.run(policies, seed, episodes, common_initial_states))
        with GymRollout(task) as own:
            return ReturnChunk(policies.indices.copy(), *own.run(policies, seed, episodes, common_initial_states))
    joint_angles, target = initial_states(task, seed, policies.indices, episodes, common_initial_states)
    if backend == "batched":
        return simulate_batched(task, policies, joint_angles, target, contacts, progress, precision=precision)
    return simulate_pybullet(task, policies, joint_angles, target)


def simulate_chunk(
    task: Task,
    network: FamilySpec,
    prior: PriorSpec,
    settings: RWGSettings,
    start: int,
    stop: int,
    backend: str = "batched",
    *,
    progress: bool = False,
    rollout: GymRollout | None = None,
) -> ReturnChunk:
    """Run every episode of policies ``start … stop−1`` (``progress``: a bar over obstacle hand-overs).

    ``rollout`` is the environment pool of the ``gym`` backend (made here, and closed, when None).
    """
    backend = resolve_backend(task, backend, network)
    policies = sample_family(task, network, prior, settings.seed, np.arange(start, stop))
    return run_batch(task, policies, backend, seed=settings.seed, episodes=settings.episodes,
                     common_initial_states=settings.common_initial_states, contacts=settings.contacts,
                     precision=settings.precision, progress=progress, rollout=rollout)
