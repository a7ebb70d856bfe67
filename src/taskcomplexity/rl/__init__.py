"""Soft Actor-Critic (+ Hindsight Experience Replay) with TorchRL: the empirical difficulty of a task.

Any :class:`~taskcomplexity.tasks.base.Task` with a Box action space: the reaching arms (with HER
on their goal-conditioned view) and any gymnasium id. ``train_sac(task, settings, seed=...)`` returns
a tidy learning curve (see :data:`~taskcomplexity.rl.train.CURVE_COLUMNS`); ``train_sac_seeds``
trains several seeds together. Discrete action spaces are not trained (``sac_skip_reason``).
"""

import warnings

with warnings.catch_warnings():
    # torchrl 0.14.1 warns about its own deprecated weight-updater classes while it defines them, on
    # import of torchrl.collectors; nothing here uses them. Import it once, quietly.
    warnings.filterwarnings(
        "ignore", message=r"Creating \w+ which inherits from WeightUpdaterBase", category=DeprecationWarning
    )
    import torchrl.collectors  # noqa: F401

from taskcomplexity.rl.settings import (  # noqa: E402
    SACSettings,
    has_goal_view,
    protocol_variants,
    sac_skip_reason,
    with_budget,
)
from taskcomplexity.rl.train import CURVE_COLUMNS, train_sac, train_sac_run, train_sac_seeds  # noqa: E402

__all__ = [
    "CURVE_COLUMNS",
    "SACSettings",
    "has_goal_view",
    "protocol_variants",
    "sac_skip_reason",
    "train_sac",
    "train_sac_run",
    "train_sac_seeds",
    "with_budget",
]
