"""State–action occupancies: the (observation, action) pairs that policies visit, recorded on a task's env.

RWG keeps only returns; the occupancy distance (:mod:`taskcomplexity.metrics.occupancy`) needs the
behaviour itself. :func:`record_occupancies` replays episodes of a :class:`PolicyBatch` on the task's
gymnasium env (the reference env: PyBullet for the arms) from the same reset states RWG uses for
(seed, policy n, episode e), so the pairs of a random policy are those of its own RWG episodes.

A pair is the policy's input and what it did: the encoded observation (``encode_observations``)
followed by the action as the env receives it (a Box action flattened; a Discrete action one-hot).
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.policies.mlp import PolicyBatch, select_policy
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import Task, decode_actions, encode_observations, flat_size
from taskcomplexity.tasks.spec import TaskSpec


def pair_size(task: Task) -> int:
    """D: width of one state–action pair of ``task``."""
    return task.observation_size + flat_size(task.action_space)


def _action_features(space: spaces.Space, action: np.ndarray) -> np.ndarray:
    if isinstance(space, spaces.Discrete):
        out = np.zeros(int(space.n))
        out[int(action) - int(space.start)] = 1.0
        return out
    return np.asarray(action, dtype=np.float64).reshape(-1)


def _resets(task: Task, seed: int, policies: np.ndarray, episodes: int) -> list[list[dict]]:
    """``env.reset`` keyword arguments of episode e of each policy: RWG's reset state of (seed, n, e)."""
    if isinstance(task, TaskSpec):
        from taskcomplexity.rwg import initial_states

        angles, target = initial_states(task, seed, policies, episodes)
        return [[{"options": {"joint_angles": angles[p, e], "target": target[p, e]}} for e in range(episodes)]
                for p in range(len(policies))]
    seeds = episode_reset_seeds(seed, np.asarray(policies)[:, None], np.arange(episodes)[None, :])
    return [[{"seed": int(s)} for s in row] for row in seeds]


def record_occupancies(
    task: Task, policies: PolicyBatch, *, seed: int, episodes: int, pairs: int, progress=None
) -> list[np.ndarray]:
    """Each policy's state–action pairs over ``episodes`` episodes, thinned to at most ``pairs``.

    Parameters
    ----------
    task : Task
    policies : PolicyBatch of K policies (indices n: the reset streams (seed, n, e) of their episodes)
    seed : int
        Run seed of the reset states (RWG's seed for random policies).
    episodes : int
        Episodes per policy (each to termination or ``task.max_steps``).
    pairs : int
        At most this many pairs per policy: every visited pair when the episodes visit fewer, else
        ``pairs`` evenly spaced ones (deterministic thinning, so the occupancy keeps its time profile).
    progress : callable, optional
        Called with 1 after each episode (e.g. a tqdm bar's ``update``).

    Returns
    -------
    list of K ndarrays (nₖ, D) float64, D = :func:`pair_size`.
    """
    resets = _resets(task, seed, policies.indices, episodes)
    space_in, space_out = task.observation_space, task.action_space
    box = isinstance(space_out, spaces.Box)
    env = task.make_env()
    out = []
    try:
        with torch.no_grad():
            for p in range(len(policies)):
                policy = select_policy(policies, p)
                visited = []
                for e in range(episodes):
                    obs, _ = env.reset(**resets[p][e])
                    for _ in range(task.max_steps):
                        x = encode_observations(space_in, np.asarray(obs)[None])
                        unit = policy.unit_outputs(policy.act(torch.from_numpy(x).view(1, 1, -1))[0].numpy(), box)
                        action = decode_actions(space_out, unit)[0]
                        visited.append(np.concatenate([x[0], _action_features(space_out, action)]))
                        obs, _, terminated, truncated, _ = env.step(action)
                        if terminated or truncated:
                            break
                    if progress is not None:
                        progress(1)
                visited = np.asarray(visited, dtype=np.float64)
                if len(visited) > pairs:
                    visited = visited[np.linspace(0, len(visited) - 1, pairs).round().astype(np.int64)]
                out.append(visited)
    finally:
        env.close()
    return out
