"""Welch's t-tests between tasks (the paper's significance tests).

The N policies of a task are split into consecutive batches and every batched metric is estimated
on each (:func:`taskcomplexity.metrics.evaluate.batch_estimates`); two tasks are compared with
Welch's unequal-variance t-test on their batch values (``docs/explanation/estimators.md``
§ Significance). The same tests apply to bootstrap draws or to SAC seeds.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics._validation import check_fraction, check_int

SIGNIFICANCE_LEVEL = 0.005
"""The paper's cut-off: a difference is significant when p < 0.005."""


class WelchResult(NamedTuple):
    """Welch's t statistic and its two-sided p-value (unpacks as ``statistic, pvalue``)."""

    statistic: float
    pvalue: float


def welch_test(a: object, b: object) -> WelchResult:
    """Two-sided Welch (unequal-variance) t-test of equal means: :func:`scipy.stats.ttest_ind` with
    ``equal_var=False``.

    Parameters
    ----------
    a, b : array_like, shape (n_a,), (n_b,)
        Two samples of at least 2 finite values each.

    Returns
    -------
    WelchResult
        ``t = (mean a - mean b) / sqrt(var a / n_a + var b / n_b)`` (variances with ddof 1) and
        ``p = 2 · P(T > |t|)`` for Student's T with the Welch–Satterthwaite degrees of freedom.
        When both samples are constant (up to rounding: a metric at its ceiling on every batch) the
        test is undefined: t is ±inf with p = 0 if the means differ beyond rounding, and t = p = NaN
        if they do not (scipy's values on exactly constant samples).
    """
    a, b = _sample(a, "a"), _sample(b, "b")
    if _constant(a) and _constant(b):
        difference = a.mean() - b.mean()
        if abs(difference) <= ROUNDING * max(abs(a.mean()), abs(b.mean())):
            return WelchResult(float("nan"), float("nan"))
        return WelchResult(float(np.copysign(np.inf, difference)), 0.0)
    result = _ttest(a, b)
    return WelchResult(float(result.statistic), float(result.pvalue))


def policies_to_resolve(a: object, b: object, policies: int, *, alpha: float = SIGNIFICANCE_LEVEL) -> float:
    """N at which Welch's test on the batches of two tasks would reach ``p < alpha`` (at the same M and batches).

    Parameters
    ----------
    a, b : array_like, shape (K_a,), (K_b,)
        A metric's values on the consecutive policy batches of two tasks, each from N policies.
    policies : int
        N, the policies each task's batches were drawn from.
    alpha : float, default 0.005
        The significance cut-off.

    Returns
    -------
    float
        The smallest N' (rounded up) at which the Welch statistic reaches the two-sided critical
        value, assuming that the difference of the batch means stays as measured and that the
        batches' variance falls as 1/N (each batch holds N/K policies; the standard error of a
        smooth estimate over policies scales as N^-1/2): N' = N · (t_crit / t)², with t the statistic
        measured here and t_crit the Student quantile at its Welch–Satterthwaite degrees of freedom
        (which the scaling leaves unchanged). The measured t is noisy (K − 1 degrees of freedom a
        side), so N' is too: it is about median-unbiased (in simulations half the runs land above the
        N at which half the tests resolve the difference, half below). Below N when the difference is
        already significant; inf when the batch means are equal (nothing to resolve); NaN when the
        test cannot be run (fewer than 2 finite values on a side, or both sides constant).
    """
    alpha = check_fraction(alpha, "alpha")
    policies = check_int(policies, "policies", minimum=1)
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a, b = a[np.isfinite(a)], b[np.isfinite(b)]
    if a.size < 2 or b.size < 2:
        return float("nan")
    if _constant(a) and _constant(b):
        return float("nan")
    measured = _ttest(a, b)
    if measured.statistic == 0:
        return float("inf")
    critical = scipy.stats.t.isf(alpha / 2.0, measured.df)
    return float(math.ceil(policies * (critical / measured.statistic) ** 2))


def welch_matrix(samples: Mapping[str, object], *, alpha: float = SIGNIFICANCE_LEVEL) -> pd.DataFrame:
    """Welch's t-test between every ordered pair of tasks.

    Parameters
    ----------
    samples : mapping of str to array_like
        Per task, the values of one metric (its batch estimates or its bootstrap draws).
    alpha : float, default 0.005
        Significance level; a pair is significant when ``p < alpha``.

    Returns
    -------
    pandas.DataFrame, one row per ordered pair (a, b) with a ≠ b
        ``task_a``, ``task_b``, ``statistic`` (positive when a's mean is higher), ``pvalue``,
        ``significant``.
    """
    alpha = check_fraction(alpha, "alpha")
    if len(samples) < 2:
        raise ValueError(f"samples must hold at least 2 tasks, got {len(samples)}")
    arrays = {task: _sample(values, f"samples[{task!r}]") for task, values in samples.items()}
    rows = []
    for task_a, values_a in arrays.items():
        for task_b, values_b in arrays.items():
            if task_a == task_b:
                continue
            statistic, pvalue = welch_test(values_a, values_b)
            rows.append(
                {
                    "task_a": task_a,
                    "task_b": task_b,
                    "statistic": statistic,
                    "pvalue": pvalue,
                    "significant": bool(pvalue < alpha),
                }
            )
    return pd.DataFrame(rows, columns=["task_a", "task_b", "statistic", "pvalue", "significant"])


def format_welch_matrix(tests: pd.DataFrame, *, digits: int = 3) -> pd.DataFrame:
    """Square "statistic (p-value)" table of :func:`welch_matrix` rows, task_a by task_b.

    Parameters
    ----------
    tests : pandas.DataFrame
        Output of :func:`welch_matrix`.
    digits : int, default 3
        Significant digits of the statistic and the p-value.

    Returns
    -------
    pandas.DataFrame
        Index task_a, columns task_b, cells such as ``"4.21 (0.00213)"``; the diagonal is empty.
    """
    digits = check_int(digits, "digits", minimum=1)
    pairs = zip(tests["statistic"], tests["pvalue"], strict=True)
    cells = tests.assign(cell=[f"{s:.{digits}g} ({p:.{digits}g})" for s, p in pairs])
    tasks = list(dict.fromkeys([*tests["task_a"], *tests["task_b"]]))
    table = cells.pivot(index="task_a", columns="task_b", values="cell").reindex(index=tasks, columns=tasks)
    return table.fillna("")


ROUNDING = 10 * np.finfo(np.float64).eps
"""Relative spread of a sample that is rounding only (scipy's own bound of a catastrophic cancellation)."""


def _ttest(a: np.ndarray, b: np.ndarray):
    """scipy's Welch test of two samples, not both constant."""
    with warnings.catch_warnings():
        if _constant(a) or _constant(b):
            # scipy warns of a catastrophic cancellation when a sample's spread is rounding beside its mean; that
            # sample's variance is 0 up to rounding, negligible beside the other's, which sets t.
            warnings.filterwarnings("ignore", message="Precision loss occurred", category=RuntimeWarning)
        return scipy.stats.ttest_ind(a, b, equal_var=False)


def _constant(values: np.ndarray) -> bool:
    """Whether the values are equal up to rounding (e.g. a metric at its ceiling, ln 2, computed on each batch)."""
    centre = values.mean()
    return bool(np.all(values == values[0]) or np.max(np.abs(values - centre)) <= ROUNDING * abs(centre))


def _sample(values: object, name: str) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1 or array.size < 2 or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be a 1-D array of at least 2 finite values, got {array!r}")
    return array
