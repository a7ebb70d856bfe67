"""A researcher's NumPy-vectorised env, for the ``vector`` backend's tests: gymnasium's Pendulum, K at a time.

``VectorPendulum-v0`` registers gymnasium's own ``PendulumEnv`` as its single env and :class:`VectorPendulum` as its
vector env, which does the single env's arithmetic on arrays and seeds environment i from ``seed[i]`` as the single
env seeds itself; ``VectorPendulumOneSeed-v0`` draws every environment's start from one generator, as gymnasium's own
classic-control vector envs do; ``VectorPendulumNoisy-v0`` adds unseeded noise after step 30.
"""

from __future__ import annotations

import numpy as np
from gymnasium import register
from gymnasium.spaces import Box
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space


class VectorPendulum(VectorEnv):
    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, max_episode_steps: int = 200, g: float = 10.0):
        self.num_envs, self.g, self.limit = num_envs, g, max_episode_steps
        self.max_speed, self.max_torque, self.dt, self.m, self.l = 8.0, 2.0, 0.05, 1.0, 1.0
        high = np.array([1.0, 1.0, self.max_speed], dtype=np.float32)
        self.single_action_space = Box(-self.max_torque, self.max_torque, (1,), np.float32)
        self.single_observation_space = Box(-high, high, dtype=np.float32)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.state = np.zeros((num_envs, 2))
        self.elapsed = np.zeros(num_envs, dtype=np.int64)
        self.ended = np.zeros(num_envs, dtype=bool)
        self.generators = [seeding.np_random(None)[0] for _ in range(num_envs)]

    def _start(self, i: int) -> None:
        high = np.array([np.pi, 1.0])
        self.state[i] = self.generators[i].uniform(low=-high, high=high)
        self.elapsed[i], self.ended[i] = 0, False

    def reset(self, *, seed=None, options=None):
        seeds = seed if isinstance(seed, list) else [seed] * self.num_envs
        for i, s in enumerate(seeds):
            if s is not None:
                self.generators[i] = seeding.np_random(s)[0]
            self._start(i)
        return self._observe(), {}

    def _observe(self) -> np.ndarray:
        th, thdot = self.state[:, 0], self.state[:, 1]
        return np.stack([np.cos(th), np.sin(th), thdot], axis=1).astype(np.float32)

    def step(self, actions):
        for i in np.flatnonzero(self.ended):  # next-step autoreset
            self._start(i)
        th, thdot = self.state[:, 0], self.state[:, 1]
        u = np.clip(np.asarray(actions)[:, 0], -self.max_torque, self.max_torque)
        costs = (((th + np.pi) % (2 * np.pi)) - np.pi) ** 2 + 0.1 * thdot**2 + 0.001 * (u**2)
        newthdot = thdot + (3 * self.g / (2 * self.l) * np.sin(th) + 3.0 / (self.m * self.l**2) * u) * self.dt
        newthdot = np.clip(newthdot, -self.max_speed, self.max_speed)
        self.state = np.stack([th + newthdot * self.dt, newthdot], axis=1)
        self.elapsed += 1
        truncated = self.elapsed >= self.limit
        self.ended = truncated.copy()
        return self._observe(), -costs, np.zeros(self.num_envs, dtype=bool), truncated, {}


class VectorPendulumOneSeed(VectorPendulum):
    def reset(self, *, seed=None, options=None):
        one = seeding.np_random(seed[0] if isinstance(seed, list) else seed)[0]
        self.generators = [one] * self.num_envs
        for i in range(self.num_envs):
            self._start(i)
        return self._observe(), {}


class VectorPendulumNoisy(VectorPendulum):
    """Adds noise from NumPy's global generator to the torque after step 30: not fixed by the seeds of its reset."""

    def step(self, actions):
        actions = np.asarray(actions, dtype=np.float64).copy()
        late = self.elapsed >= 30
        actions[late, 0] += 0.1 * np.random.normal(size=int(late.sum()))  # noqa: NPY002 - unseeded on purpose
        return super().step(actions)


register("VectorPendulum-v0", entry_point="gymnasium.envs.classic_control.pendulum:PendulumEnv",
         vector_entry_point="vector_pendulum:VectorPendulum", max_episode_steps=200)
register("VectorPendulumOneSeed-v0", entry_point="gymnasium.envs.classic_control.pendulum:PendulumEnv",
         vector_entry_point="vector_pendulum:VectorPendulumOneSeed", max_episode_steps=200)
register("VectorPendulumNoisy-v0", entry_point="gymnasium.envs.classic_control.pendulum:PendulumEnv",
         vector_entry_point="vector_pendulum:VectorPendulumNoisy", max_episode_steps=200)
