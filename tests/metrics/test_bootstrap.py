"""The fast bootstrap equals resampling policies and re-running the estimators, and is seeded."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.metrics import (
    POICSearch,
    bootstrap,
    bootstrap_indices,
    bootstrap_multiplicities,
    pic,
    poic,
    summarise_bootstrap,
)
from taskcomplexity.metrics.bootstrap import BOOTSTRAP_COLUMNS
from taskcomplexity.metrics.poic import PolicyLogMeans

# The fast path sums policies weighted by their multiplicity instead of over repeated rows,
# which changes only the summation order: estimates agree to ~1e-15, 1e-9 leaves ample room.
SAME_ESTIMATE = 1e-9


def naive_bootstrap(returns: np.ndarray, *, seed: int, resamples: int, bins: int, **options) -> pd.DataFrame:
    """The definition: resample policies, then call pic and poic on the resampled matrix."""
    rows = []
    for indices in bootstrap_indices(returns.shape[0], resamples=resamples, seed=seed):
        resampled = returns[indices]
        found = poic(resampled, **options)
        rows.append({"pic": pic(resampled, bins=bins).pic, "poic": found.poic, "temperature": found.temperature})
    return pd.DataFrame(rows)


@pytest.mark.parametrize("returns_fixture", ["continuous_returns", "integer_returns"])
def test_bootstrap_equals_the_naive_loop(returns_fixture, request):
    returns = request.getfixturevalue(returns_fixture)
    fast = bootstrap(returns, seed=11, resamples=40, bins=64)
    naive = naive_bootstrap(returns, seed=11, resamples=40, bins=64)
    np.testing.assert_allclose(fast["pic"], naive["pic"], rtol=0, atol=SAME_ESTIMATE)
    np.testing.assert_allclose(fast["poic"], naive["poic"], rtol=0, atol=SAME_ESTIMATE)
    # λ* is a lattice point chosen with a tie tolerance, so it is identical, not merely close.
    np.testing.assert_array_equal(fast["temperature"], naive["temperature"])


def test_bootstrap_equals_the_naive_loop_with_an_outlier_and_a_known_optimum(continuous_returns):
    # An outlier policy changes the bin edges of the resamples that contain it; a known optimal
    # return fixes S* for every resample.
    returns = continuous_returns.copy()
    returns[3, 5] = 400.0
    options = {"search": POICSearch(temperature_range=(1e-2, 1e3), grid_points=50, refine_points=8),
               "optimal_return": 500.0}
    fast = bootstrap(returns, seed=2, resamples=30, bins=1000, **options)
    naive = naive_bootstrap(returns, seed=2, resamples=30, bins=1000, **options)
    np.testing.assert_allclose(fast[["pic", "poic"]], naive[["pic", "poic"]], rtol=0, atol=SAME_ESTIMATE)
    np.testing.assert_array_equal(fast["temperature"], naive["temperature"])


def test_bootstrap_is_deterministic_for_a_seed(continuous_returns):
    first = bootstrap(continuous_returns, seed=5, resamples=20, bins=50)
    pd.testing.assert_frame_equal(first, bootstrap(continuous_returns, seed=5, resamples=20, bins=50))
    assert not first["pic"].equals(bootstrap(continuous_returns, seed=6, resamples=20, bins=50)["pic"])


def test_bootstrap_table_columns_and_provenance(continuous_returns):
    draws = bootstrap(continuous_returns, seed=1, resamples=7, bins=50, confidence=0.9, progress=True)
    assert tuple(draws.columns) == BOOTSTRAP_COLUMNS
    np.testing.assert_array_equal(draws["resample"], np.arange(7))
    np.testing.assert_allclose(draws["pic"], draws["h_r"] - draws["h_r_given_theta"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(draws["poic"], draws["h_o"] - draws["h_o_given_theta"], rtol=0, atol=1e-15)
    assert draws.attrs["seed"] == 1 and draws.attrs["confidence"] == 0.9 and draws.attrs["bins"] == 50


def test_bootstrap_advances_a_stages_bar_and_leaves_it_open(continuous_returns):
    import io

    from tqdm.auto import tqdm

    with tqdm(total=100, file=io.StringIO()) as bar:
        bootstrap(continuous_returns, seed=1, resamples=7, bins=50, progress=bar)
        # PIC and POIC per resample; tqdm disables a bar it closes, so an enabled one is still open
        assert bar.n == 2 * 7 and not bar.disable


def test_resample_indices_are_seeded_draws_with_replacement():
    first = list(bootstrap_indices(6, resamples=4, seed=3))
    assert [i.tolist() for i in first] == [i.tolist() for i in bootstrap_indices(6, resamples=4, seed=3)]
    assert all(i.shape == (6,) and i.min() >= 0 and i.max() < 6 for i in first)
    weights = bootstrap_multiplicities(6, resamples=4, seed=3)
    np.testing.assert_array_equal(weights, [np.bincount(i, minlength=6) for i in first])
    np.testing.assert_array_equal(weights.sum(axis=1), 6)


def test_summary_of_known_draws():
    draws = pd.DataFrame({"pic": np.arange(101.0), "poic": np.full(101, 0.5)})
    summary = summarise_bootstrap(draws, {"pic": 49.0, "poic": 0.4}, confidence=0.9)
    expected = pd.DataFrame(
        {
            "metric": ["pic", "poic"],
            "point": [49.0, 0.4],
            "mean": [50.0, 0.5],
            "sd": [np.arange(101.0).std(ddof=1), 0.0],
            # Linear-interpolation quantiles of 0 … 100 at 5 % and 95 % are 5 and 95.
            "ci_low": [5.0, 0.5],
            "ci_high": [95.0, 0.5],
        }
    )
    pd.testing.assert_frame_equal(summary, expected, rtol=1e-12)


def test_summary_takes_the_confidence_recorded_by_the_bootstrap():
    draws = pd.DataFrame({"pic": np.arange(101.0)})
    draws.attrs["confidence"] = 0.5
    summary = summarise_bootstrap(draws, {"pic": 0.0})
    assert (summary["ci_low"][0], summary["ci_high"][0]) == (25.0, 75.0)


def test_summary_refuses_unknown_metrics():
    with pytest.raises(ValueError, match="point must name columns of draws \\(pic\\), got \\['poic'\\]"):
        summarise_bootstrap(pd.DataFrame({"pic": [1.0, 2.0]}), {"poic": 1.0})


def test_bootstrap_equals_the_naive_loop_when_the_span_is_too_narrow_for_linear_binning():
    # B / (max - min) overflows: every path bins by searchsorted instead.
    low = 1e-300
    returns = np.array([[low, low, np.nextafter(low, 1.0)], [np.nextafter(low, 1.0), low, low], [low, low, low]])
    fast = bootstrap(returns, seed=3, resamples=12, bins=10**5)
    naive = naive_bootstrap(returns, seed=3, resamples=12, bins=10**5)
    np.testing.assert_allclose(fast["pic"], naive["pic"], rtol=0, atol=SAME_ESTIMATE)


def test_a_log_means_shared_with_the_point_estimate_changes_nothing(continuous_returns):
    source = PolicyLogMeans(continuous_returns)
    poic(continuous_returns, log_means=source)  # fills the cache with the point estimate's lattice
    shared = bootstrap(continuous_returns, seed=4, resamples=15, bins=40, log_means=source)
    pd.testing.assert_frame_equal(shared, bootstrap(continuous_returns, seed=4, resamples=15, bins=40))
