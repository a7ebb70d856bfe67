"""The tables of a stage whose metrics are estimated on a sample of policies (beyond the return matrix).

The occupancy and learning-path stages estimate their registry metrics on their own samples
(:class:`~taskcomplexity.metrics.occupancy.OccupancySample`,
:class:`~taskcomplexity.metrics.learning_path.LearningPath`). Any such sample has ``subsample(rows,
batch=...)``, so the point values, the bootstrap over policies and the Welch tests' policy batches
come out of one function, in the same layout as the metrics stage's tables.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from taskcomplexity.metrics.bootstrap import bootstrap_indices, summarise_bootstrap
from taskcomplexity.metrics.registry import Metric


def policy_sample_tables(sample: Any, metrics: Sequence[Metric], *, policies: int, resamples: int, seed: int,
                         batches: int) -> tuple[dict[str, float], pd.DataFrame, pd.DataFrame]:
    """(point row, bootstrap draws, batch estimates) of ``metrics`` on a sample of ``policies`` policies.

    Parameters
    ----------
    sample : object with ``subsample(rows, batch=None)``
        What the metrics' ``compute`` (and ``draws``) read.
    metrics : sequence of Metric
    policies : int
        Number of policies (rows) of the sample.
    resamples, seed : int
        Bootstrap: the policies of :func:`~taskcomplexity.metrics.bootstrap.bootstrap_indices` (a metric's
        own ``draws`` when it has them, which must use the same indices).
    batches : int
        Consecutive policy batches (sizes as :func:`numpy.array_split`).

    Returns
    -------
    row : dict
        Each metric and its details on the whole sample, and ``<metric>_mean``, ``_sd``, ``_ci_low``,
        ``_ci_high`` of each bootstrapped one.
    draws : pandas.DataFrame
        ``resample`` and one column per bootstrapped metric.
    per_batch : pandas.DataFrame
        ``batch``, ``policies`` and one column per batched metric.
    """
    row: dict[str, float] = {}
    for metric in metrics:
        row[metric.name] = float(metric.compute(sample))
        row.update({d.name: float(d.compute(sample)) for d in metric.details})
    draws: dict[str, np.ndarray] = {"resample": np.arange(resamples)}
    indices = None
    for metric in (m for m in metrics if m.bootstrapped):
        if metric.draws is not None:
            draws[metric.name] = np.asarray(metric.draws(sample), dtype=np.float64)
            continue
        if indices is None:
            indices = bootstrap_indices(policies, resamples=resamples, seed=seed)
        draws[metric.name] = np.array([float(metric.compute(sample.subsample(i))) for i in indices])
    draws = pd.DataFrame(draws)
    bootstrapped = {m.name: row[m.name] for m in metrics if m.bootstrapped}
    if bootstrapped:
        for _, s in summarise_bootstrap(draws, bootstrapped).iterrows():
            for column in ("mean", "sd", "ci_low", "ci_high"):
                row[f"{s['metric']}_{column}"] = s[column]
    batched = [m for m in metrics if m.batched]
    rows = [{"batch": b, "policies": part.size,
             **{m.name: float(m.compute(sample.subsample(part, batch=b))) for m in batched}}
            for b, part in enumerate(np.array_split(np.arange(policies), batches))]
    per_batch = pd.DataFrame(rows, columns=["batch", "policies", *(m.name for m in batched)])
    return row, draws, per_batch
