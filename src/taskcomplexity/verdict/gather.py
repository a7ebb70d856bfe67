"""Tidy values and samples of every registered metric, from the tables of the stages that estimate them.

========================  ======================================  ==================================
stage of the metric       values                                  samples of the Welch test
========================  ======================================  ==================================
metrics                   ``metrics.parquet`` (whole sample)      ``batches.parquet`` (policy batches)
diagnostics               ``estimators.parquet`` (whole sample)   its ``batches.parquet``
occupancy                 ``occupancy.parquet`` (K policies)      its ``batches.parquet``
learning_path             ``learning_path.parquet`` (path mean)   its ``batches.parquet``
primitives                ``primitives.parquet`` (DMP family)     its ``batches.parquet``
sac                       mean over seeds                         one value per seed
========================  ======================================  ==================================
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from taskcomplexity.metrics.evaluate import TIDY_COLUMNS, sac_estimates, tidy_values
from taskcomplexity.metrics.registry import Registry
from taskcomplexity.metrics.sac import seed_summary

RETURN_MATRIX_STAGES = {"metrics": ("metrics.parquet", "batches.parquet"),
                        "diagnostics": ("estimators.parquet", "batches.parquet"),
                        "occupancy": ("occupancy.parquet", "batches.parquet"),
                        "learning_path": ("learning_path.parquet", "batches.parquet"),
                        "primitives": ("primitives.parquet", "batches.parquet")}
"""Per stage estimating on policy samples (return matrices; the occupancy distances of sampled
policies): (file of the point values, file of the per-batch samples)."""


def gather(
    tables: Mapping[str, Mapping[str, Mapping[str, pd.DataFrame]]],
    *,
    registry: Registry,
    sac_curves: pd.DataFrame | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame | None]:
    """(values, samples, per-seed SAC summary) of every registered metric the tables hold.

    Parameters
    ----------
    tables : mapping of stage to mapping of task id to mapping of file name to pandas.DataFrame
        The artefact tables of :data:`RETURN_MATRIX_STAGES` per task, e.g.
        ``{"metrics": {"cart": {"metrics.parquet": …, "batches.parquet": …}}, "diagnostics": {…}}``;
        a stage or task may be missing.
    registry : Registry
        Which columns are metrics, and of which stage.
    sac_curves : pandas.DataFrame, optional
        Tidy SAC curves (:mod:`taskcomplexity.metrics.sac`); normalised with each task's random-policy
        bounds ``r_min``, ``r_max`` from ``metrics.parquet``.

    Returns
    -------
    (values, samples, per_seed)
        Tidy ``task``, ``metric``, ``value`` tables, and the per-seed SAC summary (None without curves).
    """
    values, samples = [], []
    for stage, (point_file, batch_file) in RETURN_MATRIX_STAGES.items():
        metrics = registry.of_stage(stage)
        found = tables.get(stage, {})
        values.append(tidy_values({t: f[point_file] for t, f in found.items()}, metrics))
        samples.append(tidy_values({t: f[batch_file] for t, f in found.items()}, [m for m in metrics if m.batched]))
    per_seed = None
    if sac_curves is not None and not sac_curves.empty:
        bounds = {task: (float(f["metrics.parquet"]["r_min"].iloc[0]), float(f["metrics.parquet"]["r_max"].iloc[0]))
                  for task, f in tables.get("metrics", {}).items()
                  if {"r_min", "r_max"} <= set(f["metrics.parquet"].columns)}
        per_seed = seed_summary(sac_curves, rwg_bounds=bounds)
        sac_values, sac_samples = sac_estimates(per_seed, registry.of_stage("sac"))
        values.append(sac_values)
        samples.append(sac_samples)
    return _concat(values), _concat(samples), per_seed


def _concat(parts: list[pd.DataFrame]) -> pd.DataFrame:
    parts = [p for p in parts if not p.empty]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(TIDY_COLUMNS))


def gather_details(tables: Mapping[str, Mapping[str, Mapping[str, pd.DataFrame]]], *,
                   registry: Registry) -> pd.DataFrame:
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


def gather_policies(tables: Mapping[str, Mapping[str, Mapping[str, pd.DataFrame]]], *,
                    registry: Registry) -> dict[tuple[str, str], int]:
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


def _point_tables(tables: Mapping[str, Mapping[str, Mapping[str, pd.DataFrame]]]):
    """(stage, task, point-value table) of every return-matrix stage's task in ``tables``."""
    for stage, (point_file, _) in RETURN_MATRIX_STAGES.items():
        for task, files in tables.get(stage, {}).items():
            yield stage, task, files[point_file]
