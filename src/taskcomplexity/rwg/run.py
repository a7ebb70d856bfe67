"""Algorithm 1 over a shard's policies: sample each chunk from the family, run its episodes on the backend.

:func:`run_rwg` resolves the backend (refusing one the task or the family cannot run, before any work), splits
the shard into chunks (:mod:`taskcomplexity.rwg.chunking`) and runs each through :func:`simulate_chunk` (the gym
backend's on a pool of processes, :mod:`taskcomplexity.rwg.workers`), which
samples the chunk's policies (:func:`taskcomplexity.policies.families.sample_family`) and hands them to
:func:`run_batch`, the one dispatch over the backends.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from threadpoolctl import threadpool_limits

import taskcomplexity.rwg as rwg
from taskcomplexity.policies.families import BACKEND_CALLS, FamilyBatch, FamilySpec, missing_calls, sample_family
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.progress import Progress, progress_bar
from taskcomplexity.rwg.arm_resets import initial_states
from taskcomplexity.rwg.backends import resolve_backend
from taskcomplexity.rwg.batched_backend import simulate_batched
from taskcomplexity.rwg.chunking import ReturnChunk, chunks
from taskcomplexity.rwg.gym_backend import GymRollout
from taskcomplexity.rwg.pybullet_backend import simulate_pybullet
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.rwg.workers import gym_workers, run_on_workers
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


def run_rwg(
    task: Task,
    network: FamilySpec,
    prior: PriorSpec,
    settings: RWGSettings,
    backend: str = "batched",
    *,
    completed: dict[tuple[int, int], ReturnChunk] | None = None,
    on_chunk: Callable[[tuple[int, int], ReturnChunk], None] | None = None,
    progress: Progress = False,
) -> ReturnChunk:
    """Algorithm 1 over this shard's policies.

    Parameters
    ----------
    task : Task
    network : FamilySpec
        The policy family (``network.*``).
    prior : PriorSpec
    settings : RWGSettings
    backend : str
        ``auto`` or one of :data:`taskcomplexity.rwg.backends.BACKENDS`; one the task or the family cannot run
        is refused (:class:`~taskcomplexity.errors.ConfigError`) before any work.
    completed : dict, optional
        Chunks already computed (by an interrupted run), keyed by (start, stop); they are reused.
    on_chunk : callable, optional
        Called with each newly computed chunk (e.g. to save it for resumption).
    progress : bool or tqdm
        Show a bar over environment episodes, or advance a study stage's bar
        (:mod:`taskcomplexity.progress`).

    Returns
    -------
    ReturnChunk
        The shard's returns (P, M), policies in order.
    """
    settings.validate()
    backend = resolve_backend(task, backend, network)
    completed = dict(completed or {})
    ranges = chunks(task, network, settings, backend)
    total = sum(b - a for a, b in ranges) * settings.episodes
    bar = progress_bar(progress, total=total, unit="ep", desc=f"rwg {task.task_id} [{backend}]", smoothing=0.1)
    pending = [key for key in ranges if key not in completed]
    workers = gym_workers(settings, len(pending)) if backend == "gym" else 1
    rollout = GymRollout(task) if backend == "gym" and workers == 1 else None

    def done(key: tuple[int, int], chunk: ReturnChunk) -> None:
        completed[key] = chunk
        if on_chunk is not None:
            on_chunk(key, chunk)
        bar.update((key[1] - key[0]) * settings.episodes)

    bar.update(sum(b - a for a, b in ranges if (a, b) in completed) * settings.episodes)
    # The policy forward pass already runs one thread per core (PolicyBatch.act): BLAS threads inside those
    # workers would only spin against them. One BLAS thread per worker computes the same products.
    blas = threadpool_limits(limits=1, user_api="blas")
    try:
        if workers > 1:  # the gym backend's chunks on a pool of processes, each stepping its own environments
            run_on_workers(task, network, prior, settings, pending, workers, done)
        for key in pending:
            if key not in completed:
                # through the package's public name, which a test replaces to kill a run between two chunks
                done(key, rwg.simulate_chunk(task, network, prior, settings, *key, backend=backend,
                                             progress=progress is True, rollout=rollout))
    finally:
        blas.restore_original_limits()
        bar.close()
        if rollout is not None:
            rollout.close()
    return ReturnChunk.concatenate([completed[k] for k in ranges])
