"""The sorted nearest-neighbour MI equals scikit-learn's mutual_info_classif on one continuous feature."""

from __future__ import annotations

import numpy as np
import pytest
import sklearn.feature_selection

from taskcomplexity.metrics.knn import mutual_info_classif_1d


def sklearn_mi(values: np.ndarray, labels: np.ndarray, k: int, seed: int) -> float:
    return float(sklearn.feature_selection.mutual_info_classif(
        values.reshape(-1, 1), labels, discrete_features=False, n_neighbors=k, random_state=seed)[0])


def dataset(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    labels = np.repeat(np.arange(150), 20)
    if kind == "policies":  # per-label means and scales, as random policies give
        values = rng.normal(-100, 30, size=150)[labels] + rng.lognormal(1, 0.5, size=150)[labels] * rng.normal(size=labels.size)
    elif kind == "integer":  # sparse rewards: many exact ties, resolved by the seeded noise
        values = -rng.binomial(50, rng.uniform(0, 1, size=150)[labels]).astype(np.float64)
    elif kind == "heavy_tailed":
        values = rng.standard_cauchy(labels.size) * 1e3
    elif kind == "uneven_labels":  # sizes 14 … 40: the sorted path with labels of different sizes
        labels = np.repeat(np.arange(60), rng.integers(14, 41, size=60))
        values = rng.normal(size=labels.size) + (labels % 7)
    elif kind == "small_labels":  # sizes from 1 upward: k >= size/2 somewhere, so scikit-learn computes
        labels = rng.integers(0, 80, size=500)
        values = rng.normal(size=labels.size) + (labels % 7)
    else:
        raise ValueError(kind)
    return values, labels


@pytest.mark.parametrize("k", [1, 3, 6])
@pytest.mark.parametrize("kind", ["policies", "integer", "heavy_tailed", "uneven_labels", "small_labels"])
def test_equals_scikit_learn(kind, k):
    values, labels = dataset(kind, np.random.default_rng(len(kind) + k))
    # Same neighbours, same counts, same means in the same order: identical, not merely close.
    assert mutual_info_classif_1d(values, labels, n_neighbors=k, random_state=7) == sklearn_mi(values, labels, k, 7)


def test_labels_that_occur_once_are_ignored():
    rng = np.random.default_rng(1)
    labels = np.r_[np.repeat(np.arange(40), 12), [100, 101, 102]]
    values = rng.normal(size=labels.size) + labels % 3
    assert mutual_info_classif_1d(values, labels, n_neighbors=3, random_state=0) == sklearn_mi(values, labels, 3, 0)
