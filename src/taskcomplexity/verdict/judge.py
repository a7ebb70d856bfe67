"""The verdict: does a complexity metric agree with the tasks' known relative difficulty?

The known relations and total orders are study data (:class:`taskcomplexity.study.Study`; the
paper's are in ``conf/study/paper.yaml``). ``metrics.md`` (§ The verdict) asks, for every metric and
relation, whether the metric orders the two tasks correctly and whether the difference is
significant, and per metric for the agreement counts and Kendall's τ against each known total order.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics._validation import check_fraction
from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL, welch_test
from taskcomplexity.study import Relation

OUTCOMES = ("agree", "contradict", "not significant")
"""Possible outcomes of one (metric, relation) verdict."""

VERDICT_COLUMNS = (
    "metric",
    "easier",
    "harder",
    "kind",
    "higher_is_easier",
    "value_easier",
    "value_harder",
    "difference",
    "agrees",
    "significant",
    "pvalue",
    "outcome",
)
"""Columns of the table :func:`verdict` returns."""


def verdict(
    values: pd.DataFrame,
    *,
    higher_is_easier: Mapping[str, bool],
    samples: pd.DataFrame | None = None,
    pvalues: pd.DataFrame | None = None,
    alpha: float = SIGNIFICANCE_LEVEL,
    relations: Iterable[Relation],
) -> pd.DataFrame:
    """Check every metric against every given relation between the tasks present.

    Parameters
    ----------
    values : pandas.DataFrame
        Point estimates, columns ``task``, ``metric``, ``value``; one row per (task, metric).
    higher_is_easier : mapping of str to bool
        For every metric in ``values``: True when a higher value means an easier task (PIC, POIC).
    samples : pandas.DataFrame, optional
        Per-task samples of each metric for the significance test (batch estimates or bootstrap
        draws), columns ``task``, ``metric``, ``value``, several rows per (task, metric). The test
        is :func:`~taskcomplexity.metrics.batches.welch_test` between the two tasks.
    pvalues : pandas.DataFrame, optional
        Used when ``samples`` is not given: columns ``metric``, ``task_a``, ``task_b``, ``pvalue``
        (for example :func:`~taskcomplexity.metrics.batches.welch_matrix` rows with a metric
        column); a pair may be listed in either order. With neither, every difference counts as
        significant and the p-value is NaN.
    alpha : float, default 0.005
        A difference is significant when ``p < alpha``.
    relations : iterable of Relation
        Relations to check (a study's); those whose tasks lack a value are skipped.

    Returns
    -------
    pandas.DataFrame, one row per (metric, relation) with both values present
        Columns of :data:`VERDICT_COLUMNS`. ``difference`` is ``value_easier - value_harder``;
        ``agrees`` is whether the metric orders the pair as known (strictly); ``outcome`` is
        "not significant" when ``p >= alpha`` (or p is NaN), otherwise "agree" or "contradict".
    """
    points = _tidy(values, "values")
    duplicated = points.duplicated(["task", "metric"])
    if duplicated.any():
        task, metric = points.loc[duplicated, ["task", "metric"]].iloc[0]
        raise ValueError(f"values must hold one row per (task, metric), got several for ({task!r}, {metric!r})")
    alpha = check_fraction(alpha, "alpha")
    metrics = list(dict.fromkeys(points["metric"]))
    unknown = [metric for metric in metrics if metric not in higher_is_easier]
    if unknown:
        raise ValueError(f"higher_is_easier must give a direction for every metric in values, missing {unknown}")
    if samples is not None:
        samples = _tidy(samples, "samples")
    if pvalues is not None:
        pvalues = _pvalue_lookup(pvalues)
    relations = tuple(relations)

    point = points.set_index(["metric", "task"])["value"]
    rows = []
    for metric in metrics:
        direction = bool(higher_is_easier[metric])
        for relation in relations:
            if (metric, relation.easier) not in point.index or (metric, relation.harder) not in point.index:
                continue
            value_easier = float(point[(metric, relation.easier)])
            value_harder = float(point[(metric, relation.harder)])
            agrees = value_easier > value_harder if direction else value_easier < value_harder
            pvalue = _pvalue(metric, relation, samples, pvalues)
            significant = bool(pvalue < alpha) if samples is not None or pvalues is not None else True
            outcome = "not significant" if not significant else ("agree" if agrees else "contradict")
            rows.append(
                {
                    "metric": metric,
                    "easier": relation.easier,
                    "harder": relation.harder,
                    "kind": relation.kind,
                    "higher_is_easier": direction,
                    "value_easier": value_easier,
                    "value_harder": value_harder,
                    "difference": value_easier - value_harder,
                    "agrees": bool(agrees),
                    "significant": significant,
                    "pvalue": pvalue,
                    "outcome": outcome,
                }
            )
    return pd.DataFrame(rows, columns=list(VERDICT_COLUMNS))


def verdict_summary(
    verdict_table: pd.DataFrame, values: pd.DataFrame, orders: Mapping[str, Iterable[str]] | None = None
) -> pd.DataFrame:
    """Per metric: agreements, contradictions, non-significant relations and Kendall's τ.

    Parameters
    ----------
    verdict_table : pandas.DataFrame
        Output of :func:`verdict` (its ``higher_is_easier`` column orients τ).
    values : pandas.DataFrame
        The point estimates given to :func:`verdict` (columns ``task``, ``metric``, ``value``).
    orders : mapping of str to sequence of task ids, optional
        Named known total orders, easiest first (a study's ``orders``).

    Returns
    -------
    pandas.DataFrame, one row per metric of ``verdict_table``
        ``metric``, ``relations``, ``agreements``, ``contradictions``, ``not_significant`` and, for
        each order of ``orders``, ``kendall_tau_<name>``: Kendall's τ-b between the known
        difficulty order and the difficulty the metric implies, over the tasks present (NaN with
        fewer than 2). τ = +1 means the metric orders those tasks exactly as known, -1 exactly
        reversed.
    """
    points = _tidy(values, "values").set_index(["metric", "task"])["value"]
    rows = []
    for metric, table in verdict_table.groupby("metric", sort=False):
        direction = bool(table["higher_is_easier"].iloc[0])
        row = {
            "metric": metric,
            "relations": len(table),
            "agreements": int((table["outcome"] == "agree").sum()),
            "contradictions": int((table["outcome"] == "contradict").sum()),
            "not_significant": int((table["outcome"] == "not significant").sum()),
        }
        for name, order in (orders or {}).items():
            tasks = [task for task in order if (metric, task) in points.index]
            tau = float("nan")
            if len(tasks) >= 2:
                known = np.arange(len(tasks))
                implied = np.array([points[(metric, task)] for task in tasks], dtype=np.float64)
                tau = float(scipy.stats.kendalltau(known, -implied if direction else implied).statistic)
            row[f"kendall_tau_{name}"] = tau
        rows.append(row)
    return pd.DataFrame(rows)


def verdict_by_relation(verdict_table: pd.DataFrame) -> pd.DataFrame:
    """Outcome of every relation under every metric, to see which verdicts survive a change of
    estimator (for example PIC, its Miller–Madow correction and its nearest-neighbour estimate).

    Parameters
    ----------
    verdict_table : pandas.DataFrame
        Output of :func:`verdict` for several metrics.

    Returns
    -------
    pandas.DataFrame
        Index (``easier``, ``harder``, ``kind``) in the order of ``verdict_table``, one column of
        outcomes per metric (empty where a metric lacks the pair), and ``unanimous``: whether
        every metric that judged the relation reached the same outcome.
    """
    index = ["easier", "harder", "kind"]
    wide = verdict_table.pivot(index=index, columns="metric", values="outcome")
    order = pd.MultiIndex.from_frame(verdict_table[index].drop_duplicates())
    wide = wide.reindex(index=order, columns=list(dict.fromkeys(verdict_table["metric"])))
    wide.columns.name = None
    wide["unanimous"] = wide.nunique(axis=1, dropna=True) <= 1
    return wide.fillna("")


def _tidy(table: pd.DataFrame, name: str) -> pd.DataFrame:
    required = {"task", "metric", "value"}
    if not isinstance(table, pd.DataFrame) or not required <= set(table.columns):
        columns = list(table.columns) if isinstance(table, pd.DataFrame) else type(table).__name__
        raise ValueError(f"{name} must be a DataFrame with columns task, metric, value, got {columns}")
    if not np.all(np.isfinite(table["value"].to_numpy(dtype=np.float64))):
        raise ValueError(f"{name} must hold finite values")
    return table


def _pvalue_lookup(pvalues: pd.DataFrame) -> dict[tuple[str, str, str], float]:
    required = {"metric", "task_a", "task_b", "pvalue"}
    if not isinstance(pvalues, pd.DataFrame) or not required <= set(pvalues.columns):
        raise ValueError("pvalues must be a DataFrame with columns metric, task_a, task_b, pvalue")
    lookup = {}
    columns = pvalues[["metric", "task_a", "task_b", "pvalue"]]
    for metric, task_a, task_b, pvalue in columns.itertuples(index=False):
        lookup[(metric, task_a, task_b)] = float(pvalue)
        lookup.setdefault((metric, task_b, task_a), float(pvalue))
    return lookup


def _pvalue(
    metric: str,
    relation: Relation,
    samples: pd.DataFrame | None,
    pvalues: dict[tuple[str, str, str], float] | None,
) -> float:
    if samples is not None:
        chosen = samples[samples["metric"] == metric]
        tasks = (relation.easier, relation.harder)
        draws = [chosen.loc[chosen["task"] == task, "value"].to_numpy() for task in tasks]
        for task, values in zip(tasks, draws, strict=True):
            if values.size < 2:
                raise ValueError(
                    f"samples must hold at least 2 values per (task, metric), got {values.size} "
                    f"for ({task!r}, {metric!r})"
                )
        return welch_test(*draws).pvalue
    if pvalues is not None:
        key = (metric, relation.easier, relation.harder)
        if key not in pvalues:
            raise ValueError(
                f"pvalues has no row for metric {metric!r} and tasks {relation.easier!r}, {relation.harder!r}"
            )
        return pvalues[key]
    return float("nan")
