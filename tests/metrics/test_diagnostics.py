"""Estimator diagnostics: permutation null, sweeps, Miller–Madow and nearest-neighbour MI."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.metrics import (
    POICSearch,
    permutation_null,
    pic,
    pic_bins_sweep,
    pic_knn,
    pic_miller_madow,
    pic_subsample_sweep,
    plugin_entropy,
    summarise_null,
)
from taskcomplexity.metrics.diagnostics import null_pic


def test_observed_pic_of_iid_returns_lies_within_its_permutation_null():
    # With i.i.d. returns the matrix is exchangeable with its permutations, so the observed PIC is
    # one more draw of the null distribution; 4 null standard deviations would be exceeded with
    # probability ~1e-4 for a normal null. The seed is fixed, so the test is deterministic.
    rng = np.random.default_rng(8)
    returns = rng.normal(-30.0, 4.0, size=(40, 25))
    observed = pic(returns, bins=2000)
    null = permutation_null(returns, seed=9, repeats=20, bins=2000, search=POICSearch(grid_points=40, refine_points=4))
    summary = summarise_null(null, {"pic": observed.pic}).set_index("metric")
    assert abs(summary.loc["pic", "z"]) < 4
    # And the histogram estimator is far from 0 on data whose true MI is 0: the bias it measures.
    assert summary.loc["pic", "null_mean"] > 1.0


def test_observed_pic_of_informative_returns_exceeds_its_null():
    rng = np.random.default_rng(8)
    returns = rng.normal(0.0, 10.0, size=(40, 1)) + rng.normal(0.0, 1.0, size=(40, 25))
    null = permutation_null(returns, seed=9, repeats=5, bins=50, search=POICSearch(grid_points=40, refine_points=4))
    summary = summarise_null(null, {"pic": pic(returns, bins=50).pic}).set_index("metric")
    assert summary.loc["pic", "excess"] > 1.0 and summary.loc["pic", "z"] > 10


def test_permutation_null_keeps_the_pooled_returns(continuous_returns):
    null = permutation_null(continuous_returns, seed=1, repeats=3, bins=30, search=POICSearch(grid_points=30, refine_points=2))
    assert null["repeat"].tolist() == [0, 1, 2]
    # A permutation keeps every pooled statistic: the edges, hence H(R), are unchanged.
    np.testing.assert_allclose(null["h_r"], pic(continuous_returns, bins=30).h_r, rtol=0, atol=1e-12)
    again = permutation_null(continuous_returns, seed=1, repeats=3, bins=30, search=POICSearch(grid_points=30, refine_points=2))
    pd.testing.assert_frame_equal(null, again)


def test_miller_madow_adds_occupied_bins_minus_one_over_twice_the_sample_size():
    # Edges 0, 1, …, 4 (four bins, last closed). Policy 0: bins 0, 0, 1, 3; policy 1: 2, 2, 2, 3.
    returns = np.array([[0.0, 0.5, 1.0, 3.5], [2.0, 2.2, 2.9, 4.0]])
    h_r = plugin_entropy([2, 1, 3, 2]) + (4 - 1) / (2 * 8)
    h_0 = plugin_entropy([2, 1, 0, 1]) + (3 - 1) / (2 * 4)
    h_1 = plugin_entropy([0, 0, 3, 1]) + (2 - 1) / (2 * 4)
    corrected = pic_miller_madow(returns, bins=4)
    # Closed-form values built from the same plug-in entropies: agreement to rounding.
    assert corrected.h_r == pytest.approx(h_r, abs=1e-15)
    assert corrected.h_r_given_theta == pytest.approx((h_0 + h_1) / 2, abs=1e-15)
    assert corrected.pic == pytest.approx(h_r - (h_0 + h_1) / 2, abs=1e-15)
    assert pic(returns, bins=4).h_r == pytest.approx(plugin_entropy([2, 1, 3, 2]), abs=1e-15)


def test_miller_madow_of_equal_returns_is_zero():
    assert pic_miller_madow(np.full((3, 3), 1.0), bins=10).pic == 0.0


def test_nearest_neighbour_mi_is_near_zero_for_independent_returns():
    rng = np.random.default_rng(12)
    returns = rng.normal(size=(50, 60))
    estimate = pic_knn(returns, seed=0)
    # The Ross estimator's standard error at 3000 samples is ~0.01 nats; scikit-learn clips the
    # estimate at 0.
    assert 0.0 <= estimate.mi < 0.03
    assert (estimate.policies, estimate.episodes, estimate.n_neighbors) == (50, 50, 3)


def test_nearest_neighbour_mi_is_ln_k_for_well_separated_policies():
    # Every neighbour of a return belongs to its own policy, so the estimate is
    # ψ(K·m) - ψ(m) = ln K + O(1/m): about ln 4 - 0.004 here.
    rng = np.random.default_rng(12)
    returns = 100.0 * np.arange(4)[:, None] + rng.normal(size=(4, 100))
    estimate = pic_knn(returns, seed=0, episodes_per_policy=100)
    assert estimate.mi == pytest.approx(np.log(4), abs=0.01)


def test_nearest_neighbour_mi_is_deterministic_and_handles_ties(integer_returns):
    # Integer returns tie massively; scikit-learn's tiny seeded jitter orders ties reproducibly.
    first = pic_knn(integer_returns, seed=3)
    assert first == pic_knn(integer_returns, seed=3)
    assert 0.0 <= first.mi <= np.log(integer_returns.shape[0])


def test_nearest_neighbour_subsample_respects_max_samples():
    returns = np.random.default_rng(0).normal(size=(100, 40))
    estimate = pic_knn(returns, seed=0, max_samples=600, episodes_per_policy=20)
    assert (estimate.policies, estimate.episodes) == (30, 20)


def test_nearest_neighbour_needs_more_episodes_than_neighbours():
    with pytest.raises(ValueError, match="episodes_per_policy must be an integer >= 4, got 3"):
        pic_knn(np.zeros((5, 10)), seed=0, episodes_per_policy=3)


def test_bins_sweep_matches_pic_at_each_number_of_bins(continuous_returns):
    sweep = pic_bins_sweep(continuous_returns, bins=(4, 40, 400))
    assert sweep["bins"].tolist() == [4, 40, 400]
    for row in sweep.itertuples():
        assert row.pic == pic(continuous_returns, bins=row.bins).pic
        assert row.pic_miller_madow == pic_miller_madow(continuous_returns, bins=row.bins).pic


def test_subsample_sweep_is_nested_and_its_full_sample_is_the_estimate(continuous_returns):
    sweep = pic_subsample_sweep(continuous_returns, seed=4, policies=(3, 12), episodes=(2, 8), bins=20)
    assert list(zip(sweep["policies"], sweep["episodes"], strict=True)) == [(3, 2), (3, 8), (12, 2), (12, 8)]
    # PIC ignores the order of policies and of episodes, so the full subsample is the estimate.
    full = sweep.set_index(["policies", "episodes"]).loc[(12, 8), "pic"]
    assert full == pytest.approx(pic(continuous_returns, bins=20).pic, abs=1e-12)
    pd.testing.assert_frame_equal(
        sweep, pic_subsample_sweep(continuous_returns, seed=4, policies=(3, 12), episodes=(2, 8), bins=20)
    )


def test_subsample_sweep_defaults_and_limits(continuous_returns):
    sweep = pic_subsample_sweep(continuous_returns, seed=0, bins=20)  # N = 12, M = 8
    assert sorted(set(sweep["policies"])) == [3, 6, 12]
    assert sorted(set(sweep["episodes"])) == [2, 4, 8]
    with pytest.raises(ValueError, match="policies must be integers between 2 and 12, got \\[13\\]"):
        pic_subsample_sweep(continuous_returns, seed=0, policies=[13])


def test_null_pic_is_the_pic_column_of_the_permutation_null(continuous_returns):
    # Computed afresh (nothing remembered for seed 31) and reused after permutation_null: both are
    # the PIC of the same permutations.
    fresh = null_pic(continuous_returns, seed=31, repeats=4, bins=40)
    null = permutation_null(continuous_returns, seed=31, repeats=4, bins=40, search=POICSearch(grid_points=20, refine_points=2))
    np.testing.assert_array_equal(fresh, null["pic"])
    np.testing.assert_array_equal(null_pic(continuous_returns, seed=31, repeats=4, bins=40), null["pic"])
    changed = continuous_returns.copy()
    changed[0, 0] += 1.0  # other content: not served from memory
    assert not np.array_equal(null_pic(changed, seed=31, repeats=4, bins=40), fresh)
