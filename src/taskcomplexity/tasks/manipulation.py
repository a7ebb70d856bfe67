"""Meta-World's robot-manipulation tasks (Farama's ``metaworld`` 3.x, MuJoCo 3) as gymnasium envs, seeded per episode.

``taskcomplexity/MetaWorld-v3`` with ``task_name=<name>`` (one of the 50 tasks of MT50, without its ``-v3``) and
``reward=dense|sparse`` is one Sawyer-arm task: observation 39 values (hand, gripper, two objects, the previous
frame's 18 and the goal), action 4 values in [−1, 1] (hand displacement, gripper), episodes of 500 steps (the
benchmark's ``max_path_length``; Meta-World never terminates an episode early).

Rewards, per step:

- ``dense``: Meta-World's own shaped reward (its v2 reward functions, 0 to 10);
- ``sparse``: ``info["success"] − 1``: 0 on a step whose state counts as solved, −1 otherwise, as the paper's sparse
  reaching reward is. An episode's sparse return is minus the number of steps not solved (−500: never solved).

Seeding: Meta-World's own ``reset`` ignores its ``seed`` argument, and the ``Meta-World/MT1`` id draws its 50 goals
from NumPy's global generator when it is made. Here every ``reset(seed=s)`` reseeds the env's generator with ``s``
and draws a new object and goal position from it (the task's random reset space, as Meta-World's multi-task
benchmarks sample them, goal in the observation), so an episode is a function of its reset seed alone. The RWG's
replay check (:mod:`taskcomplexity.rwg.env_checks`) holds every run to that.

Needs the ``metaworld`` extra (``pip install -e '.[metaworld]'``).
"""

from __future__ import annotations

import difflib
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import seeding

from taskcomplexity.errors import ConfigError
from taskcomplexity.extras import install_command

METAWORLD_EXTRA = install_command("metaworld")
REWARDS = ("dense", "sparse")
EPISODE_STEPS = 500
"""Meta-World's ``max_path_length``: every episode is this long."""


def metaworld_environments() -> dict[str, type]:
    """Meta-World's 50 task classes by name without ``-v3`` (MT50's order); a one-line error when it is missing."""
    try:
        from metaworld.env_dict import ALL_V3_ENVIRONMENTS
    except ImportError as err:
        raise gymnasium.error.DependencyNotInstalled(
            f"Meta-World's tasks need metaworld: {METAWORLD_EXTRA}") from err
    return {name.removesuffix("-v3"): cls for name, cls in ALL_V3_ENVIRONMENTS.items()}


class MetaWorldEnv(gymnasium.Env):
    """One Meta-World task whose episodes follow from their reset seeds (see the module docstring).

    Parameters
    ----------
    task_name : str
        The task, e.g. ``reach`` or ``pick-place`` (MT50's names without ``-v3``).
    reward : {'dense', 'sparse'}
        Meta-World's shaped reward, or ``info["success"] − 1``.
    """

    metadata = {"render_modes": []}
    environments_in_flight = 32
    """The gym backend's pool size for these envs: each takes some 0.1 s to build and 0.4 ms to step, so a pool of
    32 already makes the policies' forward pass a small part of a step, and builds 8 times fewer envs than the
    default 256."""

    def __init__(self, task_name: str = "reach", reward: str = "dense"):
        classes = metaworld_environments()
        if task_name not in classes:
            close = difflib.get_close_matches(str(task_name), list(classes), n=3, cutoff=0.5)
            hint = f"; closest: {', '.join(close)}" if close else ""
            raise ConfigError(f"task.kwargs.task_name={task_name!r} is not a Meta-World task "
                              f"(one of MT50's 50 names without -v3, e.g. reach, pick-place{hint})")
        if reward not in REWARDS:
            raise ConfigError(f"task.kwargs.reward={reward!r} is not allowed (allowed: {', '.join(REWARDS)})")
        env = classes[task_name]()
        env._partially_observable = False  # the goal is in the observation, as in MT1/MT10/MT50
        del env.sawyer_observation_space  # a cached property of the observability: recompute it
        env._set_task_called = True
        env._freeze_rand_vec = False  # a new object and goal position at every reset ...
        env.seeded_rand_vec = True  # ... drawn from the env's generator, which reset(seed=…) reseeds
        self._env = env
        self.task_name, self.reward = task_name, reward
        self.observation_space = env.observation_space
        self.action_space = env.action_space

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if seed is not None:
            self._env.np_random, _ = seeding.np_random(seed)
        observation, info = self._env.reset()
        return observation, info

    def step(self, action: np.ndarray):
        observation, reward, terminated, truncated, info = self._env.step(action)
        if self.reward == "sparse":
            reward = float(info["success"]) - 1.0
        return observation, float(reward), terminated, truncated, info

    def close(self) -> None:
        self._env.close()
