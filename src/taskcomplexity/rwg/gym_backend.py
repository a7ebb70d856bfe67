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

from taskcomplexity.errors import TaskComplexityError
from taskcomplexity.policies.families import ActingBatch
from taskcomplexity.rwg.backends import Plan, Runner, backend
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.env_checks import check_observation, check_reward, reset_env, step_raised
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import Task, decode_actions, encode_observations

FLOATS = (float, np.float64)
"""The reward types the step loop adds without calling :func:`check_reward` when finite (the checks' own fast path,
inlined: it runs once per environment step)."""


def slots_per_policy(policies: int, episodes: int, in_flight: int) -> int:
    """W: episodes of one policy in flight at once, ``in_flight`` environments in all (at least one per policy)."""
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
        width = slots_per_policy(n_pol, episodes, backend("gym").environments_in_flight(task))
        slots = n_pol * width
        envs = self._pool(slots)
        rows = policies.indices[:, None] * (not common_initial_states)  # common: every policy resets as policy 0
        seeds = episode_reset_seeds(seed, rows, np.arange(episodes)[None, :]).tolist()
        returns = np.zeros((n_pol, episodes))
        steps = np.zeros((n_pol, episodes), dtype=np.int64)
        success = np.zeros((n_pol, episodes), dtype=bool)
        limit = task.max_steps
        space_in, space_out = task.observation_space, task.action_space
        box_in, box_out = isinstance(space_in, spaces.Box), isinstance(space_out, spaces.Box)
        box_shape = space_in.shape if box_in else None
        obs = np.zeros((slots, task.observation_size))
        inputs = list(obs)  # each slot's row of the policies' input (a view)
        indices = policies.indices.tolist()
        # Per slot, as Python numbers (the loop below runs once per environment step): its policy's position, the
        # episode it runs (>= M: idle), that episode's steps and return so far (a float64 sum in step order, as the
        # return matrix would add it).
        slot_policy = [slot // width for slot in range(slots)]
        slot_episode = [slot % width for slot in range(slots)]
        slot_steps = [0] * slots
        slot_return = [0.0] * slots

        def encode(slot: int, observation: np.ndarray) -> None:
            if box_in:  # a Box observation flattened into float64 (what encode_observations gives)
                inputs[slot][:] = observation.reshape(-1)
            else:
                inputs[slot][:] = encode_observations(space_in, observation[None])[0]

        def start(slot: int) -> None:
            p, e = slot_policy[slot], slot_episode[slot]
            encode(slot, reset_env(task, envs[slot], seeds[p][e], policy=indices[p], episode=e))

        active = [slot for slot in range(slots) if slot_episode[slot] < episodes]
        for slot in active:
            start(slot)
        with torch.no_grad():
            while active:
                outputs = policies.act(torch.from_numpy(obs.reshape(n_pol, width, -1))).numpy()
                outputs = policies.unit_outputs(outputs, box_out)  # (−1, 1) for a Box
                actions = decode_actions(space_out, outputs.reshape(slots, -1))
                running = []
                for slot in active:
                    p, e = slot_policy[slot], slot_episode[slot]
                    n, step = indices[p], slot_steps[slot] + 1
                    try:  # step_env, inlined (once per environment step)
                        new, reward, terminated, truncated, info = envs[slot].step(actions[slot])
                    except TaskComplexityError:
                        raise
                    except Exception as error:
                        raise step_raised(task, error, step, policy=n, episode=e) from error
                    if type(reward) in FLOATS and reward - reward == 0.0:  # finite: what check_reward lets through
                        total = slot_return[slot] + reward
                    else:
                        total = slot_return[slot] + check_reward(task, reward, n, e, step)
                    if terminated or truncated or step >= limit:
                        returns[p, e], steps[p, e] = total, step
                        success[p, e] = bool(info.get("is_success", info.get("success", False)))
                        slot_steps[slot], slot_return[slot] = 0, 0.0
                        slot_episode[slot] = e + width
                        if e + width < episodes:
                            start(slot)
                            running.append(slot)
                    else:
                        slot_steps[slot], slot_return[slot] = step, total
                        if box_in and type(new) is np.ndarray and new.shape == box_shape:  # what the check passes
                            inputs[slot][:] = new.reshape(-1)
                        else:
                            encode(slot, check_observation(task, new, policy=n, episode=e, step=step))
                        running.append(slot)
                active = running
        return returns, steps, success


class GymRunner(Runner):
    """The ``gym`` backend's runner: one :class:`GymRollout` for every batch of a run (its environments reused)."""

    def __init__(self, task: Task):
        super().__init__(task)
        self.rollout = GymRollout(task)

    def run(self, policies: ActingBatch, plan: Plan) -> ReturnChunk:
        return ReturnChunk(policies.indices.copy(),
                           *self.rollout.run(policies, plan.seed, plan.episodes, plan.common_initial_states))

    def close(self) -> None:
        self.rollout.close()
