"""How many bins PIC's histograms take under ``metrics.bins=auto``: the paper's ratio of returns per bin.

Re-exported by :mod:`taskcomplexity.metrics.pic`; a module of its own so that reading the metrics settings
(``metrics.bins``) imports no estimator.
"""

from __future__ import annotations

import numpy as np

RETURNS_PER_BIN = 50
"""The paper's ratio N·M / B of returns per bin: 10⁴ policies × 500 episodes over 10⁵ bins."""


def auto_bins(policies: int, episodes: int) -> int:
    """B at the paper's ratio of returns per bin: ``max(2, N·M // 50)`` (10⁵ at N = 10⁴, M = 500).

    With many more bins than that, most returns sit alone in their bin and the plug-in PIC rises to
    its ceiling ln N whatever the task (it measures the estimator); with this ratio it does not.
    """
    for name, value in (("policies", policies), ("episodes", episodes)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return max(2, int(policies) * int(episodes) // RETURNS_PER_BIN)
