"""taskcomplexity: how hard is this task, and can we trust the metric that says so?

Importing the package registers the seven reaching tasks with gymnasium, e.g.
``gymnasium.make("taskcomplexity/TwoLink-Sparse-v0")``.
"""

import os

# The batched backend alternates torch's OpenMP regions with numba's parallel kernel; OpenMP threads
# that spin-wait after a region would steal the cores from the other. Set before torch loads OpenMP.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from taskcomplexity.tasks.registration import GYM_IDS, register_tasks  # noqa: E402
from taskcomplexity.tasks.spec import STUDY_TASKS, make_task, task_from_id  # noqa: E402

__version__ = "0.1.0"

register_tasks()

__all__ = ["GYM_IDS", "STUDY_TASKS", "__version__", "make_task", "task_from_id"]
