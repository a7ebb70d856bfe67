"""A slow simulator for the cluster tests: a point drifting on a line that takes ``SLOW_DRIFT_STEP_SECONDS`` of wall
time per step (0 when unset), so that a job lasts long enough to be cancelled or to reach its time limit mid-shard
while costing no CPU. The delay changes no return: a run with it and one without share their key and their bytes.
"""
import os
import time

import gymnasium as gym
import numpy as np


class SlowDrift(gym.Env):
    def __init__(self):
        self.observation_space = gym.spaces.Box(-10.0, 10.0, (1,), dtype=np.float64)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), dtype=np.float64)
        self.delay = float(os.environ.get("SLOW_DRIFT_STEP_SECONDS", "0"))

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = self.np_random.uniform(-1.0, 1.0, 1)
        return self.x.copy(), {}

    def step(self, action):
        time.sleep(self.delay)
        self.x = np.clip(self.x + 0.1 * np.asarray(action), -10.0, 10.0)
        return self.x.copy(), -abs(float(self.x[0])), False, False, {}


gym.register("SlowDrift-v0", entry_point=SlowDrift, max_episode_steps=20)
