"""Tidy values and samples of every registered metric, from the tables of the stages that estimate them.

A metric's values come from its stage's table of values on the whole sample, and the samples of its Welch
tests from the same stage's values on consecutive policy batches (the metrics, diagnostics, occupancy,
learning-path and primitives stages: each declares its two files, :class:`taskcomplexity.stages.stage.Judged`),
or, for a metric judged on seeds (SAC's), from the per-seed summary of the learning curves: the mean over
the seeds, and one value per seed. The verdict stage reads the files and hands the tables over.
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from taskcomplexity.metrics.evaluate import TIDY_COLUMNS, sac_estimates, tidy_values
from taskcomplexity.metrics.registry import Registry
from taskcomplexity.metrics.sac import seed_summary

Tables = Mapping[str, Mapping[str, tuple[pd.DataFrame, pd.DataFrame]]]
"""Per stage estimating on policy samples (return matrices; the occupancy distances of sampled policies), per
task: (the table of its metrics' values on the whole sample, one row; the table of their values on each
policy batch). Which stages and which of their files these are is declared by each stage
(:class:`taskcomplexity.stages.stage.Judged`); the verdict stage reads them."""


def gather(
    tables: Tables,
    *,
    registry: Registry,
    curves: Mapping[str, pd.DataFrame] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame | None]:
    """(values, samples, per-seed summary) of every registered metric the tables and curves hold.

    Parameters
    ----------
    tables : mapping of stage to mapping of task id to (values, batches)
        The tables of :data:`Tables`, e.g. ``{"metrics": {"cart": (metrics, batches)}, "diagnostics": {…}}``;
        a stage or task may be missing.
    registry : Registry
        Which columns are metrics, and of which stage.
    curves : mapping of stage to pandas.DataFrame, optional
        Tidy learning curves (:mod:`taskcomplexity.metrics.sac`) of the stages whose metrics are judged on
        seeds (SAC's), each normalised with ``bounds``.
    bounds : mapping of task id to (r_min, r_max), optional
        Each task's random-policy return bounds, the normalisation of the curves.

    Returns
    -------
    (values, samples, per_seed)
        Tidy ``task``, ``metric``, ``value`` tables, and the per-seed summary of the curves (None without curves).
    """
    values, samples = [], []
    for stage, found in tables.items():
        metrics = registry.of_stage(stage)
        values.append(tidy_values({t: point for t, (point, _) in found.items()}, metrics))
        batched = [m for m in metrics if m.batched]
        samples.append(tidy_values({t: batches for t, (_, batches) in found.items()}, batched))
    per_seed = None
    for stage, frame in (curves or {}).items():
        if frame is None or frame.empty:
            continue
        per_seed = seed_summary(frame, rwg_bounds=dict(bounds or {}))
        seed_values, seed_samples = sac_estimates(per_seed, registry.of_stage(stage))
        values.append(seed_values)
        samples.append(seed_samples)
    return _concat(values), _concat(samples), per_seed


def _concat(parts: list[pd.DataFrame]) -> pd.DataFrame:
    parts = [p for p in parts if not p.empty]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(TIDY_COLUMNS))


def gather_details(tables: Tables, *, registry: Registry) -> pd.DataFrame:
    """The shown details (e.g. H(R), H(O)) of every registered metric, per task, from the point files.

    Parameters
    ----------
    tables : as for :func:`gather`
    registry : Registry

    Returns
    -------
    pandas.DataFrame
        ``task``, ``quantity`` (the detail's name), ``metric`` (the metric it belongs to), ``value``.
    """
    rows = []
    for stage, task, point in _point_tables(tables):
        for metric in registry.of_stage(stage):
            for detail in metric.details:
                if detail.shown and detail.name in point.columns:
                    rows.append({"task": task, "quantity": detail.name, "metric": metric.name,
                                 "value": float(point[detail.name].iloc[0])})
    return pd.DataFrame(rows, columns=["task", "quantity", "metric", "value"])


def gather_policies(tables: Tables, *, registry: Registry) -> dict[tuple[str, str], int]:
    """N of the sample behind each (metric, task) value of the return-matrix stages (their point files'
    ``policies``): the ceiling ln N of a value, and the scale its N-to-resolve starts from.

    Parameters
    ----------
    tables : as for :func:`gather`
    registry : Registry

    Returns
    -------
    dict of (metric, task) to int
    """
    found = {}
    for stage, task, point in _point_tables(tables):
        if "policies" in point.columns:
            for metric in registry.of_stage(stage):
                found[(metric.name, task)] = int(point["policies"].iloc[0])
    return found


def _point_tables(tables: Tables):
    """(stage, task, point-value table) of every stage's task in ``tables``."""
    for stage, found in tables.items():
        for task, (point, _) in found.items():
            yield stage, task, point
