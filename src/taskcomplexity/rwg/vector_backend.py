"""The ``vector`` RWG backend: a task whose gymnasium id registers a ``vector_entry_point`` (a researcher's own
NumPy-vectorised env) steps a chunk's environments with one call.

``gymnasium.make_vec(id, num_envs=K, vectorization_mode="vector_entry_point")`` makes one vector env of K
environments (the policies' episodes in flight: W per policy, as on the ``gym`` backend). A vector env steps all its
environments at once, so the episodes run in waves: wave w resets every environment with
``reset(seed=[…])``, slot (p, j) with the seed of episode e = w·W + j of policy p,
``episode_reset_seeds(seed, n, e)`` (the seed the ``gym`` backend resets that episode with), and steps all of them
until each slot's episode has ended; what an environment returns after its episode ended (whatever its autoreset
mode makes of it) is not read. So the returns depend only on (task, policy n, episode e, seed), and equal the
``gym`` backend's when the vector env computes what its single env computes.

That needs a vector env whose ``reset(seed=[s_0, …, s_{K−1}])`` seeds environment i from s_i alone (gymnasium's own
classic-control vector envs take one seed for all, and run on the ``kernel`` backend anyway): ``seeds_each``
(:mod:`taskcomplexity.tasks.vectorised`) probes it once per task, and a task whose vector env does not is not
offered this backend.
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.policies.families import ActingBatch
from taskcomplexity.rwg.backends import Plan, Runner, backend
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.gym_backend import slots_per_policy
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import decode_actions, encode_observations
from taskcomplexity.tasks.vectorised import make_vector


def run_vector(task, policies: ActingBatch, seed: int, episodes: int, common_initial_states: bool = False):
    """Every episode of every policy of the batch, in waves of W episodes per policy: the parameters and the
    (returns, steps, success) of :meth:`taskcomplexity.rwg.gym_backend.GymRollout.run`, for a task whose vector env
    seeds each environment (:func:`taskcomplexity.tasks.vectorised.seeds_each`)."""
    n_pol = len(policies)
    width = slots_per_policy(n_pol, episodes, backend("vector").environments_in_flight(task))
    rows = policies.indices[:, None] * (not common_initial_states)
    seeds = episode_reset_seeds(seed, rows, np.arange(episodes)[None, :])
    returns = np.zeros((n_pol, episodes))
    steps = np.zeros((n_pol, episodes), dtype=np.int64)
    success = np.zeros((n_pol, episodes), dtype=bool)
    slot_policy = np.repeat(np.arange(n_pol), width)
    box = isinstance(task.action_space, spaces.Box)
    env = make_vector(task, n_pol * width)
    try:
        with torch.no_grad():
            for first in range(0, episodes, width):
                slot_episode = first + np.tile(np.arange(width), n_pol)
                running = slot_episode < episodes
                episode = np.minimum(slot_episode, episodes - 1)
                obs, _ = env.reset(seed=[int(s) for s in seeds[slot_policy, episode]])
                while running.any():
                    encoded = encode_observations(task.observation_space, obs)
                    outputs = policies.act(torch.from_numpy(encoded.reshape(n_pol, width, -1))).numpy()
                    actions = decode_actions(task.action_space,
                                             policies.unit_outputs(outputs, box).reshape(n_pol * width, -1))
                    obs, reward, terminated, truncated, info = env.step(actions)
                    at = np.flatnonzero(running)
                    p, e = slot_policy[at], episode[at]
                    returns[p, e] += np.asarray(reward, dtype=np.float64)[at]
                    steps[p, e] += 1
                    ended = (np.asarray(terminated) | np.asarray(truncated))[at] | (steps[p, e] >= task.max_steps)
                    flags = info.get("is_success", info.get("success"))
                    if flags is not None:
                        success[p[ended], e[ended]] = np.asarray(flags, dtype=bool)[at][ended]
                    running[at[ended]] = False
    finally:
        env.close()
    return returns, steps, success


class VectorRunner(Runner):
    """The ``vector`` backend's runner: :func:`run_vector` for each batch (a vector env of its environments)."""

    def run(self, policies: ActingBatch, plan: Plan) -> ReturnChunk:
        return ReturnChunk(policies.indices.copy(),
                           *run_vector(self.task, policies, plan.seed, plan.episodes, plan.common_initial_states))
