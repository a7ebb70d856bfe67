"""Welch's t-tests between tasks (the paper's significance tests).

The N policies of a task are split into consecutive batches and every batched metric is estimated
on each (:func:`taskcomplexity.metrics.evaluate.batch_estimates`); two tasks are compared with
Welch's unequal-variance t-test on their batch values (``metrics.md`` § Uncertainty and
significance). The same tests apply to bootstrap draws or to SAC seeds.
"""

from __future__ import annotations

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
    """Two-sided Welch (unequal-variance) t-test of equal means.

    Parameters
    ----------
    a, b : array_like, shape (n_a,), (n_b,)
        Two samples of at least 2 finite values each.

    Returns
    -------
    WelchResult
        ``t = (mean a - mean b) / sqrt(var a / n_a + var b / n_b)`` (variances with ddof 1) and
        ``p = 2 · P(T > |t|)`` for Student's T with the Welch–Satterthwaite degrees of freedom.
        When both samples are constant the test is undefined: t is ±inf with p = 0 if the means
        differ, and t = p = NaN if they are equal (as :func:`scipy.stats.ttest_ind`).
    """
    a, b = _sample(a, "a"), _sample(b, "b")
    var_a, var_b = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    difference = a.mean() - b.mean()
    spread = var_a + var_b
    if spread == 0:
        if difference == 0:
            return WelchResult(float("nan"), float("nan"))
        return WelchResult(float(np.copysign(np.inf, difference)), 0.0)
    statistic = difference / np.sqrt(spread)
    # Welch–Satterthwaite degrees of freedom, with the variances scaled by their maximum so
    # that squaring tiny (or huge) variances cannot underflow (overflow).
    ratio_a, ratio_b = var_a / max(var_a, var_b), var_b / max(var_a, var_b)
    dof = (ratio_a + ratio_b) ** 2 / (ratio_a**2 / (a.size - 1) + ratio_b**2 / (b.size - 1))
    pvalue = 2.0 * scipy.stats.t.sf(abs(statistic), dof)
    return WelchResult(float(statistic), float(pvalue))


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


def _sample(values: object, name: str) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1 or array.size < 2 or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be a 1-D array of at least 2 finite values, got {array!r}")
    return array
