"""The occupancy distance: exact W₂ with POT on standardised state–action pairs."""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.metrics.occupancy import OccupancySample, Standardiser, occupancy_distances, wasserstein2


def test_the_distance_of_an_occupancy_to_itself_is_zero():
    pairs = np.random.default_rng(0).normal(size=(60, 5))
    assert wasserstein2(pairs, pairs) == pytest.approx(0.0, abs=1e-7)
    assert wasserstein2(pairs, pairs[::-1]) == pytest.approx(0.0, abs=1e-7)  # order is irrelevant


@pytest.mark.parametrize("shift", [0.1, 0.5, 2.0, 7.5])
def test_a_shifted_copy_is_exactly_the_shift_away(shift):
    # W₂²(μ, μ + δ) = ‖δ‖²: the translation is the optimal coupling
    pairs = np.random.default_rng(1).normal(size=(40, 3))
    direction = np.array([3.0, -4.0, 0.0]) / 5.0
    assert wasserstein2(pairs, pairs + shift * direction) == pytest.approx(shift, rel=1e-9)


def test_in_one_dimension_it_matches_sorted_matching():
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=50), rng.exponential(size=50)
    expected = np.sqrt(np.mean((np.sort(a) - np.sort(b)) ** 2))  # the 1-D W₂ between equal-size samples
    assert wasserstein2(a[:, None], b[:, None]) == pytest.approx(expected, rel=1e-9)


def test_unequal_sizes_are_weighed_uniformly():
    # 2 points at 0 and 1 against 4 points at 0, 0, 1, 1: the same distribution
    a = np.array([[0.0], [1.0]])
    b = np.array([[0.0], [0.0], [1.0], [1.0]])
    assert wasserstein2(a, b) == pytest.approx(0.0, abs=1e-9)
    assert wasserstein2(a, np.array([[0.0]])) == pytest.approx(np.sqrt(0.5))


def test_distances_grow_with_the_shift_and_ignore_units():
    rng = np.random.default_rng(3)
    reference = rng.normal(size=(80, 4))
    policies = [reference + s for s in (0.0, 0.3, 1.0, 3.0)]
    d = occupancy_distances(policies, reference)
    assert d[0] == pytest.approx(0.0, abs=1e-7)
    assert np.all(np.diff(d) > 0)
    # a feature in other units (×1000, offset) leaves every distance unchanged: the pooled standardisation
    scale, offset = np.array([1000.0, 1.0, 0.01, 1.0]), np.array([5.0, 0.0, -3.0, 0.0])
    again = occupancy_distances([p * scale + offset for p in policies], reference * scale + offset)
    np.testing.assert_allclose(again, d, rtol=1e-9, atol=1e-7)  # sqrt of a rounding-level W₂² at 0


def test_the_standardiser_pools_and_leaves_constant_features_unscaled():
    s = Standardiser.fit([np.array([[0.0, 2.0], [2.0, 2.0]]), np.array([[4.0, 2.0]])])
    np.testing.assert_allclose(s.mean, [2.0, 2.0])
    np.testing.assert_allclose(s.scale, [np.sqrt(8 / 3), 1.0])
    np.testing.assert_allclose(s(np.array([[2.0, 2.0]])), [[0.0, 0.0]])


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="same columns"):
        wasserstein2(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="non-empty"):
        wasserstein2(np.zeros((0, 2)), np.zeros((3, 2)))


def test_the_sample_gives_mean_variance_and_subsamples():
    sample = OccupancySample(np.array([1.0, 2.0, 3.0, 6.0]))
    assert sample.mean == 3.0
    assert sample.variance == pytest.approx(np.var([1, 2, 3, 6], ddof=1))
    assert sample.subsample(np.array([0, 3])).mean == 3.5
    assert np.isnan(OccupancySample(np.array([1.0])).variance)
