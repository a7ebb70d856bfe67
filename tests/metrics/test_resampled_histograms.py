"""The bootstrap's pooled-histogram kernel against pooled histograms built one resample at a time."""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.metrics.histogram import bin_edges, bin_indices, sum_xlogx
from taskcomplexity.metrics.resampled_histograms import (
    RESAMPLES_PER_BLOCK,
    SortedReturns,
    pooled_xlogx,
    sorted_row_xlogx,
)

# Pooled counts are exact integers on both sides; the Σ c ln c of up to 1e4 bins differ only in
# summation order (compensated in the kernel, pairwise in numpy): relative 1e-14 is ample.
SAME_SUM = 1e-14


def direct(returns: np.ndarray, edges: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Σ c ln c of each resample's pooled histogram: repeat each policy's bins w times, bincount."""
    totals = []
    for w in weights:
        present = w > 0
        bins = bin_indices(returns[present], edges)
        pooled = np.bincount(bins.ravel(), weights=np.repeat(w[present], returns.shape[1]), minlength=edges.size - 1)
        totals.append(sum_xlogx(pooled))
    return np.array(totals)


@pytest.mark.parametrize("kind", ["continuous", "integer"])
@pytest.mark.parametrize("resamples", [1, RESAMPLES_PER_BLOCK + 3])
def test_pooled_xlogx_equals_the_resampled_histograms(kind, resamples):
    rng = np.random.default_rng(resamples)
    returns = rng.normal(size=(40, 30)) * rng.uniform(0.5, 2.0, size=(40, 1))
    if kind == "integer":
        returns = np.round(returns * 3)
    weights = rng.multinomial(40, np.full(40, 1 / 40), size=resamples)
    edges = bin_edges(returns.min(), returns.max(), 97)
    expected = direct(returns, edges, weights)
    np.testing.assert_allclose(pooled_xlogx(SortedReturns.of(returns), edges, weights), expected, rtol=SAME_SUM)


def test_returns_outside_the_edges_belong_to_absent_policies():
    # A group of resamples without the policy holding the extremes bins on narrower edges; that
    # policy's returns fall outside them and must not count (its weight is 0).
    rng = np.random.default_rng(2)
    returns = rng.normal(size=(12, 20))
    returns[0, 0], returns[0, 1] = -50.0, 50.0
    weights = rng.multinomial(11, np.full(11, 1 / 11), size=5)
    weights = np.column_stack((np.zeros(5, dtype=np.int64), weights))
    edges = bin_edges(returns[1:].min(), returns[1:].max(), 64)
    np.testing.assert_allclose(pooled_xlogx(SortedReturns.of(returns), edges, weights),
                               direct(returns, edges, weights), rtol=SAME_SUM)


def test_large_multiplicities_take_the_wide_path():
    # Multiplicities above 255 do not fit the packed bytes; the result must not change.
    rng = np.random.default_rng(3)
    returns = rng.normal(size=(6, 10))
    weights = np.array([[300, 0, 1, 2, 0, 5], [1, 1, 1, 1, 1, 1]])
    edges = bin_edges(returns.min(), returns.max(), 16)
    np.testing.assert_allclose(pooled_xlogx(SortedReturns.of(returns), edges, weights),
                               direct(returns, edges, weights), rtol=SAME_SUM)


def test_sorted_row_xlogx_of_chosen_rows():
    rng = np.random.default_rng(5)
    returns = np.sort(np.round(rng.normal(size=(9, 25)), 1), axis=1)
    edges = bin_edges(returns.min(), returns.max(), 31)
    rows = np.array([7, 0, 3])
    expected = [sum_xlogx(np.bincount(bin_indices(returns[r], edges), minlength=31)) for r in rows]
    np.testing.assert_allclose(sorted_row_xlogx(returns, rows, edges), expected, rtol=1e-14)
