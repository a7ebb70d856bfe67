"""The generic RWG backend: any :class:`~taskcomplexity.tasks.base.Task` through its gymnasium envs.

A pool of single environments (``task.make_env()``) is stepped in lock-step like gymnasium's
``SyncVectorEnv`` with auto-reset disabled, except that only the environments whose episode is still
running are stepped (random policies end episodes at very different times). Slot j of policy p runs
that policy's episodes e = j, j + W, j + 2W, … one after another, each reset with
``episode_reset_seeds(seed, n, e)``; the policies' forward pass is one batched call over every slot per
step. Returns therefore depend only on (task, policy n, episode e, seed), not on the pool's size,
the chunking or the sharding.

The policies are any :class:`~taskcomplexity.policies.families.ActingBatch`: one ``act`` over every slot per
step, read through ``unit_outputs``. Actions: Box spaces get those (−1, 1) outputs mapped affinely onto
[low, high]; Discrete spaces their argmax. Observations: Box flattened, Discrete one-hot (float64).
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.policies.families import ActingBatch
from taskcomplexity.rwg.env_checks import check_observation, check_reward, reset_env, step_env
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import Task, decode_actions, encode_observations

ENVIRONMENTS_IN_FLIGHT = 256
"""Default number of environments stepped together (the pool's size)."""


def environments_in_flight(task: Task) -> int:
    """The pool's size for ``task``: the env class's ``environments_in_flight`` when it declares one (an env that is
    slow to build and to step gains nothing from a wider forward pass, e.g. Meta-World's), else
    :data:`ENVIRONMENTS_IN_FLIGHT`. Only the speed depends on it, never the returns."""
    return int(getattr(task, "environments_in_flight", None) or ENVIRONMENTS_IN_FLIGHT)


def slots_per_policy(policies: int, episodes: int, in_flight: int = ENVIRONMENTS_IN_FLIGHT) -> int:
    """W: episodes of one policy in flight at once."""
    return max(1, min(episodes, in_flight // max(1, policies)))


class GymRollout:
    """A pool of a task's environments, reused across chunks; close it when done.

    Parameters
    ----------
    task : Task
    """

    def __init__(self, task: Task):
        self.task = task
        self.envs: list = []

    def close(self) -> None:
        for env in self.envs:
            env.close()
        self.envs.clear()

    def __enter__(self) -> GymRollout:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _pool(self, size: int) -> list:
        while len(self.envs) < size:
            self.envs.append(self.task.make_env())
        return self.envs[:size]

    def run(self, policies: ActingBatch, seed: int, episodes: int, common_initial_states: bool = False):
        """Every episode of every policy of the batch.

        Parameters
        ----------
        policies : ActingBatch of P policies (indices n)
        seed : int
            Run seed (reset seeds of the episodes).
        episodes : int
            M.
        common_initial_states : bool
            Reset episode e of every policy with policy 0's seed (seed, 0, e).

        Returns
        -------
        (returns, steps, success) : ndarrays (P, M) float64, int64, bool
            ``success`` is the env's ``info["is_success"]`` (or ``info["success"]``) at the episode's
            last step, False when it reports neither.
        """
        task = self.task
        n_pol = len(policies)
        width = slots_per_policy(n_pol, episodes, environments_in_flight(task))
        envs = self._pool(n_pol * width)
        rows = policies.indices[:, None] * (not common_initial_states)  # common: every policy resets as policy 0
        seeds = episode_reset_seeds(seed, rows, np.arange(episodes)[None, :])
        returns = np.zeros((n_pol, episodes))
        steps = np.zeros((n_pol, episodes), dtype=np.int64)
        success = np.zeros((n_pol, episodes), dtype=bool)

        slot_policy = np.repeat(np.arange(n_pol), width)
        slot_episode = np.tile(np.arange(width), n_pol)  # current episode of each slot (>= M: idle)
        obs = np.zeros((n_pol * width, task.observation_size))
        active = slot_episode < episodes
        limit = task.max_steps
        space_in, space_out = task.observation_space, task.action_space

        def start(slot: int) -> None:
            reset_seed = int(seeds[slot_policy[slot], slot_episode[slot]])
            first = reset_env(task, envs[slot], reset_seed, policy=int(policies.indices[slot_policy[slot]]),
                              episode=int(slot_episode[slot]))
            obs[slot] = encode_observations(space_in, first[None])[0]

        for slot in np.flatnonzero(active):
            start(slot)
        with torch.no_grad():
            while active.any():
                outputs = policies.act(torch.from_numpy(obs.reshape(n_pol, width, -1))).numpy()
                outputs = policies.unit_outputs(outputs, isinstance(space_out, spaces.Box))  # (−1, 1) for a Box
                actions = decode_actions(space_out, outputs.reshape(n_pol * width, -1))
                for slot in np.flatnonzero(active):
                    p, e = slot_policy[slot], slot_episode[slot]
                    n, step = int(policies.indices[p]), int(steps[p, e]) + 1
                    new, reward, terminated, truncated, info = step_env(task, envs[slot], actions[slot], step,
                                                                        policy=n, episode=int(e))
                    returns[p, e] += check_reward(task, reward, n, int(e), step)
                    steps[p, e] += 1
                    if terminated or truncated or steps[p, e] >= limit:
                        success[p, e] = bool(info.get("is_success", info.get("success", False)))
                        slot_episode[slot] += width
                        if slot_episode[slot] < episodes:
                            start(slot)
                        else:
                            active[slot] = False
                    else:
                        new = check_observation(task, new, policy=n, episode=int(e), step=step)
                        obs[slot] = encode_observations(space_in, new[None])[0]
        return returns, steps, success
