"""What the RWG stage checks of an environment before (and while) it caches returns from it.

A cached return matrix is a promise that the same (task, policy n, episode e, seed) gives the same
returns again, and that the returns are numbers. A researcher's own env can break that promise in ways
the RWG loop would otherwise turn into silent garbage or a traceback deep in NumPy: a ``reset`` that
ignores its seed (a rerun gives other returns), observations that do not match the declared observation
space, rewards that are NaN or infinite. Each is refused with :class:`EnvContractError`, whose message
names the env id and what it did.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from taskcomplexity.errors import TaskComplexityError
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.tasks.base import Task, encode_observations


class EnvContractError(TaskComplexityError):
    """An environment breaks what a cached return matrix relies on (seeded resets, observations in the
    declared space, finite rewards); the message names the env id and what it returned."""


def check_observation(task: Task, observation, *, seed: int | None = None, policy: int | None = None,
                      episode: int | None = None, step: int | None = None) -> np.ndarray:
    """The observation as an array, after checking it against ``task.observation_space``.

    Box: the space's shape; Discrete: one integer in ``[start, start + n)``. The keywords say where it
    came from, for the message: ``reset(seed=seed)``, or step ``step`` (from 1) of ``policy``'s ``episode``.
    """
    space = task.observation_space
    value = np.asarray(observation)
    if isinstance(space, spaces.Discrete):
        if value.shape == () and np.issubdtype(value.dtype, np.integer) \
                and int(space.start) <= int(value) < int(space.start + space.n):
            return value
        seen = f"value {value.tolist()!r}" if value.size <= 4 else f"shape {value.shape}"
    elif value.shape == tuple(space.shape):
        return value
    else:
        seen = f"shape {value.shape}"
    call = f"reset(seed={seed})" if step is None else f"step {step}"
    at = f" of policy {policy}, episode {episode}" if policy is not None else ""
    raise EnvContractError(f"task.env_id={task.env_id}: {call}{at} returned an observation of {seen}, which does "
                           f"not match the declared observation space {space}")


def check_reward(task: Task, reward, policy: int, episode: int, step: int) -> float:
    """The reward as a float, refused when it is NaN or infinite (``step`` counts from 1)."""
    value = float(reward)
    if not np.isfinite(value):
        raise EnvContractError(f"task.env_id={task.env_id} returned a non-finite reward ({value}) at policy "
                               f"{policy}, episode {episode}, step {step}; returns must be finite to be cached")
    return value


def check_env(task: Task, seed: int) -> None:
    """Before any return is computed: the reset observation is in the declared space, and two resets with
    the same seed give the same observation (else the cache could not serve the returns again)."""
    reset_seed = int(episode_reset_seeds(seed, np.array([0]), np.array([0]))[0])
    env = task.make_env()
    try:
        first = check_observation(task, env.reset(seed=reset_seed)[0], seed=reset_seed)
        again = check_observation(task, env.reset(seed=reset_seed)[0], seed=reset_seed)
    finally:
        env.close()
    space = task.observation_space
    if not np.array_equal(encode_observations(space, first[None]), encode_observations(space, again[None]),
                          equal_nan=True):
        raise EnvContractError(f"task.env_id={task.env_id} is not reproducible: two resets with seed {reset_seed} "
                               f"gave different observations (the env's reset ignores its seed), so the cache "
                               f"cannot serve its returns")
