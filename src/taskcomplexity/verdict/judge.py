"""The verdict: does a complexity metric agree with the tasks' known relative difficulty?

``docs/explanation/estimators.md`` (§ The verdict) asks, for every metric and known relation, whether the metric orders
the two tasks as known and whether the difference is significant; per metric, the counts of
outcomes and Kendall's τ against each known total order (correlations with reference scores:
:mod:`taskcomplexity.verdict.references`). The relations and orders are study data
(:class:`taskcomplexity.study_data.Study`); directions come from the metric registry.

Outcomes of one (metric, relation):

- ``undefined``: a value of either task is missing or not finite (e.g. score_R of a task whose
  returns are all equal, or SAC on a task it skipped);
- ``uninformative``: a value of either task carries no information about its task (it equals its
  permutation null or sits at its ceiling), or most of the difference is the difference of the two
  tasks' nulls (:mod:`taskcomplexity.verdict.information`): ordering the pair by it would measure the
  estimator, not the tasks;
- ``not significant``: Welch's two-sided test on the two tasks' samples gives p >= alpha, or it
  cannot be run (fewer than 2 finite samples on a side: never assumed significant);
- ``agree`` / ``contradict``: significant, and the metric orders the pair as known / the other way.

For a relation left unresolved (not significant or uninformative), ``policies_to_resolve`` estimates
the N at which the Welch test would resolve the difference
(:func:`~taskcomplexity.metrics.batches.policies_to_resolve`).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics._validation import check_fraction
from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL, policies_to_resolve, welch_matrix, welch_test
from taskcomplexity.metrics.registry import Registry
from taskcomplexity.study_data import Relation
from taskcomplexity.verdict.information import DIFFERENCE_NULL_SHARE, null_share_of_difference

OUTCOMES = ("agree", "contradict", "not significant", "uninformative", "undefined")
"""Possible outcomes of one (metric, relation) verdict."""

VERDICT_COLUMNS = (
    "metric",
    "easier",
    "harder",
    "kind",
    "value_easier",
    "value_harder",
    "pvalue",
    "outcome",
    "higher_is_easier",
    "difference",
    "agrees",
    "significant",
    "samples_easier",
    "samples_harder",
    "informative_easier",
    "informative_harder",
    "null_share_of_difference",
    "policies",
    "policies_to_resolve",
)
"""Columns of the table :func:`judge` returns."""

SUMMARY_COUNTS = ("relations", "agreements", "contradictions", "not_significant", "uninformative", "undefined")
"""Count columns of :func:`summarise` (``relations`` counts every outcome)."""


def judge(
    values: pd.DataFrame,
    samples: pd.DataFrame,
    relations: Iterable[Relation],
    *,
    registry: Registry,
    alpha: float = SIGNIFICANCE_LEVEL,
    uninformative: Collection[tuple[str, str]] = (),
    nulls: Mapping[tuple[str, str], float] | None = None,
    policies: Mapping[tuple[str, str], int] | None = None,
) -> pd.DataFrame:
    """Every metric present in ``values`` against every relation.

    Parameters
    ----------
    values : pandas.DataFrame
        Point values, columns ``task``, ``metric``, ``value``; at most one row per (task, metric).
        Values may be NaN or infinite (the outcome is then "undefined").
    samples : pandas.DataFrame
        Samples of the same metrics for Welch's test (policy batches or SAC seeds), columns
        ``task``, ``metric``, ``value``, several rows per (task, metric); non-finite ones are dropped.
    relations : iterable of Relation
        The study's known relations, in order.
    registry : Registry
        Directions of the metrics; every metric of ``values`` must be registered.
    alpha : float, default 0.005
        A difference is significant when p < alpha.
    uninformative : collection of (metric, task)
        Values that carry no information (:func:`~taskcomplexity.verdict.information.uninformative`):
        a relation with one on either side is ``uninformative`` whatever its test says.
    nulls : mapping of (metric, task) to float, optional
        Permutation-null means of values that are not net of their null
        (:func:`~taskcomplexity.verdict.information.null_means`): a relation whose difference is more than
        :data:`~taskcomplexity.verdict.information.DIFFERENCE_NULL_SHARE` the nulls' is ``uninformative``.
    policies : mapping of (metric, task) to int, optional
        N of the sample behind each value's batches, for ``policies_to_resolve`` (NaN without it).

    Returns
    -------
    pandas.DataFrame, one row per (metric, relation), metrics in registry order
        Columns of :data:`VERDICT_COLUMNS`: the two values (NaN when missing), the p-value (NaN
        when untested), the outcome (:data:`OUTCOMES`), the direction, ``difference`` =
        value_easier − value_harder, ``agrees`` (the values order the pair as known, strictly),
        ``significant`` (the test alone), the sample sizes tested on each side, whether each value
        carries information, the share of the difference the two nulls give (NaN without nulls),
        N (the larger of the two sides') and, for a relation whose test is not
        significant (whether its values carry information or not), the N at which the test would
        resolve it (NaN otherwise or when untestable).
    """
    values, samples = _tidy(values, "values"), _tidy(samples, "samples")
    duplicated = values.duplicated(["task", "metric"])
    if duplicated.any():
        task, metric = values.loc[duplicated, ["task", "metric"]].iloc[0]
        raise ValueError(f"values must hold one row per (task, metric), got several for ({task!r}, {metric!r})")
    alpha = check_fraction(alpha, "alpha")
    metrics = registry.order(values["metric"])
    unknown = [m for m in metrics if m not in registry]
    if unknown:
        raise ValueError(f"values names metrics the registry does not know: {unknown}")
    relations = tuple(relations)
    point = values.set_index(["metric", "task"])["value"].astype(np.float64)
    finite = samples[np.isfinite(samples["value"].to_numpy(dtype=np.float64))]
    draws = {key: group.to_numpy(dtype=np.float64) for key, group in finite.groupby(["metric", "task"])["value"]}
    rows = []
    for metric in metrics:
        direction = registry[metric].higher_is_easier
        for relation in relations:
            easy = float(point.get((metric, relation.easier), np.nan))
            hard = float(point.get((metric, relation.harder), np.nan))
            a = draws.get((metric, relation.easier), np.empty(0))
            b = draws.get((metric, relation.harder), np.empty(0))
            defined = bool(np.isfinite(easy) and np.isfinite(hard))
            testable = defined and a.size >= 2 and b.size >= 2
            pvalue = welch_test(a, b).pvalue if testable else float("nan")
            agrees = defined and (easy > hard if direction else easy < hard)
            significant = bool(pvalue < alpha)
            informative = ((metric, relation.easier) not in uninformative,
                           (metric, relation.harder) not in uninformative)
            share = null_share_of_difference(easy, hard, *((nulls or {}).get((metric, t), np.nan)
                                                            for t in (relation.easier, relation.harder)))
            if not defined:
                outcome = "undefined"
            elif not all(informative) or share > DIFFERENCE_NULL_SHARE:
                outcome = "uninformative"
            elif not significant:
                outcome = "not significant"
            else:
                outcome = "agree" if agrees else "contradict"
            sizes = [(policies or {}).get((metric, t)) for t in (relation.easier, relation.harder)]
            n = max((int(v) for v in sizes if v is not None), default=None)
            # Unresolved: not significant, or uninformative without a significant test (a significant
            # difference between values without information is not resolved by more policies).
            unresolved = outcome == "not significant" or (outcome == "uninformative" and not significant)
            resolve = policies_to_resolve(a, b, n, alpha=alpha) if testable and n and unresolved else float("nan")
            rows.append({
                "metric": metric, "easier": relation.easier, "harder": relation.harder, "kind": relation.kind,
                "value_easier": easy, "value_harder": hard, "pvalue": pvalue, "outcome": outcome,
                "higher_is_easier": direction, "difference": easy - hard, "agrees": bool(agrees),
                "significant": significant, "samples_easier": int(a.size), "samples_harder": int(b.size),
                "informative_easier": informative[0], "informative_harder": informative[1],
                "null_share_of_difference": share,
                "policies": float("nan") if n is None else float(n), "policies_to_resolve": resolve,
            })
    return pd.DataFrame(rows, columns=list(VERDICT_COLUMNS))


def summarise(
    verdict: pd.DataFrame,
    values: pd.DataFrame,
    *,
    registry: Registry,
    orders: Mapping[str, Iterable[str]] | None = None,
    uninformative: Collection[tuple[str, str]] = (),
    nulls: Mapping[tuple[str, str], float] | None = None,
) -> pd.DataFrame:
    """Per metric: outcome counts and Kendall's τ per known order.

    Parameters
    ----------
    verdict : pandas.DataFrame
        Output of :func:`judge` (may be empty: a study without relations).
    values : pandas.DataFrame
        The point values given to :func:`judge` (``task``, ``metric``, ``value``).
    registry : Registry
        Directions and order of the metrics.
    orders : mapping of str to sequence of task ids, optional
        Named known total orders, easiest first (a study's ``orders``).
    uninformative : collection of (metric, task)
        Values without information: left out of Kendall's τ like missing ones.
    nulls : mapping of (metric, task) to float, optional
        Permutation-null means (as for :func:`judge`): τ is NaN when the difference of any pair of the
        order's tasks is mostly the difference of their nulls (the order it ranks is the estimator's).

    Returns
    -------
    pandas.DataFrame, one row per metric of ``values`` (registry order)
        ``metric``, the counts of :data:`SUMMARY_COUNTS`; for each order ``kendall_tau_<name>``:
        Kendall's τ-b between the known order and the order the metric implies, over the tasks
        with a finite, informative value (NaN with fewer than 2, or when a pair's difference is mostly its
        nulls'; +1 = exactly as known, −1 = reversed).
    """
    values = _tidy(values, "values")
    finite = values[np.isfinite(values["value"].to_numpy(dtype=np.float64))]
    if uninformative:
        kept = [(m, t) not in uninformative for m, t in zip(finite["metric"], finite["task"], strict=True)]
        finite = finite[kept]
    points = finite.set_index(["metric", "task"])["value"]
    rows = []
    for metric in registry.order(values["metric"]):
        sign = 1.0 if registry[metric].higher_is_easier else -1.0
        outcomes = verdict.loc[verdict["metric"] == metric, "outcome"]
        row = {"metric": metric, "relations": int(outcomes.size),
               "agreements": int((outcomes == "agree").sum()),
               "contradictions": int((outcomes == "contradict").sum()),
               "not_significant": int((outcomes == "not significant").sum()),
               "uninformative": int((outcomes == "uninformative").sum()),
               "undefined": int((outcomes == "undefined").sum())}
        for name, order in (orders or {}).items():
            tasks = [task for task in order if (metric, task) in points.index]
            tau = float("nan")
            if len(tasks) >= 2 and not _null_driven(points, nulls or {}, metric, tasks):
                implied = np.array([points[(metric, task)] for task in tasks], dtype=np.float64)
                tau = float(scipy.stats.kendalltau(np.arange(len(tasks)), -sign * implied).statistic)
            row[f"kendall_tau_{name}"] = tau
        rows.append(row)
    columns = ["metric", *SUMMARY_COUNTS]
    return pd.DataFrame(rows, columns=list(dict.fromkeys(columns + [k for r in rows for k in r])))


def _null_driven(points: pd.Series, nulls: Mapping[tuple[str, str], float], metric: str, tasks: list[str]) -> bool:
    """Whether the difference of any pair of ``tasks`` on ``metric`` is mostly the difference of their nulls."""
    for i, a in enumerate(tasks):
        for b in tasks[i + 1:]:
            share = null_share_of_difference(float(points[(metric, a)]), float(points[(metric, b)]),
                                             nulls.get((metric, a), np.nan), nulls.get((metric, b), np.nan))
            if share > DIFFERENCE_NULL_SHARE:
                return True
    return False


SURVIVAL = ("yes", "no", "one informative estimator", "no significant verdict")
"""Whether a relation's verdict survives a change of estimator (:func:`survival`), in the report's order."""


def survival(outcomes: Iterable[str]) -> str:
    """Does the verdict on one relation survive a change of estimator? One of :data:`SURVIVAL`.

    Only the informative estimators' outcomes count (an uninformative one measures its estimator, and a
    missing one was not computed): "no significant verdict" when none of them is significant (agree,
    contradict); "one informative estimator" when there is no other to change to; otherwise "yes" when
    every informative estimator reaches the same outcome, "no" when they differ.
    """
    informative = [o for o in outcomes if isinstance(o, str) and o not in ("uninformative", "")]
    if not any(o in ("agree", "contradict") for o in informative):
        return "no significant verdict"
    if len(informative) < 2:
        return "one informative estimator"
    return "yes" if len(set(informative)) == 1 else "no"


def by_relation(verdict: pd.DataFrame, metrics: Iterable[str]) -> pd.DataFrame:
    """Outcome of every relation under each of ``metrics``: does a verdict survive a change of estimator?

    Parameters
    ----------
    verdict : pandas.DataFrame
        Output of :func:`judge`.
    metrics : iterable of str
        Metrics to compare (e.g. the estimators of one quantity), in column order.

    Returns
    -------
    pandas.DataFrame
        ``easier``, ``harder``, ``kind``, one column of outcomes per metric present ("" where not
        computed), and ``survives``: :func:`survival` of the row's outcomes. Empty (those columns only)
        when fewer than two of ``metrics`` are present.
    """
    metrics = [m for m in metrics if (verdict["metric"] == m).any()]
    index = ["easier", "harder", "kind"]
    if len(metrics) < 2:
        return pd.DataFrame(columns=[*index, "survives"])
    chosen = verdict[verdict["metric"].isin(metrics)]
    wide = chosen.pivot(index=index, columns="metric", values="outcome")
    order = pd.MultiIndex.from_frame(chosen[index].drop_duplicates())
    wide = wide.reindex(index=order, columns=metrics)
    wide.columns.name = None
    wide = wide.fillna("")
    wide["survives"] = [survival(row) for row in wide[metrics].itertuples(index=False)]
    return wide.reset_index()


def pairwise_welch(samples: pd.DataFrame, *, registry: Registry, alpha: float = SIGNIFICANCE_LEVEL) -> pd.DataFrame:
    """Welch's test between every ordered pair of tasks, per metric (the paper's significance matrices).

    Parameters
    ----------
    samples : pandas.DataFrame
        Tidy ``task``, ``metric``, ``value`` samples (batches or seeds); non-finite ones are dropped.
    registry : Registry
        Order of the metrics.
    alpha : float
        Significance cut-off.

    Returns
    -------
    pandas.DataFrame
        ``metric``, ``task_a``, ``task_b``, ``statistic`` (positive when a's mean is higher),
        ``pvalue``, ``significant``; tasks in the order of ``samples``; only metrics with at least
        2 finite samples on each of at least 2 tasks.
    """
    samples = _tidy(samples, "samples")
    samples = samples[np.isfinite(samples["value"].to_numpy(dtype=np.float64))]
    parts = []
    for metric in registry.order(samples["metric"]):
        chosen = samples[samples["metric"] == metric]
        draws = {t: g.to_numpy(dtype=np.float64) for t, g in chosen.groupby("task", sort=False)["value"]}
        draws = {t: d for t, d in draws.items() if d.size >= 2}
        if len(draws) >= 2:
            parts.append(welch_matrix(draws, alpha=alpha).assign(metric=metric))
    columns = ["metric", "task_a", "task_b", "statistic", "pvalue", "significant"]
    return pd.concat(parts, ignore_index=True)[columns] if parts else pd.DataFrame(columns=columns)



def _tidy(table: pd.DataFrame, name: str) -> pd.DataFrame:
    required = {"task", "metric", "value"}
    if not isinstance(table, pd.DataFrame) or not required <= set(table.columns):
        columns = list(table.columns) if isinstance(table, pd.DataFrame) else type(table).__name__
        raise ValueError(f"{name} must be a DataFrame with columns task, metric, value, got {columns}")
    return table
