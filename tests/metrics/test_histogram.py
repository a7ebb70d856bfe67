"""Binning and sparse per-policy histograms agree with numpy.histogram bin for bin."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from taskcomplexity.metrics import bin_edges, plugin_entropy, policy_bin_counts
from taskcomplexity.metrics.histogram import bin_indices, histogram_terms

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(values=hnp.arrays(np.float64, st.integers(2, 60), elements=finite), bins=st.integers(2, 5000))
def test_bin_indices_equal_searchsorted_with_a_closed_last_bin(values, bins):
    if values.min() == values.max():
        values = np.append(values, values[0] + 1.0)
    edges = bin_edges(values.min(), values.max(), bins)
    # Values sitting exactly on edges are the hard case for the linear formula.
    on_edges = edges[np.linspace(0, bins, 7).astype(int)]
    # One ulp either side of inner edges: the fast path must leave them to the careful one.
    near_edges = np.clip(np.r_[np.nextafter(on_edges, -np.inf), np.nextafter(on_edges, np.inf)], edges[0], edges[-1])
    for sample in (values, on_edges, near_edges):
        expected = np.minimum(np.searchsorted(edges, sample, side="right") - 1, bins - 1)
        np.testing.assert_array_equal(bin_indices(sample, edges), expected)


def test_bin_indices_handle_a_span_too_narrow_for_the_linear_formula():
    low = 1e-300
    edges = bin_edges(low, np.nextafter(low, 1.0), 10**5)  # B / span overflows to inf
    values = np.array([low, np.nextafter(low, 1.0)])
    expected = np.minimum(np.searchsorted(edges, values, side="right") - 1, 10**5 - 1)
    np.testing.assert_array_equal(bin_indices(values, edges), expected)
    assert bin_indices(values, edges)[-1] == 10**5 - 1


def test_policy_bin_counts_match_numpy_histogram_row_by_row():
    rng = np.random.default_rng(11)
    returns = np.round(rng.normal(size=(9, 40)), 1)  # rounding creates shared bins and ties
    edges = bin_edges(returns.min(), returns.max(), 17)
    counts = policy_bin_counts(returns, edges)
    assert (counts.n_policies, counts.n_bins, counts.n_episodes) == (9, 17, 40)
    for policy, row in enumerate(returns):
        dense = np.zeros(17, dtype=np.int64)
        part = slice(counts.indptr[policy], counts.indptr[policy + 1])
        dense[counts.bins[part]] = counts.counts[part]
        np.testing.assert_array_equal(dense, np.histogram(row, bins=edges)[0])
        assert counts.occupied_bins()[policy] == np.count_nonzero(dense)
    np.testing.assert_array_equal(counts.pooled_counts(), np.histogram(returns, bins=edges)[0])


def test_bin_major_matrix_transposes_the_histograms_and_drops_empty_bins():
    returns = np.array([[0.0, 0.0, 9.0], [9.0, 9.0, 10.0]])
    counts = policy_bin_counts(returns, bin_edges(0.0, 10.0, 10))
    # Occupied bins: 0 (policy 0 twice) and 9 ([9, 10] closed: policy 0 once, policy 1 three times).
    np.testing.assert_array_equal(counts.bin_major().toarray(), [[2, 0], [1, 3]])


def test_policy_bin_counts_refuse_edges_that_miss_returns():
    with pytest.raises(ValueError, match="edges must span every return"):
        policy_bin_counts(np.array([[0.0, 1.0], [2.0, 3.0]]), np.linspace(0.0, 2.0, 5))


@pytest.mark.parametrize("size", [1, 2, 7, 1000])
def test_plugin_entropy_of_a_uniform_histogram_is_ln_of_its_support(size):
    # ln n - n·(c ln c)/(n c) is exact up to a few roundings.
    assert plugin_entropy(np.r_[np.full(size, 3), np.zeros(5)]) == pytest.approx(np.log(size), abs=1e-12)


def test_plugin_entropy_of_a_known_histogram():
    p = np.array([0.5, 0.25, 0.25])
    assert plugin_entropy([2, 1, 1, 0]) == pytest.approx(-np.sum(p * np.log(p)), abs=1e-15)


@pytest.mark.parametrize("decimals", [None, 1])
def test_histogram_terms_equal_the_sparse_histograms(decimals):
    # One parallel pass without sorting gives the same pooled counts, occupied bins and Σ c ln c
    # (up to the order of summation of each policy's terms: a few ulps).
    rng = np.random.default_rng(4)
    returns = rng.normal(size=(37, 50)) * rng.uniform(0.1, 3.0, size=(37, 1))
    if decimals is not None:
        returns = np.round(returns, decimals)
    edges = bin_edges(returns.min(), returns.max(), 113)
    returns[0, :3] = edges[[0, 50, -1]]  # values exactly on edges, the last bin closed
    counts = policy_bin_counts(returns, edges)
    terms = histogram_terms(returns, edges)
    np.testing.assert_array_equal(terms.pooled, counts.pooled_counts())
    np.testing.assert_array_equal(terms.occupied, counts.occupied_bins())
    np.testing.assert_allclose(terms.policy_entropies(), counts.policy_entropies(), rtol=0, atol=1e-14)


def test_histogram_terms_sum_c_ln_c_bit_for_bit_in_first_occurrence_order():
    # The kernel adds c ln c of each policy's bins in the order their first return appears and skips
    # counts of 1 (1·ln 1 = +0.0 leaves a sum unchanged): the plain loop in that order must agree to
    # the bit, at B where most bins hold one return and at B where most hold several.
    rng = np.random.default_rng(11)
    returns = rng.normal(size=(23, 300)) * rng.uniform(0.2, 2.0, size=(23, 1))
    for bins in (20, 100_000):
        edges = bin_edges(returns.min(), returns.max(), bins)
        index = bin_indices(returns, edges)
        expected = []
        for row in index:
            counts = np.bincount(row, minlength=bins)
            total, seen = 0.0, set()
            for b in row:
                if b not in seen:
                    seen.add(b)
                    total += float(counts[b]) * math.log(float(counts[b]))
            expected.append(total)
        np.testing.assert_array_equal(histogram_terms(returns, edges).xlogx, expected)
