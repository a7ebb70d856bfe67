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
BASES = VALUE, INFORMATIVE, NET_OF_NULL = ("value", "informative", "net of null")
"""What a correlation is computed on: every task's value; only the tasks whose value carries information
(:mod:`taskcomplexity.verdict.information`); the value minus the mean of its permutation null."""
CONFIDENCE = 0.95
"""Level of the percentile bootstrap interval of a Pearson r."""
CORRELATION_COLUMNS = ("quantity", "metric", "reference", "basis", "tasks", "pearson_r", "pearson_p", "pearson_low",
                       "pearson_high", "resamples", "spearman_r", "spearman_p")
"""Columns of :func:`correlations` (``metric``: the registered metric the quantity is or belongs to; ``basis``: one of
:data:`BASES`; ``pearson_low``/``pearson_high``: the percentile interval of r over the bootstrap resamples of the
policies, of which ``resamples`` were used, NaN without them)."""


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


def correlations(quantities_table: pd.DataFrame, references: pd.DataFrame, names: Iterable[str] | None = None,
                 *, draws: pd.DataFrame | None = None, information: pd.DataFrame | None = None,
                 registry: Registry | None = None) -> pd.DataFrame:
    """Pearson and Spearman r (with p) of every quantity with every reference score, across tasks.

    Parameters
    ----------
    quantities_table : pandas.DataFrame
        Output of :func:`quantities`.
    references : pandas.DataFrame
        Output of :func:`reference_scores`.
    names : iterable of str, optional
        The references to use (default: every one present).
    draws : pandas.DataFrame, optional
        ``task``, ``metric``, ``resample``, ``value``: bootstrap draws of metrics over the policies (as values, not
        easiness). A metric with draws on every correlated task gets a percentile interval of its Pearson r: r of
        the reference scores (held at their whole-sample values) with resample b of every task, over b. Each task's
        draws are first centred on its whole-sample value (shifted by the value minus their mean): resampling
        policies with replacement biases a plug-in entropy estimate by an amount that differs between tasks, and the
        interval is of the estimate's spread, not of that bias.
    information : pandas.DataFrame, optional
        The :func:`~taskcomplexity.verdict.information.information` table. Each metric it checks gets the rows of
        basis ``informative`` (its tasks whose value carries information) and, when it has a null, ``net of
        null`` (its value minus the null's mean, draws likewise).
    registry : Registry, optional
        The metrics' directions (needed with ``draws`` or ``information``).

    Returns
    -------
    pandas.DataFrame, columns :data:`CORRELATION_COLUMNS`
        One row per (quantity, reference, basis), over the tasks where both are finite (``tasks`` counts
        them); r and p are NaN with fewer than 3 tasks or a constant side.
    """
    present = list(dict.fromkeys(references["reference"]))
    chosen = [n for n in (names if names is not None else present) if n in present]
    sign = {m.name: 1.0 if m.higher_is_easier else -1.0 for m in registry} if registry is not None else {}
    resampled = easiness_draws(draws, registry) if registry is not None else {}
    checked = information if information is not None and not information.empty else None
    rows = []
    for (quantity, metric), group in quantities_table.groupby(["quantity", "metric"], sort=False):
        by_task = group.set_index("task")["value"].astype(float)
        own = resampled.get(metric) if quantity == metric else None
        bases = on_bases(by_task, own, checked if quantity == metric else None, metric, sign.get(metric, 1.0))
        for basis, values, resamples in bases:
            for name in chosen:
                rows.append({"quantity": quantity, "metric": metric, "reference": name, "basis": basis,
                             **_correlate(values, references, name, resamples)})
    return pd.DataFrame(rows, columns=list(CORRELATION_COLUMNS))


def easiness_draws(draws: pd.DataFrame | None, registry: Registry) -> dict[str, pd.DataFrame]:
    """Bootstrap draws (``task``, ``metric``, ``resample``, ``value``) as easiness, one wide table (resample × task)
    per metric."""
    sign = {m.name: 1.0 if m.higher_is_easier else -1.0 for m in registry}
    resampled = {}
    if draws is not None and not draws.empty:
        for metric, group in draws.groupby("metric", sort=False):
            wide = group.pivot_table(index="resample", columns="task", values="value", aggfunc="first")
            resampled[metric] = wide * sign.get(metric, 1.0)
    return resampled


def on_bases(by_task: pd.Series, own: pd.DataFrame | None, checked: pd.DataFrame | None, metric: str,
             sign: float) -> list[tuple[str, pd.Series, pd.DataFrame | None]]:
    """A metric's easiness per task (and its bootstrap draws, resample × task) on each of :data:`BASES` it has.

    Each task's draws are centred on its whole-sample value first (resampling policies biases a plug-in estimate by
    an amount that differs between tasks: an interval is of the estimate's spread, not of that bias). With the
    information table ``checked``, the metric also gets its informative tasks, and its value net of its null's mean
    when it has a null.
    """
    if own is not None:
        own = own - own.mean() + by_task.reindex(own.columns)
    bases = [(VALUE, by_task, own)]
    if checked is not None:
        mine = checked[checked["metric"] == metric].set_index("task")
        if len(mine):
            keep = [t for t in by_task.index if t in mine.index and bool(mine.loc[t, "informative"])]
            bases.append((INFORMATIVE, by_task.loc[keep], None if own is None else own[[
                t for t in keep if t in own.columns]]))
            null = mine["null_mean"].astype(float) * sign
            if mine["null_share"].notna().any():
                net = (by_task - null.reindex(by_task.index)).dropna()
                bases.append((NET_OF_NULL, net, None if own is None else own.sub(null, axis=1)))
    return bases


def _correlate(values: pd.Series, references: pd.DataFrame, name: str, resamples: pd.DataFrame | None) -> dict:
    """Pearson (with its bootstrap interval) and Spearman of ``values`` with reference ``name``, over the tasks
    where both are finite."""
    ref = references[references["reference"] == name].set_index("task")["value"].astype(float)
    ref = ref[np.isfinite(ref.to_numpy())]
    values = values[np.isfinite(values.to_numpy(dtype=np.float64))]
    tasks = [t for t in ref.index if t in values.index]
    x = ref.loc[tasks].to_numpy(dtype=np.float64)
    y = values.loc[tasks].to_numpy(dtype=np.float64)
    row = {"tasks": len(tasks), "pearson_low": float("nan"), "pearson_high": float("nan"), "resamples": 0}
    for test_name, test in (("pearson", scipy.stats.pearsonr), ("spearman", scipy.stats.spearmanr)):
        row[f"{test_name}_r"], row[f"{test_name}_p"] = correlation(test, x, y)
    if resamples is not None and np.isfinite(row["pearson_r"]) and set(tasks) <= set(resamples.columns):
        matrix = resamples[tasks].to_numpy(dtype=np.float64)
        matrix = matrix[np.isfinite(matrix).all(axis=1)]
        rs = pearson_rows(x, matrix)
        rs = rs[np.isfinite(rs)]
        if rs.size >= 2:
            tail = (1 - CONFIDENCE) / 2
            row["pearson_low"], row["pearson_high"] = (float(q) for q in np.quantile(rs, [tail, 1 - tail]))
            row["resamples"] = int(rs.size)
    return row


def pearson_rows(x: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Pearson r of ``x`` (n,) with each row of ``rows`` (B, n), as :func:`scipy.stats.pearsonr` gives it for one
    row; NaN for a constant row."""
    dx = x - x.mean()
    dy = rows - rows.mean(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = dy @ dx / (np.linalg.norm(dy, axis=1) * np.linalg.norm(dx))
    return np.clip(r, -1.0, 1.0)


def on_values(correlated: pd.DataFrame) -> pd.DataFrame:
    """The rows of a :func:`correlations` table on every task's value (basis ``value``)."""
    return correlated[correlated["basis"] == VALUE] if "basis" in correlated.columns else correlated


def correlation(test, x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(r, p) of ``test(x, y)``; NaN with fewer than 3 points or a constant side."""
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan"), float("nan")
    result = test(x, y)
    return float(result.statistic), float(result.pvalue)
