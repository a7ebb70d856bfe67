"""Evaluate registered metrics: point estimates, bootstrap draws, per-batch estimates, per-seed SAC values.

This is the one place where a metric's function is called; the stages choose which metrics
(:meth:`~taskcomplexity.metrics.registry.Registry.of_stage`) and store the tables.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from taskcomplexity.metrics._validation import check_int
from taskcomplexity.metrics.bootstrap import bootstrap_indices
from taskcomplexity.metrics.registry import Metric
from taskcomplexity.metrics.sample import Estimation, Sample

TIDY_COLUMNS = ("task", "metric", "value")
"""Columns of a tidy table of metric values."""


def point_estimates(sample: Sample, metrics: Sequence[Metric]) -> dict[str, float]:
    """Every metric and its details on the whole sample: ``{name: value}`` (units of each metric)."""
    row: dict[str, float] = {}
    for metric in metrics:
        row[metric.name] = float(metric.compute(sample))
        for detail in metric.details:
            row[detail.name] = detail.compute(sample)
    return row


def bootstrap_estimates(sample: Sample, metrics: Sequence[Metric]) -> pd.DataFrame:
    """Bootstrap draws of every bootstrapped metric of ``metrics``.

    Returns
    -------
    pandas.DataFrame, one row per resample
        ``resample`` (0-based) and one column per bootstrapped metric. Resample b draws the
        policies of :func:`~taskcomplexity.metrics.bootstrap.bootstrap_indices` (seed
        ``estimation.bootstrap_seed``) for every metric, fast or not.
    """
    chosen = [m for m in metrics if m.bootstrapped]
    resamples = sample.estimation.resamples
    table = {"resample": np.arange(resamples)}
    for metric in chosen:
        if metric.draws is not None:
            table[metric.name] = np.asarray(metric.draws(sample), dtype=np.float64)
            continue
        indices = bootstrap_indices(sample.returns.shape[0], resamples=resamples,
                                    seed=sample.estimation.bootstrap_seed)
        table[metric.name] = np.array([float(metric.compute(sample.subsample(i))) for i in indices])
    return pd.DataFrame(table)


def batch_estimates(
    returns: object, metrics: Sequence[Metric], *, batches: int = 5, estimation: Estimation | None = None
) -> pd.DataFrame:
    """Every batched metric of ``metrics`` on consecutive batches of policies (the Welch tests' samples).

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n in sampling order.
    metrics : sequence of Metric
        Metrics to consider; those with ``batched`` are estimated.
    batches : int, default 5
        Number of batches; policies ``0 … N-1`` are split into consecutive blocks of N/batches
        (sizes differ by at most one, as :func:`numpy.array_split`). Every batch needs at least
        2 policies.
    estimation : Estimation, optional
        Estimator settings (default :class:`~taskcomplexity.metrics.sample.Estimation()`).

    Returns
    -------
    pandas.DataFrame, one row per batch
        ``batch`` (0-based), ``policies`` (batch size) and one column per batched metric.
    """
    sample = Sample(returns, estimation or Estimation())
    batches = check_int(batches, "batches", minimum=1)
    n_policies = sample.returns.shape[0]
    if n_policies < 2 * batches:
        raise ValueError(f"batches must be at most N/2 = {n_policies // 2} so that every batch holds at least "
                         f"2 policies, got {batches}")
    chosen = [m for m in metrics if m.batched]
    rows = []
    for batch, policies in enumerate(np.array_split(np.arange(n_policies), batches)):
        part = sample.subsample(policies, batch=batch)
        rows.append({"batch": batch, "policies": policies.size,
                     **{m.name: float(m.compute(part)) for m in chosen}})
    return pd.DataFrame(rows, columns=["batch", "policies", *(m.name for m in chosen)])


def tidy_values(rows: dict[str, pd.DataFrame], metrics: Sequence[Metric]) -> pd.DataFrame:
    """Tidy ``task, metric, value`` from one table per task holding a column per metric.

    Parameters
    ----------
    rows : mapping of task id to pandas.DataFrame
        Per task, a table with one column per metric (one row: point values; several: samples).
    metrics : sequence of Metric
        Metrics to take (those missing from a task's table are skipped).
    """
    parts = [
        pd.DataFrame({"task": task, "metric": m.name, "value": table[m.name].to_numpy(dtype=np.float64)})
        for task, table in rows.items()
        for m in metrics
        if m.name in table.columns
    ]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(TIDY_COLUMNS))


def sac_estimates(per_seed: pd.DataFrame, metrics: Sequence[Metric]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Values and per-seed samples of the SAC metrics.

    Parameters
    ----------
    per_seed : pandas.DataFrame
        :func:`~taskcomplexity.metrics.sac.seed_summary` of every task.
    metrics : sequence of Metric
        The stage-``sac`` metrics.

    Returns
    -------
    (values, samples) : pandas.DataFrame, pandas.DataFrame
        Tidy ``task``, ``metric``, ``value``: the mean over the finite seeds, and one row per
        finite seed. A task without a finite seed for a metric has no row.
    """
    rows = []
    for task, table in per_seed.groupby("task", sort=False):
        for metric in metrics:
            values = np.asarray(metric.compute(table), dtype=np.float64)
            rows += [{"task": task, "metric": metric.name, "value": float(v)} for v in values[np.isfinite(values)]]
    samples = pd.DataFrame(rows, columns=list(TIDY_COLUMNS))
    values = samples.groupby(["task", "metric"], sort=False, as_index=False)["value"].mean()
    return values[list(TIDY_COLUMNS)], samples
