"""Reaching tasks: specs, URDF arms, the PyBullet reference environment and the batched backend."""

from taskcomplexity.tasks.spec import REWARDS, ArmSpec, RewardSpec, TaskSpec, arm_presets, make_task, preset_tasks

__all__ = ["REWARDS", "ArmSpec", "RewardSpec", "TaskSpec", "arm_presets", "make_task", "preset_tasks"]
