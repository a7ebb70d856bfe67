"""Reaching tasks: specs, URDF arms, the PyBullet reference environment and the batched backend."""

from taskcomplexity.tasks.spec import ARMS, REWARDS, STUDY_TASKS, ArmSpec, RewardSpec, TaskSpec, make_task

__all__ = ["ARMS", "REWARDS", "STUDY_TASKS", "ArmSpec", "RewardSpec", "TaskSpec", "make_task"]
