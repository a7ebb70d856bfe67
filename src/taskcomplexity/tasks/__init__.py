"""Reaching tasks: specs, URDF arms, the PyBullet reference environment and the batched backend."""

from taskcomplexity.tasks.spec import REWARDS, STUDY_TASKS, ArmSpec, RewardSpec, TaskSpec, arm_presets, make_task

__all__ = ["REWARDS", "STUDY_TASKS", "ArmSpec", "RewardSpec", "TaskSpec", "arm_presets", "make_task"]
