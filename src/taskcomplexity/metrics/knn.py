"""Nearest-neighbour mutual information between a label and one continuous variable, in one dimension.

:func:`mutual_info_classif_1d` computes what :func:`sklearn.feature_selection.mutual_info_classif`
computes for a single continuous feature (Ross 2014, as scikit-learn 1.x implements it): the same
scaling and the same seeded noise, then per sample i with label L

* ``rᵢ``: the distance to its k-th nearest neighbour among the other samples of L, k = min(k, |L| - 1);
* ``mᵢ``: the number of samples of any label at a distance ``<= nextafter(rᵢ, 0)`` (itself included);
* ``MI = ψ(n) + ⟨ψ(k)⟩ - ⟨ψ(|L|)⟩ - ⟨ψ(mᵢ)⟩``, clipped at 0.

scikit-learn finds neighbours with a KD-tree per label and a radius query per sample (about 3 s for
50 000 samples, most of it Python overhead per label). On a line both are searches in sorted
arrays: the k-th neighbour is the k-th step of a merge outwards from the sample's position among its
label's sorted values, and ``mᵢ`` is two binary searches in all sorted values. Distances are
``|fl(xᵢ - xⱼ)|``, as the tree's (``sqrt(fl(d²)) = |d|`` and squaring is monotone), so the counts are
identical and the estimate equals scikit-learn's to rounding of the final means.

scikit-learn switches to brute-force distances (``x² - 2xy + y²``, rounded differently) for a label
whose k is at least half its size; those inputs are passed to scikit-learn itself.
"""

from __future__ import annotations

import functools

import numba
import numpy as np
import scipy.special
import sklearn.feature_selection
import sklearn.preprocessing
import threadpoolctl


def mutual_info_classif_1d(values: np.ndarray, labels: np.ndarray, *, n_neighbors: int, random_state: int) -> float:
    """``mutual_info_classif(values.reshape(-1, 1), labels, discrete_features=False, ...)[0]``.

    Parameters
    ----------
    values : numpy.ndarray, shape (n,)
        The continuous variable.
    labels : numpy.ndarray, shape (n,), int
        The discrete variable.
    n_neighbors : int
        k, at least 1.
    random_state : int
        Seed of the noise scikit-learn adds (a :class:`numpy.random.RandomState` seed).

    Returns
    -------
    float
        The estimate in nats (>= 0).
    """
    labels = np.asarray(labels)
    _, inverse, counts = np.unique(labels, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    k_of_label = np.minimum(n_neighbors, counts - 1)
    paired = counts > 1
    if np.any(k_of_label[paired] >= counts[paired] // 2):
        with _openmp().limit(limits=1, user_api="openmp"):
            return float(sklearn.feature_selection.mutual_info_classif(
                values.reshape(-1, 1), labels, discrete_features=False, n_neighbors=n_neighbors,
                random_state=random_state)[0])

    # The preprocessing of sklearn.feature_selection._mutual_info._estimate_mi, step for step.
    rng = np.random.RandomState(random_state)
    column = np.asarray(values, dtype=np.float64).reshape(-1, 1).astype(np.float64, copy=True)
    column = sklearn.preprocessing.scale(column, with_mean=False, copy=False)
    means = np.maximum(1, np.mean(np.abs(column), axis=0))
    column += 1e-10 * means * rng.standard_normal(size=(column.shape[0], 1))
    x = column[:, 0]

    keep = paired[inverse]  # samples whose label occurs once are ignored
    x, inverse = x[keep], inverse[keep]
    order = np.argsort(inverse, kind="stable")
    starts = np.searchsorted(inverse[order], np.arange(counts.size + 1))
    kth = np.empty(x.size)
    _kth_distances(x, order, starts, k_of_label, kth)
    radius = np.nextafter(kth, 0)
    within = np.empty(x.size, dtype=np.int64)
    _count_within(np.sort(x), x, radius, within)

    label_counts = counts[inverse].astype(np.float64)
    k_all = k_of_label[inverse].astype(np.float64)
    mi = (scipy.special.digamma(x.size) + np.mean(scipy.special.digamma(k_all))
          - np.mean(scipy.special.digamma(label_counts)) - np.mean(scipy.special.digamma(within)))
    return float(max(0, mi))


@functools.cache
def _openmp():
    """The process's thread pools (:class:`threadpoolctl.ThreadpoolController`, found once): scikit-learn's
    neighbour searches run on OpenMP threads, whose start and wait cost 10-20 times the work on the few samples of
    a label that takes that path (k at least half of it), so it runs them on one thread (the same numbers: a label
    that small is one chunk of the search whatever the threads)."""
    return threadpoolctl.ThreadpoolController()


@numba.njit(cache=True, parallel=True)
def _kth_distances(x, order, starts, k_of_label, out):
    """Distance of every sample to its k-th nearest other sample of the same label."""
    for label in numba.prange(starts.size - 1):
        members = order[starts[label]:starts[label + 1]]
        if members.size < 2:
            continue
        sorted_values = np.sort(x[members])
        rank = np.argsort(x[members], kind="mergesort")
        k = k_of_label[label]
        for position in range(members.size):
            here = sorted_values[position]
            left, right = position - 1, position + 1
            distance = 0.0
            for _ in range(k):
                to_left = here - sorted_values[left] if left >= 0 else np.inf
                to_right = sorted_values[right] - here if right < members.size else np.inf
                if to_left <= to_right:
                    distance, left = to_left, left - 1
                else:
                    distance, right = to_right, right + 1
            out[members[rank[position]]] = distance


@numba.njit(cache=True, parallel=True)
def _count_within(sorted_all, x, radius, out):
    """Number of samples at a distance <= radius[i] from x[i] (x[i] itself included)."""
    n = sorted_all.size
    for i in numba.prange(x.size):
        centre, reach = x[i], radius[i]
        # First sorted index whose distance on the left is <= reach (distances fall towards centre).
        low, high = 0, n
        while low < high:
            middle = (low + high) // 2
            if sorted_all[middle] < centre and centre - sorted_all[middle] > reach:
                low = middle + 1
            else:
                high = middle
        first = low
        # First sorted index beyond the reach on the right.
        low, high = first, n
        while low < high:
            middle = (low + high) // 2
            if sorted_all[middle] <= centre or sorted_all[middle] - centre <= reach:
                low = middle + 1
            else:
                high = middle
        out[i] = low - first
