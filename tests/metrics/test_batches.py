"""Batch estimates and Welch's t-tests between tasks."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
import scipy.stats

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


def welch_by_hand(a, b):
    """Welch's t and two-sided p from the textbook formulas (variances with ddof 1)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    var_a, var_b = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    statistic = (a.mean() - b.mean()) / np.sqrt(var_a + var_b)
    dof = (var_a + var_b) ** 2 / (var_a**2 / (a.size - 1) + var_b**2 / (b.size - 1))
    return statistic, 2 * scipy.stats.t.sf(abs(statistic), dof)


def test_welch_test_of_a_textbook_example():
    a, b = np.array([19.1, 20.4, 21.2, 18.9, 20.0]), np.array([22.3, 21.8, 23.9, 22.7])
    statistic, pvalue = welch_test(a, b)
    # the same formulas summed in another order: agreement to 1e-12 relative
    assert (statistic, pvalue) == pytest.approx(welch_by_hand(a, b), rel=1e-12)
    assert statistic < 0 and pvalue < 0.005


def test_a_constant_sample_beside_a_varying_one_is_tested_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        statistic, pvalue = welch_test([5.0, 5.0], [1.0, 2.0, 3.0])
    # t = (5 − 2) / sqrt(0 + 1/3) = 3·√3 on the varying side's 2 degrees of freedom; rounding only: 1e-12 relative
    assert statistic == pytest.approx(3 * np.sqrt(3), rel=1e-12)
    assert pvalue == pytest.approx(2 * scipy.stats.t.sf(3 * np.sqrt(3), 2), rel=1e-12)


def test_welch_test_of_constant_samples():
    assert welch_test([1.0, 1.0], [2.0, 2.0, 2.0]) == (-np.inf, 0.0)
    statistic, pvalue = welch_test([1.0, 1.0], [1.0, 1.0])
    assert np.isnan(statistic) and np.isnan(pvalue)


def test_values_equal_up_to_rounding_are_a_constant_sample():
    ceiling = [np.log(2), np.nextafter(np.log(2), 1), np.log(2)]  # a metric at ln 2 on every batch, one ulp apart
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        statistic, pvalue = welch_test(ceiling, ceiling[::-1])
        assert np.isnan(statistic) and np.isnan(pvalue)  # not a t drawn from rounding
        assert welch_test(ceiling, [0.5, 0.5]) == (np.inf, 0.0)
        assert welch_test(ceiling, [0.1, 0.2, 0.3]).statistic > 0  # beside a varying sample: scipy's test, quietly


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
