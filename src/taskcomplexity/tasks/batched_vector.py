"""The fast backend as a gymnasium vector environment: B instances of a reaching task stepped by one kernel call.

:class:`BatchedReachingVector` is what ``gymnasium.vector.SyncVectorEnv`` of B
:class:`~taskcomplexity.tasks.pybullet_env.ReachingEnv` (each behind ``TimeLimit``, and behind
:class:`~taskcomplexity.tasks.goal_env.GoalReachingEnv` when goal-conditioned) is, with the physics, observation
and reward of every instance computed by :class:`~taskcomplexity.tasks.batched.BatchedReaching`'s fused kernel
instead of B PyBullet worlds:

- the same reset draws: instance i keeps its own ``np.random.Generator`` (``gymnasium.utils.seeding.np_random``
  of its seed), and a reset maps four of its U[0, 1) variates to the state (:func:`mechanics.initial_state`), as
  ``ReachingEnv.reset`` does;
- the same episode end: terminated on success (d < threshold) and truncated once an instance has taken
  ``task.max_steps`` steps (as ``TimeLimit`` does: both can hold at once);
- auto-reset disabled (``autoreset_mode = DISABLED``): the caller resets finished instances with
  ``reset(options={"reset_mask": mask})``, as TorchRL's ``GymWrapper`` does.

Only contact-free tasks: the obstacle task's contacts need PyBullet's solver (its exact hand-over), so it is
refused. Observations, rewards and episode ends equal the PyBullet vector's to the kernel's tolerance
(1e-6 on the contact-free tasks; ``tests/tasks/test_batched_vector.py`` steps both side by side).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
import torch
from gymnasium import spaces
from gymnasium.utils.seeding import np_random

from taskcomplexity.errors import ConfigError
from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.goal_env import GOAL_SIZE, observation_size, split_observation
from taskcomplexity.tasks.spec import TaskSpec


class BatchedReachingVector(gymnasium.vector.VectorEnv):
    """``num_envs`` instances of a contact-free reaching task as one gymnasium vector environment.

    Observations are float64 arrays (B, obs_size) (or a dict of them), rewards float64 (B,), ``terminated`` and
    ``truncated`` bool (B,); the info dict is empty (the reaching arms report success through the observation).

    Parameters
    ----------
    task : TaskSpec
        A reaching task without an obstacle.
    num_envs : int
        B.
    goal_conditioned : bool
        Observations as the goal-conditioned view's dict (``observation``, ``achieved_goal``, ``desired_goal``;
        :mod:`taskcomplexity.tasks.goal_env`) instead of the task observation.
    """

    metadata = {"autoreset_mode": gymnasium.vector.AutoresetMode.DISABLED}

    def __init__(self, task: TaskSpec, num_envs: int, *, goal_conditioned: bool = False):
        if task.arm.obstacle is not None:
            raise ConfigError(f"task {task.task_id} has an obstacle: its contacts need PyBullet "
                              "(use the pybullet backend)")
        self.task = task.validate()
        self.num_envs = int(num_envs)
        self.goal_conditioned = goal_conditioned
        self.autoreset_mode = gymnasium.vector.AutoresetMode.DISABLED
        self._batch = BatchedReaching(task, self.num_envs)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        dof = task.arm.dof
        self.single_action_space = spaces.Box(-1.0, 1.0, (dof,), dtype=np.float64)
        if goal_conditioned:
            box = spaces.Box(-np.inf, np.inf, (GOAL_SIZE,), dtype=np.float64)
            self.single_observation_space = spaces.Dict({
                "observation": spaces.Box(-np.inf, np.inf, (observation_size(task),), dtype=np.float64),
                "achieved_goal": box,
                "desired_goal": box,
            })
        else:
            self.single_observation_space = spaces.Box(-np.inf, np.inf, (task.observation_size,), dtype=np.float64)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, self.num_envs)

    # -- gymnasium vector API ----------------------------------------------------------------
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
        """Reset the instances of ``options["reset_mask"]`` (all of them without it); returns (observations, {}).

        ``seed``: None, an int (instance i gets ``seed + i``) or one seed (or None) per instance, as
        ``SyncVectorEnv.reset`` takes it; a seeded instance restarts its generator, the others continue theirs.
        """
        if seed is None:
            seed = [None] * self.num_envs
        elif isinstance(seed, int):
            seed = [seed + i for i in range(self.num_envs)]
        if len(seed) != self.num_envs:
            raise ValueError(f"{len(seed)} seeds for {self.num_envs} environments")
        mask = (options or {}).get("reset_mask")
        mask = np.ones(self.num_envs, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        index = np.flatnonzero(mask)
        uniforms = np.empty((len(index), 4))
        for row, i in enumerate(index):
            if seed[i] is not None or self._rngs[i] is None:
                self._rngs[i], _ = np_random(seed[i])
            uniforms[row] = self._rngs[i].random(4)
        joint_angles, target = mechanics.initial_state(self.task.arm, uniforms)
        self._batch.reset(torch.from_numpy(joint_angles), torch.from_numpy(target), index=torch.from_numpy(index))
        return self._observations(), {}

    def step(self, actions):
        """Advance every instance one step; returns (observations, rewards, terminated, truncated, {})."""
        actions = np.clip(np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1), -1.0, 1.0)
        _, reward, done = self._batch.step(torch.from_numpy(actions))
        truncated = self._batch.steps.numpy() >= self.task.max_steps
        return self._observations(), reward.numpy().copy(), done.numpy().copy(), truncated.copy(), {}

    # -- pieces --------------------------------------------------------------------------------
    def _observations(self):
        observation = self._batch.observation.numpy().copy()
        return split_observation(self.task, observation) if self.goal_conditioned else observation
