"""The Task seam: what every measurable task provides, whatever simulates it.

A task is anything RWG, SAC and the report can run: one of the paper's reaching arms
(:class:`~taskcomplexity.tasks.spec.TaskSpec`) or any gymnasium id (:class:`~taskcomplexity.tasks.gym_task.GymTask`).
The layers above (RWG backends, the SAC stage, the study and its report) talk to a task only through
this protocol, so a new task needs no change there.

Episode e of policy n starts from the reset seed :func:`taskcomplexity.seeding.episode_reset_seeds`
(seed, n, e): a pure function of the three, shared by every backend, chunking and sharding.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import gymnasium
import numpy as np
from gymnasium import spaces

from taskcomplexity.errors import ConfigError

SUPPORTED_SPACES = ("Box", "Discrete")


@runtime_checkable
class Task(Protocol):
    """A task the pipeline can measure.

    Attributes
    ----------
    task_id : str
        Short id used in tables, logs and figure files (e.g. ``two_link-sparse``, ``Pendulum-v1``).
    env_id : str
        The gymnasium id the task is made from (``"pkg.module:Env-v0"`` ids import ``pkg.module``).
    max_steps : int
        Episode length limit (truncation), environment steps.
    observation_space, action_space : gymnasium.Space
        Box or Discrete.
    observation_size, action_size : int
        Width of the policy's input (flattened observation; one-hot for Discrete) and output (action
        dimensions; one output per action for Discrete).
    """

    @property
    def task_id(self) -> str: ...

    @property
    def env_id(self) -> str: ...

    @property
    def max_steps(self) -> int: ...

    @property
    def observation_space(self) -> gymnasium.Space: ...

    @property
    def action_space(self) -> gymnasium.Space: ...

    @property
    def observation_size(self) -> int: ...

    @property
    def action_size(self) -> int: ...

    def make_env(self, **kwargs: Any) -> gymnasium.Env:
        """A fresh single environment with the task's time limit."""
        ...

    def identity(self) -> dict:
        """Everything about the task that can change its returns (hashed into cache keys)."""
        ...


def check_space(space: gymnasium.Space, what: str, where: str) -> None:
    """Refuse spaces other than Box and Discrete, naming the key and the space."""
    if isinstance(space, spaces.Box):
        if what == "action" and not (np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))):
            raise ConfigError(f"{where}: the action space {space} has infinite bounds; random policies need finite "
                              "bounds to scale their actions into")
        return
    if isinstance(space, spaces.Discrete):
        return
    raise ConfigError(f"{where}: the {what} space {space} is not supported (allowed: {', '.join(SUPPORTED_SPACES)})")


def flat_size(space: gymnasium.Space) -> int:
    """Policy width of a Box (its number of elements) or a Discrete space (its number of values)."""
    if isinstance(space, spaces.Discrete):
        return int(space.n)
    return int(np.prod(space.shape, dtype=np.int64))


def encode_observations(space: gymnasium.Space, observations: np.ndarray) -> np.ndarray:
    """Observations as the policy's float64 input.

    Parameters
    ----------
    observations : ndarray (K, *space.shape) for Box, (K,) int for Discrete

    Returns
    -------
    ndarray (K, flat_size(space)) float64; Discrete values one-hot.
    """
    if isinstance(space, spaces.Discrete):
        index = np.asarray(observations, dtype=np.int64).reshape(-1) - int(space.start)
        out = np.zeros((index.size, int(space.n)))
        out[np.arange(index.size), index] = 1.0
        return out
    observations = np.asarray(observations, dtype=np.float64)
    return observations.reshape(observations.shape[0], -1)


def decode_actions(space: gymnasium.Space, outputs: np.ndarray) -> np.ndarray:
    """Policy outputs in (−1, 1) as actions of ``space``.

    Parameters
    ----------
    outputs : ndarray (K, flat_size(space))

    Returns
    -------
    ndarray (K, *space.shape) of the space's dtype for Box (the outputs mapped affinely from (−1, 1)
    onto [low, high]); ndarray (K,) int64 for Discrete (argmax of the outputs, plus ``start``).
    """
    outputs = np.asarray(outputs, dtype=np.float64)
    if isinstance(space, spaces.Discrete):
        return np.argmax(outputs, axis=-1).astype(np.int64) + int(space.start)
    low = space.low.astype(np.float64).reshape(-1)
    high = space.high.astype(np.float64).reshape(-1)
    actions = low + (outputs + 1.0) * 0.5 * (high - low)
    return actions.reshape((outputs.shape[0], *space.shape)).astype(space.dtype, copy=False)
