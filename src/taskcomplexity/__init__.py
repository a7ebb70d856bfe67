"""taskcomplexity: how hard is this task, and can we trust the metric that says so?

Importing the package registers the seven reaching tasks with gymnasium, e.g.
``gymnasium.make("taskcomplexity/TwoLink-Sparse-v0")``.
"""

from taskcomplexity.tasks.registration import GYM_IDS, register_tasks
from taskcomplexity.tasks.spec import STUDY_TASKS, make_task, task_from_id

__version__ = "0.1.0"

register_tasks()

__all__ = ["GYM_IDS", "STUDY_TASKS", "__version__", "make_task", "task_from_id"]
