"""Per-policy statistics of a return matrix and the normalised random-sampling score.

Follows Oller et al. (2020) as ``docs/explanation/estimators.md`` states them (§ Per-policy statistics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from taskcomplexity.metrics._validation import check_real, validate_returns

__all__ = ["ScoreSummary", "policy_statistics", "random_sampling_score", "validate_returns"]


@dataclass(frozen=True)
class ScoreSummary:
    """The normalised random-sampling score of a task and the quantities it is built from.

    Attributes
    ----------
    r_min : float
        Worst policy mean, min over n of Mₙ (return units).
    r_max : float
        Best single return, max over all S[n, e], or ``max(best_return, that)`` when an
        algorithm's best return was supplied (return units).
    r_mean : float
        Mean of all N·M returns (return units).
    score : float
        ``(r_mean - r_min) / (r_max - r_min)``, in [0, 1]; NaN when ``r_max == r_min``
        (every return equal and no better return supplied), because the scale is then undefined.
    variance : float
        The "variance" baseline ``Var(all returns, ddof=0) / (r_max - r_min)`` (return units);
        NaN when ``r_max == r_min``.
    """

    r_min: float
    r_max: float
    r_mean: float
    score: float
    variance: float


def policy_statistics(returns: object) -> pd.DataFrame:
    """Mean, variance, rank and scaled mean of every policy's returns.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n (in sampling order), column e is episode e.

    Returns
    -------
    pandas.DataFrame, N rows
        ``policy`` (int, sampling index n), ``mean`` (Mₙ), ``variance`` (Vₙ, with M - 1 in the
        denominator), ``std`` (√Vₙ), ``rank`` (int, 1 = lowest mean; ties keep sampling order),
        ``scaled_mean`` (Mₙ min-max scaled to [0, 1]; all 0 when every Mₙ is equal).
    """
    returns = validate_returns(returns)
    mean = returns.mean(axis=1)
    variance = returns.var(axis=1, ddof=1)
    rank = np.empty(mean.size, dtype=np.int64)
    rank[np.argsort(mean, kind="stable")] = np.arange(1, mean.size + 1)
    span = mean.max() - mean.min()
    scaled = (mean - mean.min()) / span if span > 0 else np.zeros_like(mean)
    return pd.DataFrame(
        {
            "policy": np.arange(mean.size, dtype=np.int64),
            "mean": mean,
            "variance": variance,
            "std": np.sqrt(variance),
            "rank": rank,
            "scaled_mean": scaled,
        }
    )


def random_sampling_score(returns: object, *, best_return: float | None = None) -> ScoreSummary:
    """Normalised random-sampling score and variance baseline of a task.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns of N random policies over M episodes each.
    best_return : float, optional
        Best return reached by a learning algorithm on the task; when given, r_max becomes
        ``max(best_return, max S)``.

    Returns
    -------
    ScoreSummary
        r_min, r_max, r_mean, score and the variance baseline (see its attributes).
    """
    returns = validate_returns(returns)
    r_min = float(returns.mean(axis=1).min())
    r_max = float(returns.max())
    if best_return is not None:
        r_max = max(check_real(best_return, "best_return"), r_max)
    r_mean = float(returns.mean())
    span = r_max - r_min
    if span > 0:
        score = (r_mean - r_min) / span
        variance = float(returns.var(ddof=0)) / span
    else:
        score = variance = float("nan")
    return ScoreSummary(r_min=r_min, r_max=r_max, r_mean=r_mean, score=score, variance=variance)
