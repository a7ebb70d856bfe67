"""A composed config's task: the seam between the ``task``/``arm``/``reward`` config groups and the Task types."""

from __future__ import annotations

from typing import Any

from taskcomplexity.config import build, plain
from taskcomplexity.errors import ConfigError

TASK_KINDS = ("reaching", "gym")


def task_from_config(cfg: Any):
    """The :class:`~taskcomplexity.tasks.base.Task` of a composed config.

    ``task.kind`` chooses: ``reaching`` builds a :class:`~taskcomplexity.tasks.spec.TaskSpec` from
    the ``arm`` and ``reward`` groups and ``max_steps``; ``gym`` a
    :class:`~taskcomplexity.tasks.gym_task.GymTask` from ``task.env_id``, ``task.kwargs``,
    ``task.max_steps`` and ``task.name``.
    """
    node = plain(cfg)
    task_node = dict(node.get("task") or {"kind": "reaching"})
    kind = task_node.pop("kind", "reaching")
    if kind == "reaching":
        from taskcomplexity.tasks.spec import ArmSpec, RewardSpec, TaskSpec

        if task_node:
            raise ConfigError(f"task.{sorted(task_node)[0]} is not a key of task=reaching (the arm and reward "
                              "groups and max_steps compose the reaching tasks)")
        arm = build(ArmSpec, node["arm"], "arm")
        reward = build(RewardSpec, node["reward"], "reward")
        max_steps = node.get("max_steps", 50)
        if isinstance(max_steps, bool) or not isinstance(max_steps, int):
            raise ConfigError(f"max_steps must be an integer >= 1, got {max_steps!r}")
        return TaskSpec(arm=arm, reward=reward, max_steps=max_steps).validate()
    if kind == "gym":
        from taskcomplexity.tasks.gym_task import GymTask

        if task_node.get("env_id") is None:
            raise ConfigError("task.env_id is required with task=gym (a gymnasium id, e.g. task.env_id=Pendulum-v1)")
        return build(GymTask, task_node, "task")
    raise ConfigError(f"task.kind must be one of {list(TASK_KINDS)}, got {kind!r}")
