"""A researcher's own task, as docs/tutorials/own-task.md uses it: a point mass reaching a goal on a line.

The agent pushes a unit mass on a line of half-width 1 (force in [-1, 1], time step 0.05 s, velocity
damped by 10 % per step) towards a goal drawn uniformly in [-0.8, 0.8] at reset. Observation:
(position, velocity, goal). Reward per step: −|position − goal|. The episode ends when the mass is
within ``tolerance`` of the goal, and is truncated after 50 steps. A smaller tolerance is a harder task.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces


class Reach1D(gym.Env):
    """Point mass on a line reaching a random goal; ``tolerance`` (m) sets how close counts as reached."""

    metadata = {"render_modes": []}

    def __init__(self, tolerance: float = 0.1):
        self.tolerance = float(tolerance)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64)
        self._state = np.zeros(3)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        goal = self.np_random.uniform(-0.8, 0.8)
        self._state = np.array([0.0, 0.0, goal])
        return self._state.copy(), {}

    def step(self, action):
        force = float(np.clip(np.asarray(action, dtype=np.float64).reshape(-1)[0], -1.0, 1.0))
        position, velocity, goal = self._state
        velocity = 0.9 * velocity + 0.05 * force
        position = float(np.clip(position + 0.05 * velocity * 20.0, -1.0, 1.0))
        self._state = np.array([position, velocity, goal])
        distance = abs(position - goal)
        return self._state.copy(), -distance, distance < self.tolerance, False, {}


gym.register("Reach1D-v0", entry_point=Reach1D, max_episode_steps=50)
