"""POIC: hand-computed mutual information, the log-space computation and the temperature search."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.special
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from taskcomplexity.metrics import POICSearch, mutual_information_curve, poic
from taskcomplexity.metrics.poic import PolicyLogMeans
from taskcomplexity.metrics.temperature import TemperatureLattice


def h(p: float) -> float:
    """Binary entropy in nats, written out independently of the library."""
    return -sum(x * math.log(x) for x in (p, 1 - p) if x > 0)


@st.composite
def return_matrices(draw) -> np.ndarray:
    """Small continuous or integer-valued return matrices."""
    shape = (draw(st.integers(2, 8)), draw(st.integers(2, 8)))
    if draw(st.booleans()):
        elements = st.integers(-50, 0).map(float)
    else:
        elements = st.floats(-100, 100, allow_nan=False, allow_subnormal=False)
    return draw(hnp.arrays(np.float64, shape, elements=elements))


def test_mutual_information_of_two_policies_by_hand():
    returns = np.array([[0.0, -1.0], [-2.0, -3.0]])  # S* = 0
    p1, p2 = (1 + math.exp(-1)) / 2, (math.exp(-2) + math.exp(-3)) / 2
    curve = mutual_information_curve(returns, [1.0])
    # Both sides are a handful of exps and logs of values near 1: agreement to 1e-14.
    assert curve["h_o"][0] == pytest.approx(h((p1 + p2) / 2), abs=1e-14)
    assert curve["h_o_given_theta"][0] == pytest.approx((h(p1) + h(p2)) / 2, abs=1e-14)
    assert curve["mi"][0] == pytest.approx(h((p1 + p2) / 2) - (h(p1) + h(p2)) / 2, abs=1e-14)


def test_a_known_optimal_return_shifts_the_reference():
    returns = np.array([[0.0, -1.0], [-2.0, -3.0]])
    p1, p2 = math.exp(-1) * (1 + math.exp(-1)) / 2, math.exp(-1) * (math.exp(-2) + math.exp(-3)) / 2
    curve = mutual_information_curve(returns, [1.0], optimal_return=1.0)
    assert curve["mi"][0] == pytest.approx(h((p1 + p2) / 2) - (h(p1) + h(p2)) / 2, abs=1e-14)
    assert poic(returns, optimal_return=1.0).s_star == 1.0
    assert poic(returns, optimal_return=-5.0).s_star == 0.0


def test_small_temperatures_reach_the_limit_without_underflow():
    # At λ = 1e-4 every exp((S - S*)/λ) below the best episode underflows in linear space;
    # in log space p₁ = 1/2 (one of two episodes at S*) and p₂ = 0 exactly in the limit.
    returns = np.array([[0.0, -1000.0], [-500.0, -700.0]])
    curve = mutual_information_curve(returns, [1e-4, 1e-2])
    np.testing.assert_allclose(curve["mi"], h(0.25) - h(0.5) / 2, rtol=0, atol=1e-15)


def test_mutual_information_decays_as_one_over_temperature(continuous_returns):
    # With dₙ = S* - Mₙ, 1 - pₙ = dₙ/λ + O(1/λ²), and the entropy terms linear in 1 - pₙ cancel:
    # λ·MI(λ) -> (1/N) Σ dₙ ln(dₙ / d̄). At λ = 1e8 the O(d/λ) remainder is ~1e-7 relative.
    d = continuous_returns.max() - continuous_returns.mean(axis=1)
    limit = np.mean(d * np.log(d / d.mean()))
    mi = mutual_information_curve(continuous_returns, [1e8])["mi"][0]
    assert 1e8 * mi == pytest.approx(limit, rel=1e-5)


@pytest.mark.parametrize("returns_fixture", ["continuous_returns", "integer_returns"])
def test_log_means_equal_scipy_logsumexp(returns_fixture, request):
    # Covers the dense path (continuous returns) and the path that stores repeated returns once.
    returns = request.getfixturevalue(returns_fixture)
    temperatures = np.geomspace(1e-4, 2e4, 40)
    source = PolicyLogMeans(returns)
    centred = returns - returns.max(axis=1, keepdims=True)
    expected = scipy.special.logsumexp(centred[:, :, None] / temperatures, axis=1) - np.log(returns.shape[1])
    # Values lie in [-ln M, 0]; different summation orders agree to a few ulps.
    np.testing.assert_allclose(source.evaluate(temperatures), expected, rtol=0, atol=1e-13)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(returns=return_matrices())
def test_search_finds_at_least_the_maximum_of_a_dense_reference_grid(returns):
    found = poic(returns)
    reference = mutual_information_curve(returns, np.geomspace(1e-4, 2e4, 5000))["mi"].max()
    # The refined lattice is finer than the reference grid (ln-step 0.003 vs 0.0038), but its
    # points differ: near a maximum MI is quadratic in ln λ with curvature of order 1 nat, so a
    # half step of 0.0015 costs at most ~1e-6 nats.
    assert found.poic >= reference - 1e-6
    assert found.poic == pytest.approx(mutual_information_curve(returns, [found.temperature])["mi"][0], abs=1e-12)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(returns=return_matrices())
def test_poic_is_a_mutual_information_of_a_binary_variable(returns):
    found = poic(returns)
    # 0 <= MI <= H(O) <= ln 2, up to summation rounding.
    assert -1e-12 <= found.poic <= found.h_o + 1e-12
    assert found.h_o <= math.log(2) + 1e-12
    assert found.poic == pytest.approx(found.h_o - found.h_o_given_theta, abs=1e-15)
    assert 1e-4 <= found.temperature <= 2e4


def test_the_default_search_is_the_published_one():
    # Range 1e-4 … 2e4 with 200 coarse points (the published search's range and trial count).
    assert POICSearch().lattice() == TemperatureLattice(low=1e-4, high=2e4, grid_points=200, refine_points=32,
                                                        refine_peaks=3)


def test_refinement_never_lowers_the_estimate(continuous_returns, integer_returns):
    for returns in (continuous_returns, integer_returns):
        assert poic(returns).poic >= poic(returns, search=POICSearch(refine_points=1)).poic


def test_the_search_is_deterministic(continuous_returns):
    assert poic(continuous_returns) == poic(continuous_returns)


def test_maximum_inside_the_range_is_not_at_the_boundary(continuous_returns):
    found = poic(continuous_returns)
    assert not found.at_boundary
    assert 1e-3 < found.temperature < 1e3


def test_a_range_below_the_maximum_puts_it_at_the_upper_boundary(continuous_returns):
    # MI rises on the way to its interior maximum, so a range just below it is maximal at its
    # upper end. (Far below, small-sample curves can rise again towards the λ -> 0 limit.)
    best = poic(continuous_returns).temperature
    found = poic(continuous_returns, search=POICSearch(temperature_range=(best / 4, best / 2)))
    assert found.at_boundary
    assert found.temperature == best / 2


def test_a_range_above_the_maximum_puts_it_at_the_lower_boundary(continuous_returns):
    best = poic(continuous_returns).temperature
    found = poic(continuous_returns, search=POICSearch(temperature_range=(best * 2, best * 4)))
    assert found.at_boundary
    assert found.temperature == best * 2


def test_equal_returns_carry_no_information():
    found = poic(np.full((3, 4), -50.0))
    assert (found.poic, found.h_o, found.h_o_given_theta) == (0.0, 0.0, 0.0)
    assert found.temperature == 1e-4  # a flat curve: the lowest temperature wins the tie
    assert found.at_boundary


def test_a_shared_log_means_changes_nothing_and_must_match_the_returns(continuous_returns):
    source = PolicyLogMeans(continuous_returns)
    assert poic(continuous_returns, log_means=source) == poic(continuous_returns)
    assert poic(continuous_returns, log_means=source) == poic(continuous_returns)  # now from its cache
    with pytest.raises(ValueError, match="log_means must be PolicyLogMeans\\(returns\\)"):
        poic(continuous_returns + 1.0, log_means=source)


def test_policy_terms_equal_the_plain_formula_bit_for_bit():
    # _policy_terms takes the terms of the clipped floor ln p = -700 computed once; every value must
    # still be the plain formula's, at temperatures that put policies on the floor, inside and at 1.
    from taskcomplexity.metrics.poic import _policy_terms

    rng = np.random.default_rng(5)
    returns = rng.normal(-30.0, 10.0, size=(40, 1)) + rng.normal(0.0, 3.0, size=(40, 25))
    source = PolicyLogMeans(returns)
    temperatures = np.geomspace(1e-3, 1e3, 40)
    log_means = source.evaluate(temperatures)
    reference = float(returns.max())
    out = np.empty((40, 3, temperatures.size))
    _policy_terms(log_means, source.row_max, temperatures, np.arange(temperatures.size), reference, out)
    expected = np.empty_like(out)
    for n in range(40):
        for c, temperature in enumerate(temperatures):
            log_p = min(max(log_means[n, c] + (source.row_max[n] - reference) / temperature, -700.0), 0.0)
            p, q = math.exp(log_p), -math.expm1(log_p)
            expected[n, :, c] = p, q, -(p * log_p + math.log(max(q, 1e-300)) * q)
    assert (expected[:, 0] == math.exp(-700.0)).any() and (expected[:, 0] > 0.5).any()
    np.testing.assert_array_equal(out, expected)
    columns = np.array([3, 17, 18, 39])  # a subset of the columns: the same values at those columns
    part = np.empty((40, 3, columns.size))
    _policy_terms(log_means, source.row_max, temperatures, columns, reference, part)
    np.testing.assert_array_equal(part, expected[:, :, columns])


def test_curves_of_the_needed_temperatures_equal_the_full_curves():
    # Populations with different S* and different needs: each group of equal S* is computed at the
    # union of its needs, the rest is NaN. The values computed agree with computing every temperature
    # for every group up to the BLAS's reduction order (a few ulps of sums of N terms); where one
    # population is alone, or needs everything, they are identical.
    from taskcomplexity.metrics.bootstrap import bootstrap_multiplicities
    from taskcomplexity.metrics.poic import optimality_curves

    rng = np.random.default_rng(3)
    returns = rng.normal(-30.0, 10.0, size=(300, 1)) + rng.normal(0.0, 3.0, size=(300, 40))
    source = PolicyLogMeans(returns)
    temperatures = np.geomspace(0.1, 100.0, 60)
    log_means = source.evaluate(temperatures)
    weights = bootstrap_multiplicities(300, resamples=50, seed=2)
    s_star = np.where(weights > 0, source.row_max, -np.inf).max(axis=1)
    assert np.unique(s_star).size >= 2
    needed = np.zeros((50, 60), dtype=bool)
    for row, start in enumerate(rng.integers(0, 50, size=50)):
        needed[row, start:start + 10] = True
    full = optimality_curves(log_means, source.row_max, temperatures, weights, s_star)
    part = optimality_curves(log_means, source.row_max, temperatures, weights, s_star, needed)
    for name in ("mi", "h_o", "h_o_given_theta"):
        got, reference = getattr(part, name), getattr(full, name)
        np.testing.assert_allclose(got[needed], reference[needed], rtol=0, atol=1e-14)
        groups = [np.flatnonzero(s_star == value) for value in np.unique(s_star)]
        unneeded = np.zeros_like(needed)
        for rows in groups:
            unneeded[rows] = ~needed[rows].any(axis=0)
        assert np.isnan(got[unneeded]).all() and not np.isnan(got[~unneeded]).any()
    everything = optimality_curves(log_means, source.row_max, temperatures, weights, s_star,
                                   np.ones((50, 60), dtype=bool))
    np.testing.assert_array_equal(everything.mi, full.mi)
