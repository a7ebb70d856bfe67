"""Every public estimator refuses bad input at the boundary with a message naming the problem."""

from __future__ import annotations

import re

import numpy as np
import pytest

from taskcomplexity import metrics

GOOD = np.arange(12.0).reshape(3, 4)

# Each public function that takes a return matrix, with the keyword arguments it requires.
CALLS = {
    "validate_returns": lambda r: metrics.validate_returns(r),
    "policy_statistics": lambda r: metrics.policy_statistics(r),
    "random_sampling_score": lambda r: metrics.random_sampling_score(r),
    "pic": lambda r: metrics.pic(r, bins=10),
    "pic_reference": lambda r: metrics.pic_reference(r, bins=10),
    "policy_bin_counts": lambda r: metrics.policy_bin_counts(r, np.linspace(0.0, 11.0, 4)),
    "poic": lambda r: metrics.poic(r),
    "mutual_information_curve": lambda r: metrics.mutual_information_curve(r, [1.0]),
    "bootstrap": lambda r: metrics.bootstrap(r, seed=0, resamples=2, bins=10),
    "batch_estimates": lambda r: metrics.batch_estimates(r, metrics.DEFAULT_REGISTRY.of_stage("metrics"), batches=1,
                                                           estimation=metrics.Estimation(bins=10)),
    "permutation_null": lambda r: metrics.permutation_null(r, seed=0, repeats=1, bins=10),
    "pic_bins_sweep": lambda r: metrics.pic_bins_sweep(r, bins=(10,)),
    "pic_subsample_sweep": lambda r: metrics.pic_subsample_sweep(r, seed=0, bins=10),
    "pic_miller_madow": lambda r: metrics.pic_miller_madow(r, bins=10),
    "pic_knn": lambda r: metrics.pic_knn(r, seed=0, n_neighbors=1),
}


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
def test_every_function_accepts_a_valid_matrix(call):
    call(GOOD)


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
@pytest.mark.parametrize(("bad", "policy", "episode"), [(np.nan, 1, 2), (np.inf, 0, 3), (-np.inf, 2, 0)])
def test_non_finite_returns_are_refused_naming_policy_and_episode(call, bad, policy, episode):
    returns = GOOD.copy()
    returns[-1, -1] = np.nan  # a later offender: the message names the first in row-major order
    returns[policy, episode] = bad
    with pytest.raises(ValueError, match=f"returns must be finite; found .* at policy {policy}, episode {episode}"):
        call(returns)


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
def test_a_single_policy_is_refused(call):
    with pytest.raises(ValueError, match="returns must have at least 2 policies \\(rows\\), got 1"):
        call(np.zeros((1, 5)))


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
def test_a_single_episode_is_refused(call):
    with pytest.raises(ValueError, match="returns must have at least 2 episodes \\(columns\\), got 1"):
        call(np.zeros((5, 1)))


@pytest.mark.parametrize("shape", [(6,), (2, 3, 4), ()])
def test_returns_must_be_two_dimensional(shape):
    pattern = f"returns must be a 2-D array .* got an array with shape {re.escape(str(shape))}"
    with pytest.raises(ValueError, match=pattern):
        metrics.validate_returns(np.zeros(shape))


@pytest.mark.parametrize("values", [[["a", "b"], ["c", "d"]], [[True, False], [False, True]], [[1j, 2], [3, 4]]])
def test_returns_must_be_real_numbers(values):
    with pytest.raises(TypeError, match="returns must be an array of real numbers, got dtype"):
        metrics.validate_returns(np.array(values))


def test_validated_returns_are_contiguous_float64():
    checked = metrics.validate_returns(np.arange(6).reshape(3, 2).T)
    assert checked.dtype == np.float64
    assert checked.flags["C_CONTIGUOUS"]
    np.testing.assert_array_equal(checked, [[0, 2, 4], [1, 3, 5]])


@pytest.mark.parametrize("bins", [1, 0, -3, 2.5, "10", True, None])
@pytest.mark.parametrize("estimator", [metrics.pic, metrics.pic_reference, metrics.pic_miller_madow])
def test_bins_must_be_an_integer_of_at_least_two(estimator, bins):
    with pytest.raises(ValueError, match=f"bins must be an integer >= 2, got {bins!r}"):
        estimator(GOOD, bins=bins)


def test_bins_are_checked_by_the_bootstrap_batches_and_sweeps():
    for call in (
        lambda: metrics.bootstrap(GOOD, seed=0, bins=1),
        lambda: metrics.batch_estimates(GOOD, metrics.DEFAULT_REGISTRY.of_stage("metrics"), batches=1,
                                              estimation=metrics.Estimation(bins=1)),
        lambda: metrics.pic_bins_sweep(GOOD, bins=(10, 1)),
        lambda: metrics.permutation_null(GOOD, seed=0, bins=1),
    ):
        with pytest.raises(ValueError, match="bins must be an integer >= 2, got 1"):
            call()


@pytest.mark.parametrize(
    "temperature_range", [(1.0, 1.0), (2.0, 1.0), (0.0, 1.0), (-1.0, 1.0), (1.0, np.inf), (1.0,), "ab"]
)
def test_temperature_range_must_be_positive_and_increasing(temperature_range):
    pattern = "temperature_range must be a pair \\(low, high\\) of finite numbers with 0 < low < high, got"
    search = metrics.POICSearch(temperature_range=temperature_range)
    for call in (search.validate, *_takers_of(search)):
        with pytest.raises(ValueError, match=pattern):
            call()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"grid_points": 1}, "grid_points must be an integer >= 2, got 1"),
        ({"grid_points": 2.0}, "grid_points must be an integer >= 2, got 2.0"),
        ({"refine_points": 0}, "refine_points must be an integer >= 1, got 0"),
        ({"refine_peaks": 0}, "refine_peaks must be an integer >= 1, got 0"),
        ({"refine_peaks": True}, "refine_peaks must be an integer >= 1, got True"),
    ],
)
def test_poic_search_options_are_checked(options, message):
    search = metrics.POICSearch(**options)
    for call in (search.validate, *_takers_of(search)):
        with pytest.raises(ValueError, match=message):
            call()


def _takers_of(search: object) -> list:
    """Every public function that takes a search, called with ``search``."""
    return [
        lambda: metrics.poic(GOOD, search=search),
        lambda: metrics.bootstrap(GOOD, seed=0, resamples=2, bins=10, search=search),
        lambda: metrics.permutation_null(GOOD, seed=0, repeats=1, bins=10, search=search),
    ]


def test_search_must_be_a_poic_search():
    for call in _takers_of({"grid_points": 50}):
        with pytest.raises(TypeError, match="search must be a POICSearch, got \\{'grid_points': 50\\}"):
            call()


def test_optimal_return_must_be_finite():
    with pytest.raises(ValueError, match="optimal_return must be a finite real number, got nan"):
        metrics.poic(GOOD, optimal_return=np.nan)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"seed": -1}, "seed must be a non-negative integer, got -1"),
        ({"seed": 1.5}, "seed must be a non-negative integer, got 1.5"),
        ({"seed": 0, "resamples": 0}, "resamples must be an integer >= 1, got 0"),
        ({"seed": 0, "confidence": 1.0}, "confidence must be a number in the open interval \\(0, 1\\), got 1.0"),
    ],
)
def test_bootstrap_options_are_checked(options, message):
    with pytest.raises(ValueError, match=message):
        metrics.bootstrap(GOOD, **options)


def test_best_return_must_be_finite():
    with pytest.raises(ValueError, match="best_return must be a finite real number, got inf"):
        metrics.random_sampling_score(GOOD, best_return=np.inf)


def test_temperatures_of_the_curve_must_be_positive():
    with pytest.raises(ValueError, match="temperatures must be a non-empty 1-D array of positive finite numbers"):
        metrics.mutual_information_curve(GOOD, [1.0, 0.0])
