"""The ``kernel`` RWG backend: gymnasium's classic-control tasks on batched numba kernels.

All M episodes of all P policies of a chunk run at once: one batched policy forward pass
(:meth:`~taskcomplexity.policies.families.ActingBatch.act`, read through ``unit_outputs`` as the ``gym``
backend reads it) and one parallel numba step (:func:`taskcomplexity.tasks.classic.kernels.step_all`) per
environment step. Episode e of policy n starts from the state that
``env.reset(seed=episode_reset_seeds(seed, n, e))`` would draw, so the returns equal the ``gym`` backend's
(``tests/rwg/test_kernel_backend.py`` states the tolerance). An env whose step draws random numbers (the
noisy CartPole) carries each episode's generator along with its state (four uint64 words per slot),
continued from the reset's draws as the env continues its ``np_random``.

Random policies end their episodes at very different times: once fewer than COMPACT_BELOW of the
slots run, the running episodes of each policy are packed to the front and the forward pass shrinks to
the policies that still run, over as many slots as the busiest of them needs.
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.families import ActingBatch
from taskcomplexity.rwg.backends import BACKENDS, Plan, Runner
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.classic import ClassicKernel, kernel_for
from taskcomplexity.tasks.classic.kernels import observe_all, step_all, step_serial
from taskcomplexity.tasks.step_kernel import prepare_kernels

COMPACT_BELOW = 0.75
"""Repack the batch once fewer than this fraction of its slots run."""
PARALLEL_FROM = BACKENDS["kernel"].parallel_from
"""Batches of at least this many environments are stepped on every core, smaller ones on one (4096)."""


def task_kernel(task) -> ClassicKernel:
    """The kernel of a task (a GymTask whose id and arguments have one)."""
    kernel = kernel_for(getattr(task, "env_id", ""), getattr(task, "kwargs", {}))
    if kernel is None:
        raise ConfigError(f"backend=kernel: task {task.task_id} has no batched kernel (allowed: auto, gym)")
    return kernel


def reset_seeds(seed: int, indices: np.ndarray, episodes: int, common_initial_states: bool = False) -> np.ndarray:
    """(P, M) reset seeds: per (seed, n, e), or per (seed, e) for every policy (common initial states)."""
    rows = np.asarray(indices)[:, None] * (not common_initial_states)
    return episode_reset_seeds(seed, rows, np.arange(episodes)[None, :])


def run_kernel(task, policies: ActingBatch, seed: int, episodes: int, common_initial_states: bool = False):
    """Every episode of every policy of the batch.

    Parameters
    ----------
    task : GymTask with a kernel
    policies : ActingBatch of P policies (indices n)
    seed : int
        Run seed.
    episodes : int
        M.
    common_initial_states : bool
        Episode e of every policy starts from the same state.

    Returns
    -------
    (returns, steps, success) : ndarrays (P, M) float64, int64, bool (success: always False, as the
    classic-control envs report none).
    """
    kernel = task_kernel(task)
    prepare_kernels()
    params = kernel.params(task.kwargs)
    n_pol = len(policies)
    box = isinstance(task.action_space, spaces.Box)
    seeds = reset_seeds(seed, policies.indices, episodes, common_initial_states)
    state, generators = kernel.start(seeds, task.kwargs)
    state = state.reshape(n_pol * episodes, kernel.state_size)
    generators = generators.reshape(n_pol * episodes, generators.shape[-1])
    obs = np.empty((n_pol * episodes, task.observation_size))
    observe_all(kernel.code, state, obs)
    running = np.ones(n_pol * episodes, dtype=bool)
    returns = np.zeros(n_pol * episodes)
    steps = np.zeros(n_pol * episodes, dtype=np.int64)
    all_returns = np.zeros(n_pol * episodes)
    all_steps = np.zeros(n_pol * episodes, dtype=np.int64)

    # The arrays above are laid out (policy rows R, slots W): slot (r, w) runs episode index[r·W + w].
    index = np.arange(n_pol * episodes)
    width = episodes
    active = policies
    with torch.no_grad():
        for _ in range(task.max_steps):
            outputs = active.act(torch.from_numpy(obs.reshape(len(active), width, -1))).numpy()
            outputs = active.unit_outputs(outputs, box).reshape(len(active) * width, -1)
            step = step_all if running.size >= PARALLEL_FROM else step_serial
            alive = step(kernel.code, params, state, generators, outputs, obs, running, returns, steps,
                         task.max_steps)
            if alive == 0:
                break
            if alive < COMPACT_BELOW * running.size:
                all_returns[index], all_steps[index] = returns, steps
                rows, slots = _compaction(running.reshape(len(active), width))
                state, generators, obs, running, returns, steps, index = (
                    a[slots.ravel()] for a in (state, generators, obs, running, returns, steps, index)
                )
                active, width = active.select(rows), slots.shape[1]
    all_returns[index], all_steps[index] = returns, steps
    shape = (n_pol, episodes)
    return all_returns.reshape(shape), all_steps.reshape(shape), np.zeros(shape, dtype=bool)


def _compaction(running: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pack the running episodes of each policy row to the front and drop rows that have none.

    Parameters
    ----------
    running : ndarray (R, W) bool

    Returns
    -------
    rows : ndarray (R',) int
        The policy rows kept.
    slots : ndarray (R', W') int
        Flat positions (r·W + w) of the new layout's slots: each kept row's running episodes first,
        padded with finished ones up to W', the largest number running in a row.
    """
    counts = running.sum(axis=1)
    rows = np.flatnonzero(counts)
    order = np.argsort(~running[rows], axis=1, kind="stable")[:, : counts.max()]
    return rows, rows[:, None] * running.shape[1] + order


class KernelRunner(Runner):
    """The ``kernel`` backend's runner: :func:`run_kernel` for each batch."""

    def run(self, policies: ActingBatch, plan: Plan) -> ReturnChunk:
        return ReturnChunk(policies.indices.copy(),
                           *run_kernel(self.task, policies, plan.seed, plan.episodes, plan.common_initial_states))
