"""PIC, the histogram estimator of I(Θ; R): properties, closed-form cases and the reference loop."""

from __future__ import annotations

from dataclasses import astuple

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from taskcomplexity.metrics import PICResult, pic, pic_reference

# The fast and the reference estimators differ only in summation order and in computing
# ln n - Σ c ln c / n instead of -Σ p ln p: a few ulps of values below ~15 nats.
SAME_ESTIMATE = 1e-12


@st.composite
def return_matrices(draw, max_policies: int = 10, max_episodes: int = 10) -> np.ndarray:
    """Continuous returns, or integer returns in {-50, …, 0} with ties (sparse rewards)."""
    shape = (draw(st.integers(2, max_policies)), draw(st.integers(2, max_episodes)))
    if draw(st.booleans()):
        elements = st.integers(-50, 0).map(float)
    else:
        elements = st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=False)
    return draw(hnp.arrays(np.float64, shape, elements=elements))


@settings(max_examples=150, deadline=None, derandomize=True)
@given(returns=return_matrices(), bins=st.integers(2, 1000))
def test_fast_estimate_equals_the_reference_loop(returns, bins):
    fast, reference = pic(returns, bins=bins), pic_reference(returns, bins=bins)
    assert fast.bins == reference.bins == bins
    for field in ("pic", "h_r", "h_r_given_theta"):
        assert getattr(fast, field) == pytest.approx(getattr(reference, field), abs=SAME_ESTIMATE)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(returns=return_matrices(), bins=st.integers(2, 1000))
def test_pic_lies_between_zero_and_ln_n(returns, bins):
    # The pooled histogram is the equal mixture of the per-policy ones, so by concavity
    # mean Hₙ <= H(R) <= mean Hₙ + ln N holds exactly for plug-in entropies.
    estimate = pic(returns, bins=bins)
    assert -SAME_ESTIMATE <= estimate.pic <= np.log(returns.shape[0]) + SAME_ESTIMATE


@settings(max_examples=100, deadline=None, derandomize=True)
@given(
    base=hnp.arrays(np.float64, st.integers(2, 12), elements=st.floats(-100, 100, allow_subnormal=False)),
    policies=st.integers(2, 8),
    bins=st.integers(2, 500),
    seed=st.integers(0, 2**32 - 1),
)
def test_pic_is_zero_when_every_policy_has_the_same_multiset_of_returns(base, policies, bins, seed):
    rng = np.random.default_rng(seed)
    returns = np.stack([rng.permutation(base) for _ in range(policies)])
    assert pic(returns, bins=bins).pic == pytest.approx(0.0, abs=SAME_ESTIMATE)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(
    policies=st.integers(2, 12),
    episodes=st.integers(2, 12),
    spare_bins=st.integers(0, 500),
    seed=st.integers(0, 2**32 - 1),
)
def test_pic_is_ln_n_for_disjoint_supports_with_one_return_per_bin(policies, episodes, spare_bins, seed):
    # Policy n returns n·M, n·M + 1, …; with B >= N·M bins narrower than 1, every return has its
    # own bin: Hₙ = ln M, H(R) = ln(N·M), so PIC = ln N.
    rng = np.random.default_rng(seed)
    returns = np.arange(policies * episodes, dtype=float).reshape(policies, episodes)
    returns = rng.permuted(rng.permutation(returns), axis=1)
    estimate = pic(returns, bins=policies * episodes + spare_bins)
    assert estimate.pic == pytest.approx(np.log(policies), abs=SAME_ESTIMATE)
    assert estimate.h_r_given_theta == pytest.approx(np.log(episodes), abs=SAME_ESTIMATE)


def test_pic_is_ln_n_when_each_policy_always_returns_its_own_value():
    returns = np.repeat(np.array([[-3.0], [0.0], [5.0], [7.5]]), 6, axis=1)
    estimate = pic(returns, bins=1000)
    assert astuple(estimate) == pytest.approx((np.log(4), np.log(4), 0.0, 1000), abs=SAME_ESTIMATE)


def test_two_policies_two_bins_by_hand():
    # Bins [0, 0.5) and [0.5, 1]: pooled counts (3, 1); policy 0 (2, 0), policy 1 (1, 1).
    returns = np.array([[0.0, 0.1], [0.2, 1.0]])
    h_r = -(0.75 * np.log(0.75) + 0.25 * np.log(0.25))
    expected = PICResult(pic=h_r - np.log(2) / 2, h_r=h_r, h_r_given_theta=np.log(2) / 2, bins=2)
    assert astuple(pic(returns, bins=2)) == pytest.approx(astuple(expected), abs=1e-15)


def test_all_equal_returns_give_zero():
    assert pic(np.full((4, 3), -50.0), bins=10) == PICResult(0.0, 0.0, 0.0, 10)
    assert pic_reference(np.full((4, 3), -50.0), bins=10) == PICResult(0.0, 0.0, 0.0, 10)


def test_pic_ignores_the_order_of_policies_and_of_episodes(continuous_returns):
    rng = np.random.default_rng(5)
    shuffled = rng.permuted(rng.permutation(continuous_returns), axis=1)
    assert pic(shuffled, bins=50).pic == pytest.approx(pic(continuous_returns, bins=50).pic, abs=SAME_ESTIMATE)


def test_default_bins_are_the_published_hundred_thousand(continuous_returns):
    assert pic(continuous_returns).bins == 100_000
