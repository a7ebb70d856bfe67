"""Reference scores of a study's tasks, and the correlation of every metric with them.

A study may carry two kinds of reference data (:class:`taskcomplexity.study_data.Study`):

- ``reference``: a score per task, higher = easier, used as given;
- ``algorithm_scores``: a learning algorithm's best and average return per task (A_max, A_avg), from
  which the normalised scores of Furuta et al. (2021, "Policy Information Capacity") follow, with the
  random policies' bounds of the task's ``metrics.parquet`` (r_min = min over policies of the policy
  mean, r_max = max over all episode returns, r_mean = mean of all returns)::

      Score(A) = (A_avg  − r_min) / (max(r_max, A_max) − r_min)
      Score(R) = (r_mean − r_min) / (max(r_max, A_max) − r_min)

  Score(A) says how close a learning algorithm gets to the best return seen, on the random policies'
  scale (higher = easier); Score(R) is the same scale's random-sampling score (the ``score`` metric
  without the A_max term).

:data:`REFERENCES` declares them; :func:`reference_scores` computes them per task and
:func:`correlations` correlates every metric (by its easiness: negated when lower is easier) and every
shown detail (e.g. H(R), as it is) with each of them, across tasks.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics.registry import Registry
from taskcomplexity.study_data import Study


@dataclass(frozen=True)
class Reference:
    """A named reference score: higher = easier."""

    name: str
    label: str
    meaning: str


REFERENCES = (
    Reference("reference", "reference score", "the study's own reference scores (study.reference)"),
    Reference("score_a", "Score(A)", "(A_avg − r_min) / (max(r_max, A_max) − r_min): a learning algorithm's "
              "average return on the random policies' scale (Furuta et al. 2021)"),
    Reference("score_r", "Score(R)", "(r_mean − r_min) / (max(r_max, A_max) − r_min): the random policies' mean "
              "return on the same scale (Furuta et al. 2021)"),
)
"""Every kind of reference score, in table order."""

REFERENCE_COLUMNS = ("task", "reference", "value")
CORRELATION_COLUMNS = ("quantity", "metric", "reference", "tasks", "pearson_r", "pearson_p", "spearman_r",
                       "spearman_p")
"""Columns of :func:`correlations` (``metric``: the registered metric the quantity is or belongs to)."""


def reference_label(name: str) -> str:
    """Display label of a reference name (the name itself when unknown)."""
    return next((r.label for r in REFERENCES if r.name == name), name)


def reference_scores(study: Study, bounds: Mapping[str, Mapping[str, float]]) -> pd.DataFrame:
    """Every reference score of the study's tasks.

    Parameters
    ----------
    study : Study
        Its ``reference`` and ``algorithm_scores``.
    bounds : mapping of task id to mapping
        Each task's ``r_min``, ``r_max`` and ``r_mean`` (return units) from its metrics artefact;
        tasks missing here get no Score(A)/Score(R).

    Returns
    -------
    pandas.DataFrame
        ``task``, ``reference`` (a name of :data:`REFERENCES`), ``value``; one row per (task, reference)
        the study defines, in study order. Score(A)/Score(R) are NaN when the scale is empty
        (max(r_max, A_max) = r_min).
    """
    rows = [{"task": t, "reference": "reference", "value": float(v)} for t, v in study.reference.items()]
    for task, score in study.algorithm_scores.items():
        if task not in bounds:
            continue
        r_min, r_max, r_mean = (float(bounds[task][k]) for k in ("r_min", "r_max", "r_mean"))
        span = max(r_max, score.max) - r_min
        rows.append({"task": task, "reference": "score_a", "value": (score.average - r_min) / span if span > 0
                     else float("nan")})
        rows.append({"task": task, "reference": "score_r", "value": (r_mean - r_min) / span if span > 0
                     else float("nan")})
    order = {t: i for i, t in enumerate(study.ids)}
    kinds = {r.name: i for i, r in enumerate(REFERENCES)}
    frame = pd.DataFrame(rows, columns=list(REFERENCE_COLUMNS))
    if frame.empty:
        return frame
    return frame.sort_values(["reference", "task"], key=lambda c: c.map(kinds) if c.name == "reference"
                             else c.map(order)).reset_index(drop=True)


def quantities(values: pd.DataFrame, details: pd.DataFrame | None, *, registry: Registry) -> pd.DataFrame:
    """The tidy values to correlate: every metric by its easiness, every shown detail as it is.

    Parameters
    ----------
    values : pandas.DataFrame
        ``task``, ``metric``, ``value`` (the verdict's values).
    details : pandas.DataFrame, optional
        ``task``, ``quantity``, ``metric``, ``value``: shown details (e.g. H(R)) of the metrics.
    registry : Registry
        Directions and order.

    Returns
    -------
    pandas.DataFrame
        ``task``, ``quantity``, ``metric``, ``value`` (easiness for a metric), metrics in registry
        order, each followed by its details.
    """
    sign = {m.name: 1.0 if m.higher_is_easier else -1.0 for m in registry}
    parts = [values.assign(quantity=values["metric"],
                           value=values["value"].astype(float) * values["metric"].map(sign).fillna(1.0))]
    if details is not None and not details.empty:
        parts.append(details.astype({"value": float}))
    frame = pd.concat(parts, ignore_index=True)[["task", "quantity", "metric", "value"]]
    order = {}
    for metric in registry.order(frame["metric"]):
        order[metric] = len(order)
        for detail in registry[metric].details if metric in registry else ():
            order[detail.name] = len(order)
    rank = frame["quantity"].map(order).fillna(len(order)).to_numpy()
    return frame.iloc[np.argsort(rank, kind="stable")].reset_index(drop=True)


def correlations(quantities_table: pd.DataFrame, references: pd.DataFrame,
                 names: Iterable[str] | None = None) -> pd.DataFrame:
    """Pearson and Spearman r (with p) of every quantity with every reference score, across tasks.

    Parameters
    ----------
    quantities_table : pandas.DataFrame
        Output of :func:`quantities`.
    references : pandas.DataFrame
        Output of :func:`reference_scores`.
    names : iterable of str, optional
        The references to use (default: every one present).

    Returns
    -------
    pandas.DataFrame, columns :data:`CORRELATION_COLUMNS`
        One row per (quantity, reference), over the tasks where both are finite (``tasks`` counts
        them); r and p are NaN with fewer than 3 tasks or a constant side.
    """
    rows = []
    present = list(dict.fromkeys(references["reference"]))
    chosen = [n for n in (names if names is not None else present) if n in present]
    finite = quantities_table[np.isfinite(quantities_table["value"].to_numpy(dtype=np.float64))]
    for (quantity, metric), group in finite.groupby(["quantity", "metric"], sort=False):
        by_task = group.set_index("task")["value"]
        for name in chosen:
            ref = references[references["reference"] == name].set_index("task")["value"].astype(float)
            ref = ref[np.isfinite(ref.to_numpy())]
            tasks = [t for t in ref.index if t in by_task.index]
            x = ref.loc[tasks].to_numpy(dtype=np.float64)
            y = by_task.loc[tasks].to_numpy(dtype=np.float64)
            row = {"quantity": quantity, "metric": metric, "reference": name, "tasks": len(tasks)}
            for test_name, test in (("pearson", scipy.stats.pearsonr), ("spearman", scipy.stats.spearmanr)):
                row[f"{test_name}_r"], row[f"{test_name}_p"] = correlation(test, x, y)
            rows.append(row)
    return pd.DataFrame(rows, columns=list(CORRELATION_COLUMNS))


def correlation(test, x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(r, p) of ``test(x, y)``; NaN with fewer than 3 points or a constant side."""
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan"), float("nan")
    result = test(x, y)
    return float(result.statistic), float(result.pvalue)
