"""Per-policy statistics and the normalised random-sampling score (Oller et al. 2020)."""

from __future__ import annotations

from dataclasses import astuple

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.metrics import ScoreSummary, policy_statistics, random_sampling_score

# Policy 1 and policy 3 tie on the mean; the tie keeps sampling order.
RETURNS = np.array(
    [
        [4.0, 6.0, 8.0],  # mean 6, variance 4
        [1.0, 2.0, 3.0],  # mean 2, variance 1
        [9.0, 9.0, 9.0],  # mean 9, variance 0
        [0.0, 2.0, 4.0],  # mean 2, variance 4
    ]
)


def test_policy_statistics_of_a_hand_computed_matrix():
    table = policy_statistics(RETURNS)
    expected = pd.DataFrame(
        {
            "policy": [0, 1, 2, 3],
            "mean": [6.0, 2.0, 9.0, 2.0],
            "variance": [4.0, 1.0, 0.0, 4.0],
            "std": [2.0, 1.0, 0.0, 2.0],
            "rank": [3, 1, 4, 2],
            "scaled_mean": [4 / 7, 0.0, 1.0, 0.0],
        }
    )
    # Means and variances of small integers are exact up to one rounding: 1e-12 is generous.
    pd.testing.assert_frame_equal(table, expected, rtol=0, atol=1e-12)


def test_ranks_are_a_stable_sort_of_the_means():
    rng = np.random.default_rng(3)
    returns = rng.integers(0, 3, size=(50, 2)).astype(float)  # many tied means
    table = policy_statistics(returns)
    np.testing.assert_array_equal(np.argsort(table["rank"].to_numpy()), np.argsort(table["mean"], kind="stable"))
    assert sorted(table["rank"]) == list(range(1, 51))


def test_scaled_mean_is_zero_when_every_policy_has_the_same_mean():
    table = policy_statistics(np.array([[1.0, 3.0], [2.0, 2.0], [3.0, 1.0]]))
    np.testing.assert_array_equal(table["scaled_mean"], 0.0)


def test_random_sampling_score_of_a_hand_computed_matrix():
    summary = random_sampling_score(RETURNS)
    r_mean = RETURNS.mean()  # 57 / 12 = 4.75
    variance = RETURNS.var()  # ddof 0
    expected = ScoreSummary(r_min=2.0, r_max=9.0, r_mean=4.75, score=(4.75 - 2) / 7, variance=variance / 7)
    assert astuple(summary) == pytest.approx(astuple(expected), rel=1e-12)
    assert r_mean == 4.75


def test_a_better_algorithm_return_raises_r_max_and_a_worse_one_is_ignored():
    assert random_sampling_score(RETURNS, best_return=16.0).r_max == 16.0
    assert random_sampling_score(RETURNS, best_return=16.0).score == pytest.approx(2.75 / 14, rel=1e-12)
    assert random_sampling_score(RETURNS, best_return=5.0) == random_sampling_score(RETURNS)


def test_score_is_undefined_when_every_return_is_equal():
    summary = random_sampling_score(np.full((3, 4), -50.0))
    assert (summary.r_min, summary.r_max, summary.r_mean) == (-50.0, -50.0, -50.0)
    assert np.isnan(summary.score) and np.isnan(summary.variance)
    assert random_sampling_score(np.full((3, 4), -50.0), best_return=0.0).score == 0.0
