"""taskcomplexity: how hard is this task, and can we trust the metric that says so?

Importing the package registers the reaching task of every arm preset (``conf/arm/``) with each reward
it allows with gymnasium, e.g. ``gymnasium.make("taskcomplexity/TwoLink-Sparse-v0")``.
"""

from taskcomplexity.tasks.registration import gym_ids, register_tasks
from taskcomplexity.tasks.spec import make_task, preset_tasks, task_from_id

__version__ = "0.1.0"

register_tasks()

__all__ = ["__version__", "gym_ids", "make_task", "preset_tasks", "task_from_id"]
