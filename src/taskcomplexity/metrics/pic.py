"""Policy Information Capacity (PIC) with the published histogram estimator.

PIC = H(R) - H(R|Θ), the mutual information between the policy index and the episode return
(``docs/explanation/estimators.md`` § PIC). Entropies are plug-in estimates on B equal-width bins spanning all N·M
returns; every policy is histogrammed on the same edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskcomplexity.metrics._validation import check_bins, validate_returns
from taskcomplexity.metrics.bins import RETURNS_PER_BIN as RETURNS_PER_BIN
from taskcomplexity.metrics.bins import auto_bins as auto_bins
from taskcomplexity.metrics.histogram import HistogramTerms, bin_edges, histogram_terms, plugin_entropy

DEFAULT_BINS = 100_000
"""Number of equal-width bins of the published estimator."""


@dataclass(frozen=True)
class PICResult:
    """A PIC estimate and its two entropy terms.

    Attributes
    ----------
    pic : float
        H(R) - H(R|Θ) in nats; between 0 and ln N for the plug-in estimator.
    h_r : float
        Entropy of the pooled returns H(R) in nats.
    h_r_given_theta : float
        Mean per-policy entropy H(R|Θ) = (1/N) Σₙ Hₙ in nats.
    bins : int
        Number of bins B the estimate used.
    """

    pic: float
    h_r: float
    h_r_given_theta: float
    bins: int


def pic(returns: object, *, bins: int = DEFAULT_BINS) -> PICResult:
    """Histogram estimate of the Policy Information Capacity.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n, column e is episode e. N, M >= 2, all finite.
    bins : int, default 100_000
        Number B of equal-width bins spanning ``[min S, max S]`` (the last bin closed).

    Returns
    -------
    PICResult
        PIC, H(R) and H(R|Θ) in nats. When every return is equal all three are 0.

    Notes
    -----
    One parallel pass bins all N·M returns and counts each policy's histogram (see
    :func:`~taskcomplexity.metrics.histogram.histogram_terms`). The result equals
    :func:`pic_reference` up to floating-point rounding.
    """
    returns = validate_returns(returns)
    bins = check_bins(bins)
    low, high = float(returns.min()), float(returns.max())
    if low == high:
        return PICResult(pic=0.0, h_r=0.0, h_r_given_theta=0.0, bins=bins)
    return pic_of_terms(histogram_terms(returns, bin_edges(low, high, bins)), bins)


def pic_of_terms(terms: HistogramTerms, bins: int) -> PICResult:
    """The plug-in PIC from the per-policy histograms (:func:`~taskcomplexity.metrics.histogram.histogram_terms`)
    on B = ``bins`` shared bins spanning the returns (min < max)."""
    h_r = plugin_entropy(terms.pooled)
    h_r_given_theta = float(terms.policy_entropies().mean())
    return PICResult(pic=h_r - h_r_given_theta, h_r=h_r, h_r_given_theta=h_r_given_theta, bins=bins)


def pic_reference(returns: object, *, bins: int) -> PICResult:
    """Plain per-policy implementation of :func:`pic`, kept obviously correct for the tests.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    bins : int
        Number of equal-width bins, >= 2.

    Returns
    -------
    PICResult
        Same definition as :func:`pic`, computed with :func:`numpy.histogram` policy by policy.
    """
    returns = validate_returns(returns)
    bins = check_bins(bins)
    low, high = returns.min(), returns.max()
    if low == high:
        return PICResult(pic=0.0, h_r=0.0, h_r_given_theta=0.0, bins=bins)
    edges = np.linspace(low, high, bins + 1)

    def entropy(values: np.ndarray) -> float:
        counts, _ = np.histogram(values, bins=edges)
        p = counts[counts > 0] / values.size
        return float(-np.sum(p * np.log(p)))

    h_r = entropy(returns.ravel())
    h_r_given_theta = float(np.mean([entropy(row) for row in returns]))
    return PICResult(pic=h_r - h_r_given_theta, h_r=h_r, h_r_given_theta=h_r_given_theta, bins=bins)
