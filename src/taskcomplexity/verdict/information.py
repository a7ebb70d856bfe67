"""Does a metric's value carry information about the task, or only about its estimator?

Off the paper's scale a histogram PIC can equal what it gives for returns shuffled across policies
(its permutation null, where the true information is 0), or sit at its ceiling ln N, where every
return's bin names its policy whatever the task. A relation judged on such a value measures the
estimator; the verdict calls it ``uninformative`` instead of agree or contradict.

Two checks, declared per metric in the registry (:class:`~taskcomplexity.metrics.registry.Information`):

- **null**: the value exceeds its permutation null (R repeats, mean μ₀, sd s₀) significantly. A new
  null draw is compared with the observed value by the one-sided prediction t-test
  t = (value − μ₀) / (s₀ √(1 + 1/R)), R − 1 degrees of freedom: informative when p < alpha.
  ``null_share`` = μ₀ / value is the part of the value that the null alone gives (the estimator's bias).
- **difference from the null** (a relation's, for a metric with a null): the two tasks' nulls differ
  too (each null depends on the task's pooled returns), so a difference of values is partly a
  difference of nulls. When more than :data:`DIFFERENCE_NULL_SHARE` of it is (Δnull / Δvalue > 1/2,
  which includes every case where the excesses over the nulls order the pair the other way), the
  relation's order comes from the estimator, not the tasks: the relation is uninformative on it even
  when each value exceeds its own null.
- **ceiling**: ln N − value ≥ :data:`CEILING_MARGIN`. For the plug-in estimator,
  ln N − PIC is the conditional entropy of the policy given a return's bin, H(Θ | bin); below
  0.05 · ln 2 nats fewer than about 1 return in 20 shares its bin with another policy's (a bin
  shared evenly by two policies costs ln 2), so the estimate says only that the returns are
  separated by more than a bin's width: every task there scores ln N and no pair can be ranked.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics._validation import check_fraction
from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL
from taskcomplexity.metrics.registry import Registry

CEILING_MARGIN = 0.05 * math.log(2)
"""Nats below ln N under which a PIC-like value counts as at its ceiling (module docstring)."""

DIFFERENCE_NULL_SHARE = 0.5
"""Largest share of a relation's difference that may be the difference of the two nulls (module docstring)."""

INFORMATION_COLUMNS = ("task", "metric", "value", "null_mean", "null_sd", "null_repeats", "null_share",
                       "null_pvalue", "ceiling", "ceiling_gap", "informative", "reason")
"""Columns of :func:`information`."""


def null_test(value: float, draws: np.ndarray) -> float:
    """One-sided p-value that ``value`` is a draw of the null whose ``draws`` are given (prediction t-test).

    Parameters
    ----------
    value : float
        The observed estimate.
    draws : array_like, shape (R,)
        Estimates on R permutations (R >= 2).

    Returns
    -------
    float
        P(a new null draw >= value) under a normal null with the draws' mean and sd, accounting for
        the uncertainty of their mean: t = (value − mean) / (sd √(1 + 1/R)), Student's t with R − 1
        degrees of freedom. With sd = 0: 0 when value exceeds the mean, else 1. NaN with fewer than 2
        finite draws or a non-finite value.
    """
    draws = np.asarray(draws, dtype=np.float64)
    draws = draws[np.isfinite(draws)]
    if draws.size < 2 or not math.isfinite(value):
        return float("nan")
    mean, sd = float(draws.mean()), float(draws.std(ddof=1))
    if sd == 0.0:
        return 0.0 if value > mean else 1.0
    statistic = (value - mean) / (sd * math.sqrt(1.0 + 1.0 / draws.size))
    return float(scipy.stats.t.sf(statistic, draws.size - 1))


def information(
    values: pd.DataFrame,
    nulls: Mapping[tuple[str, str], np.ndarray],
    policies: Mapping[tuple[str, str], int],
    *,
    registry: Registry,
    alpha: float = SIGNIFICANCE_LEVEL,
) -> pd.DataFrame:
    """The information check of every (metric, task) value whose metric declares a null or a ceiling.

    Parameters
    ----------
    values : pandas.DataFrame
        Tidy ``task``, ``metric``, ``value`` (the values the verdict judges).
    nulls : mapping of (null name, task) to array, shape (R,)
        Permutation-null draws per task (``"pic"``, ``"poic"``: the diagnostics' ``null.parquet``).
    policies : mapping of (metric, task) to int
        N of the sample each value was estimated on (its ceiling is ln N).
    registry : Registry
        Which metrics declare which check (:class:`~taskcomplexity.metrics.registry.Information`).
    alpha : float, default 0.005
        A value exceeds its null when the one-sided p < alpha.

    Returns
    -------
    pandas.DataFrame, one row per checked (metric, task), columns :data:`INFORMATION_COLUMNS`
        ``null_*`` NaN (``null_repeats`` 0) when the metric has no null or the task no null draws;
        ``null_share`` = null mean / value (NaN for a value net of its null or not above 0);
        ``ceiling`` = ln N and ``ceiling_gap`` = ln N − value (NaN without a ceiling);
        ``informative``: every available check passed; ``reason``: why not ("" when informative).
        A check without its data (no diagnostics) neither passes nor fails: it is left out.
    """
    alpha = check_fraction(alpha, "alpha")
    rows = []
    for row in values.itertuples(index=False):
        metric, task, value = str(row.metric), str(row.task), float(row.value)
        check = registry[metric].information if metric in registry else None
        if check is None or not math.isfinite(value):
            continue
        out = {"task": task, "metric": metric, "value": value, "null_mean": np.nan, "null_sd": np.nan,
               "null_repeats": 0, "null_share": np.nan, "null_pvalue": np.nan, "ceiling": np.nan,
               "ceiling_gap": np.nan}
        reasons = []
        draws = nulls.get((check.null, task)) if check.null else None
        if draws is not None and np.isfinite(draws).sum() >= 2:
            draws = np.asarray(draws, dtype=np.float64)[np.isfinite(draws)]
            out.update(null_mean=float(draws.mean()), null_sd=float(draws.std(ddof=1)), null_repeats=int(draws.size))
            # A value net of its null is compared with 0 (its null, shifted by the same mean).
            observed = value + out["null_mean"] if check.net_of_null else value
            out["null_pvalue"] = null_test(observed, draws)
            if not check.net_of_null and value > 0:
                out["null_share"] = out["null_mean"] / value
            if not out["null_pvalue"] < alpha:
                reasons.append("equals its permutation null")
        n = policies.get((metric, task))
        if check.ceiling and n is not None and n >= 2:
            out["ceiling"] = math.log(n)
            out["ceiling_gap"] = out["ceiling"] - value
            if out["ceiling_gap"] < CEILING_MARGIN:
                reasons.append("sits at its ceiling ln N")
        if out["null_repeats"] == 0 and math.isnan(out["ceiling"]):
            continue
        out["informative"] = not reasons
        out["reason"] = " and ".join(reasons)
        rows.append(out)
    return pd.DataFrame(rows, columns=list(INFORMATION_COLUMNS))


def uninformative(table: pd.DataFrame) -> set[tuple[str, str]]:
    """The (metric, task) pairs of an :func:`information` table whose value carries no information."""
    if table is None or table.empty:
        return set()
    chosen = table[~table["informative"].astype(bool)]
    return set(zip(chosen["metric"].astype(str), chosen["task"].astype(str), strict=True))


def null_means(table: pd.DataFrame) -> dict[tuple[str, str], float]:
    """(metric, task) → the mean of the permutation null of its value, for values that are not net of it."""
    if table is None or table.empty:
        return {}
    chosen = table[np.isfinite(table["null_mean"].to_numpy(dtype=np.float64)) & table["null_share"].notna()]
    return {(str(m), str(t)): float(v) for m, t, v in zip(chosen["metric"], chosen["task"], chosen["null_mean"],
                                                           strict=True)}


def null_share_of_difference(easier: float, harder: float, null_easier: float, null_harder: float) -> float:
    """(null_easier − null_harder) / (easier − harder): how much of a difference the nulls alone give.

    NaN when the values are equal or a term is missing; above 1 when the excesses over the nulls order
    the pair the other way than the values do.
    """
    difference = easier - harder
    if not all(map(math.isfinite, (easier, harder, null_easier, null_harder))) or difference == 0:
        return float("nan")
    return (null_easier - null_harder) / difference


def episodes_to_settle(share: float, episodes: int, *, limit: float = DIFFERENCE_NULL_SHARE) -> float:
    """M at which the nulls' share of a relation's difference falls to ``limit``, at a held B.

    Parameters
    ----------
    share : float
        :func:`null_share_of_difference` now, above ``limit``.
    episodes : int
        M now.
    limit : float, default 0.5
        The share above which the relation is uninformative (:data:`DIFFERENCE_NULL_SHARE`).

    Returns
    -------
    float
        The smallest M′ (rounded up) that brings the share to ``limit``, assuming that at a held B both tasks' nulls
        fall at least as M^-1/2 (``tests/verdict/test_information.py`` measures 4× the episodes halving a histogram
        null at least: the plug-in bias of each policy's entropy falls with M) and that the rest of the difference,
        the excesses over the nulls, stays: with the nulls scaled by f, the share is f·s / (1 − s + f·s), at most
        ``limit`` when f ≤ limit·(1 − s) / (s·(1 − limit)), and M′ = M / f². NaN when the excesses order the pair
        the other way (s ≥ 1: shrinking the nulls turns the order, it does not settle it) or ``share`` is not
        above ``limit``.
    """
    limit = check_fraction(limit, "limit")
    if not (math.isfinite(share) and limit < share < 1):
        return float("nan")
    factor = limit * (1 - share) / (share * (1 - limit))
    # rounded up, but not past a whole M that rounding in the factor leaves a hair below the target
    return float(math.ceil(episodes / factor**2 - 1e-9))
