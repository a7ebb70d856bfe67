"""Soft Actor-Critic (+ Hindsight Experience Replay) with TorchRL: the empirical difficulty of a task.

``train_sac(task, settings, seed=...)`` returns a tidy learning curve (see
:data:`~taskcomplexity.rl.train.CURVE_COLUMNS`); ``train_sac_seeds`` trains several seeds together.
"""

import warnings

with warnings.catch_warnings():
    # torchrl 0.14.1 warns about its own deprecated weight-updater classes while it defines them, on
    # import of torchrl.collectors; nothing here uses them. Import it once, quietly.
    warnings.filterwarnings(
        "ignore", message=r"Creating \w+ which inherits from WeightUpdaterBase", category=DeprecationWarning
    )
    import torchrl.collectors  # noqa: F401

from taskcomplexity.rl.settings import PAPER_BUDGETS, SACSettings, protocol_variants  # noqa: E402
from taskcomplexity.rl.train import CURVE_COLUMNS, train_sac, train_sac_seeds  # noqa: E402

__all__ = ["CURVE_COLUMNS", "PAPER_BUDGETS", "SACSettings", "protocol_variants", "train_sac", "train_sac_seeds"]
