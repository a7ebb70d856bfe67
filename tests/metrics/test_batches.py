"""Batch estimates and Welch's t-tests between tasks."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from taskcomplexity.metrics import (
    DEFAULT_REGISTRY,
    Estimation,
    batch_estimates,
    format_welch_matrix,
    pic,
    poic,
    random_sampling_score,
    welch_matrix,
    welch_test,
)

RWG = DEFAULT_REGISTRY.of_stage("metrics")


def test_batches_are_consecutive_blocks_estimated_separately(continuous_returns):
    table = batch_estimates(continuous_returns, RWG, batches=3, estimation=Estimation(bins=40))
    assert table["batch"].tolist() == [0, 1, 2] and table["policies"].tolist() == [4, 4, 4]
    assert list(table.columns) == ["batch", "policies", *(m.name for m in RWG if m.batched)]
    for batch, rows in enumerate((slice(0, 4), slice(4, 8), slice(8, 12))):
        part = continuous_returns[rows]
        assert table["pic"][batch] == pic(part, bins=40).pic
        assert table["poic"][batch] == poic(part).poic
        assert table["score"][batch] == random_sampling_score(part).score
        assert table["variance"][batch] == random_sampling_score(part).variance


def test_uneven_batches_follow_array_split(integer_returns):
    table = batch_estimates(integer_returns, RWG, batches=4, estimation=Estimation(bins=20))  # N = 15
    assert table["policies"].tolist() == [4, 4, 4, 3]
    assert table["pic"][3] == pic(integer_returns[12:], bins=20).pic
    assert table["r_mean"][3] == integer_returns[12:].mean()


def test_only_batched_metrics_get_batch_estimates(continuous_returns):
    table = batch_estimates(continuous_returns, [m for m in RWG if m.name == "pic"] + [
        DEFAULT_REGISTRY["sac_final"]], batches=2, estimation=Estimation(bins=30))
    assert list(table.columns) == ["batch", "policies", "pic"]


def test_batch_estimates_are_deterministic(continuous_returns):
    pd.testing.assert_frame_equal(
        batch_estimates(continuous_returns, RWG, estimation=Estimation(bins=30)),
        batch_estimates(continuous_returns, RWG, estimation=Estimation(bins=30)),
    )


def test_every_batch_needs_two_policies(continuous_returns):
    with pytest.raises(ValueError, match="batches must be at most N/2 = 6 .* got 7"):
        batch_estimates(continuous_returns, RWG, batches=7)


samples = hnp.arrays(np.float64, st.integers(2, 20), elements=st.floats(-1e3, 1e3, allow_subnormal=False))


@settings(max_examples=200, deadline=None, derandomize=True)
@given(a=samples, b=samples)
def test_welch_test_equals_scipy(a, b):
    ours = welch_test(a, b)
    assume(np.ptp(a) > 0 or np.ptp(b) > 0)  # undefined otherwise; see test_welch_test_of_constant_samples
    # scipy squares var/n in the degrees of freedom, which underflows below ~1e-154; ours scales
    # the variances first. Compare where scipy's formula is representable.
    assume(all(v == 0 or v > 1e-150 for v in (a.var(ddof=1) / a.size, b.var(ddof=1) / b.size)))
    with warnings.catch_warnings():
        # scipy flags nearly constant samples ("Precision loss occurred in moment calculation");
        # the comparison is still meaningful, both sides use the same moments.
        warnings.filterwarnings("ignore", message="Precision loss occurred", category=RuntimeWarning)
        theirs = scipy.stats.ttest_ind(a, b, equal_var=False)
    # Same formulas, possibly different summation: agreement to 1e-9 relative. Variances that
    # underflow to 0 with equal means give NaN on both sides.
    assert ours.statistic == pytest.approx(theirs.statistic, rel=1e-9, abs=1e-12, nan_ok=True)
    assert ours.pvalue == pytest.approx(theirs.pvalue, rel=1e-9, abs=1e-12, nan_ok=True)


def test_welch_test_of_a_textbook_example():
    a, b = np.array([19.1, 20.4, 21.2, 18.9, 20.0]), np.array([22.3, 21.8, 23.9, 22.7])
    statistic, pvalue = welch_test(a, b)
    reference = scipy.stats.ttest_ind(a, b, equal_var=False)
    assert (statistic, pvalue) == pytest.approx((reference.statistic, reference.pvalue), rel=1e-12)
    assert statistic < 0 and pvalue < 0.005


def test_welch_test_of_constant_samples():
    assert welch_test([1.0, 1.0], [2.0, 2.0, 2.0]) == (-np.inf, 0.0)
    statistic, pvalue = welch_test([1.0, 1.0], [1.0, 1.0])
    assert np.isnan(statistic) and np.isnan(pvalue)


def test_welch_test_needs_two_finite_values_per_sample():
    with pytest.raises(ValueError, match="b must be a 1-D array of at least 2 finite values"):
        welch_test([1.0, 2.0], [3.0])


def test_welch_matrix_covers_every_ordered_pair():
    rng = np.random.default_rng(4)
    draws = {"easy": rng.normal(5, 0.1, 5), "hard": rng.normal(1, 0.1, 5), "twin": rng.normal(1, 0.1, 5)}
    table = welch_matrix(draws)
    assert len(table) == 6
    assert set(zip(table["task_a"], table["task_b"], strict=True)) == {(a, b) for a in draws for b in draws if a != b}
    by_pair = table.set_index(["task_a", "task_b"])
    assert by_pair.loc[("easy", "hard"), "statistic"] == -by_pair.loc[("hard", "easy"), "statistic"]
    assert by_pair.loc[("easy", "hard"), "significant"]
    assert not by_pair.loc[("hard", "twin"), "significant"]
    assert by_pair.loc[("hard", "twin"), "pvalue"] == welch_test(draws["hard"], draws["twin"]).pvalue


def test_formatted_matrix_is_square_with_an_empty_diagonal():
    table = welch_matrix({"a": [1.0, 2.0, 3.0], "b": [4.0, 5.0, 7.0]})
    square = format_welch_matrix(table, digits=2)
    assert list(square.index) == list(square.columns) == ["a", "b"]
    assert square.loc["a", "a"] == ""
    statistic, pvalue = welch_test([1.0, 2.0, 3.0], [4.0, 5.0, 7.0])
    assert square.loc["a", "b"] == f"{statistic:.2g} ({pvalue:.2g})"
