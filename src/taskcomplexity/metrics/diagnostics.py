"""Diagnostics of the PIC estimator (``docs/explanation/estimators.md`` § Estimator biases).

The histogram PIC with B = 10⁵ bins is dominated by estimation bias on continuous returns. These
functions make that visible for a task: a permutation null (true MI = 0), sweeps over the number of
bins and over policy and episode subsamples, a bias-corrected estimator (Miller–Madow) and one that
is not histogram-based (nearest-neighbour MI between a discrete and a continuous variable).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from taskcomplexity.metrics._validation import check_bins, check_int, check_seed, validate_returns
from taskcomplexity.metrics.histogram import bin_edges, histogram_terms, plugin_entropy
from taskcomplexity.metrics.knn import mutual_info_classif_1d
from taskcomplexity.metrics.pic import DEFAULT_BINS, PICResult, pic, pic_of_terms
from taskcomplexity.metrics.poic import PolicyLogMeans, poic
from taskcomplexity.metrics.shuffle import shuffled_ahead
from taskcomplexity.metrics.temperature import DEFAULT_SEARCH, POICSearch, check_search

DEFAULT_BINS_SWEEP = (10, 100, 1000, 10_000, 100_000)
"""Numbers of bins of :func:`pic_bins_sweep`."""


@dataclass(frozen=True)
class KNNMIResult:
    """Nearest-neighbour estimate of the mutual information between policy and return.

    Attributes
    ----------
    mi : float
        Estimated I(Θ; R) in nats (clipped at 0 by scikit-learn); at most ln(policies).
    policies : int
        Policies in the subsample the estimate used.
    episodes : int
        Episodes per policy in the subsample.
    n_neighbors : int
        Neighbours k of the estimator.
    """

    mi: float
    policies: int
    episodes: int
    n_neighbors: int


@dataclass(frozen=True)
class KNNOptions:
    """The options of :func:`pic_knn` an estimate was made with, so that its null uses the same ones.

    Attributes
    ----------
    seed : int
        Seed of the subsample and of scikit-learn's tie-breaking noise.
    n_neighbors, max_samples, episodes_per_policy : int
        As in :func:`pic_knn`.
    """

    seed: int
    n_neighbors: int = 3
    max_samples: int = 50_000
    episodes_per_policy: int = 50

    def estimate(self, returns: np.ndarray) -> KNNMIResult:
        """:func:`pic_knn` of ``returns`` (shape (N, M)) with these options (episodes per policy at most M)."""
        return pic_knn(returns, seed=self.seed, n_neighbors=self.n_neighbors, max_samples=self.max_samples,
                       episodes_per_policy=min(self.episodes_per_policy, returns.shape[1]))


def permutation_null(returns: object, *, seed: int, repeats: int = 10, bins: int = DEFAULT_BINS,
                     search: POICSearch = DEFAULT_SEARCH, optimal_return: float | None = None,
                     knn: KNNOptions | None = None) -> pd.DataFrame:
    """Every estimator of I(Θ; R) and POIC on the returns permuted across policies, where the true MI is 0.

    Each repeat shuffles all N·M returns uniformly and reshapes them to (N, M), which keeps the
    pooled returns (and so the bin edges and S*) and destroys any dependence on the policy. Each
    permutation is estimated by histogram PIC, Miller–Madow PIC (from the same histogram), POIC and,
    with ``knn``, the nearest-neighbour MI (with the same subsample positions and noise as the observed
    estimate), so that every estimator is compared with its own null on the same permutations.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    seed : int
        Seed of the :class:`numpy.random.Generator` drawing the permutations.
    repeats : int, default 10
        Number of permutations.
    bins : int, default 100_000
        Histogram bins of PIC.
    search, optimal_return
        The POIC temperature search and known optimal return (see :func:`~taskcomplexity.metrics.poic.poic`).
    knn : KNNOptions, optional
        The options of the observed nearest-neighbour estimate; None leaves the ``pic_knn`` column out.

    Returns
    -------
    pandas.DataFrame, one row per repeat
        ``repeat``, ``pic``, ``h_r``, ``h_r_given_theta``, ``poic``, ``temperature``,
        ``pic_miller_madow`` and (with ``knn``) ``pic_knn`` (nats; the temperature in return units).
        Summarise with :func:`summarise_null`.
    """
    returns = validate_returns(returns)
    repeats = check_int(repeats, "repeats", minimum=1)
    bins = check_bins(bins)
    check_search(search)
    rng = np.random.default_rng(check_seed(seed))
    key = _null_key(returns, seed, repeats, bins)
    rows = []
    # The next permutation and its sorted rows are made in the background while this one is estimated.
    for repeat, (shuffled, log_means) in enumerate(shuffled_ahead(rng, returns, repeats, PolicyLogMeans)):
        estimate, corrected = _plugin_and_miller_madow(shuffled, bins)
        found = poic(shuffled, search=search, optimal_return=optimal_return, log_means=log_means)
        row = {
            "repeat": repeat,
            "pic": estimate.pic,
            "h_r": estimate.h_r,
            "h_r_given_theta": estimate.h_r_given_theta,
            "poic": found.poic,
            "temperature": found.temperature,
            "pic_miller_madow": corrected.pic,
        }
        if knn is not None:
            row["pic_knn"] = knn.estimate(shuffled).mi
        rows.append(row)
    _remember_null_pic(key, np.array([row["pic"] for row in rows]))
    return pd.DataFrame(rows)


def null_pic(returns: object, *, seed: int, repeats: int = 10, bins: int = DEFAULT_BINS) -> np.ndarray:
    """The ``pic`` column of :func:`permutation_null` (same arguments, same permutations), shape (repeats,).

    The permutations dominate the cost, so the values :func:`permutation_null` found for the same
    returns (compared by content), seed, repeats and bins are reused when still remembered.
    """
    returns = validate_returns(returns)
    seed = check_seed(seed)
    repeats = check_int(repeats, "repeats", minimum=1)
    bins = check_bins(bins)
    key = _null_key(returns, seed, repeats, bins)
    if key in _NULL_PIC:
        return _NULL_PIC[key].copy()
    rng = np.random.default_rng(seed)
    draws = np.array([pic(shuffled, bins=bins).pic for shuffled, _ in shuffled_ahead(rng, returns, repeats)])
    _remember_null_pic(key, draws)
    return draws.copy()


_NULL_PIC: dict[tuple, np.ndarray] = {}
"""Recent null PIC draws by :func:`_null_key`: a few floats each, the last _NULL_PIC_KEPT kept."""
_NULL_PIC_KEPT = 16


def _null_key(returns: np.ndarray, seed: int, repeats: int, bins: int) -> tuple:
    digest = hashlib.blake2b(np.ascontiguousarray(returns), digest_size=32).hexdigest()
    return digest, returns.shape, int(seed), int(repeats), int(bins)


def _remember_null_pic(key: tuple, draws: np.ndarray) -> None:
    _NULL_PIC.pop(key, None)
    _NULL_PIC[key] = draws
    while len(_NULL_PIC) > _NULL_PIC_KEPT:
        del _NULL_PIC[next(iter(_NULL_PIC))]


def summarise_null(null: pd.DataFrame, observed: Mapping[str, float]) -> pd.DataFrame:
    """Compare observed estimates with their permutation null.

    Parameters
    ----------
    null : pandas.DataFrame
        Draws of :func:`permutation_null` (at least 2 repeats).
    observed : mapping of str to float
        Observed value of each metric to compare, e.g. ``{"pic": 4.6, "poic": 0.018}``.

    Returns
    -------
    pandas.DataFrame, one row per metric
        ``metric``, ``observed``, ``null_mean``, ``null_sd`` (ddof 1), ``excess`` (observed minus
        null mean), ``z`` (excess in null standard deviations; inf when the null sd is 0).
    """
    missing = [metric for metric in observed if metric not in null.columns]
    if missing:
        raise ValueError(f"observed must name columns of null ({', '.join(null.columns)}), got {missing}")
    if len(null) < 2:
        raise ValueError(f"null must hold at least 2 repeats, got {len(null)}")
    rows = []
    for metric, value in observed.items():
        draws = null[metric].to_numpy(dtype=np.float64)
        mean, sd = float(draws.mean()), float(draws.std(ddof=1))
        excess = float(value) - mean
        with np.errstate(divide="ignore", invalid="ignore"):
            z = float(np.divide(excess, sd))
        rows.append(
            {
                "metric": metric,
                "observed": float(value),
                "null_mean": mean,
                "null_sd": sd,
                "excess": excess,
                "z": z,
            }
        )
    return pd.DataFrame(rows)


def pic_bins_sweep(returns: object, *, bins: Sequence[int] = DEFAULT_BINS_SWEEP) -> pd.DataFrame:
    """Histogram PIC and its entropies for several numbers of bins.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    bins : sequence of int, default (10, 100, 1000, 10_000, 100_000)
        Numbers of bins, each >= 2.

    Returns
    -------
    pandas.DataFrame, one row per number of bins
        ``bins``, ``pic``, ``h_r``, ``h_r_given_theta``, ``pic_miller_madow`` (nats).
    """
    returns = validate_returns(returns)
    counts = [check_bins(b) for b in _non_empty(bins, "bins")]
    rows = []
    for b in counts:
        plugin, corrected = _plugin_and_miller_madow(returns, b)
        rows.append(
            {
                "bins": b,
                "pic": plugin.pic,
                "h_r": plugin.h_r,
                "h_r_given_theta": plugin.h_r_given_theta,
                "pic_miller_madow": corrected.pic,
            }
        )
    return pd.DataFrame(rows)


def pic_subsample_sweep(
    returns: object,
    *,
    seed: int,
    policies: Sequence[int] | None = None,
    episodes: Sequence[int] | None = None,
    bins: int = DEFAULT_BINS,
) -> pd.DataFrame:
    """Histogram PIC on nested random subsamples of policies and episodes.

    One random order of the policies and one of the episodes is drawn; the subsample (n, m) takes
    the first n policies and the first m episodes of those orders, so subsamples are nested.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    seed : int
        Seed of the :class:`numpy.random.Generator` drawing the two orders.
    policies : sequence of int, optional
        Subsample sizes n, each in ``2 … N``; default N/8, N/4, N/2 and N (those >= 2).
    episodes : sequence of int, optional
        Subsample sizes m, each in ``2 … M``; default M/8, M/4, M/2 and M (those >= 2).
    bins : int, default 100_000
        Histogram bins.

    Returns
    -------
    pandas.DataFrame, one row per (n, m)
        ``policies``, ``episodes``, ``pic``, ``h_r``, ``h_r_given_theta`` (nats).
    """
    returns = validate_returns(returns)
    bins = check_bins(bins)
    n_policies, n_episodes = returns.shape
    policies = _subsample_sizes(policies, n_policies, "policies")
    episodes = _subsample_sizes(episodes, n_episodes, "episodes")
    rng = np.random.default_rng(check_seed(seed))
    policy_order, episode_order = rng.permutation(n_policies), rng.permutation(n_episodes)
    rows = []
    for n in policies:
        for m in episodes:
            estimate = pic(returns[np.ix_(policy_order[:n], episode_order[:m])], bins=bins)
            rows.append(
                {
                    "policies": n,
                    "episodes": m,
                    "pic": estimate.pic,
                    "h_r": estimate.h_r,
                    "h_r_given_theta": estimate.h_r_given_theta,
                }
            )
    return pd.DataFrame(rows)


def pic_miller_madow(returns: object, *, bins: int = DEFAULT_BINS) -> PICResult:
    """Histogram PIC with the Miller–Madow bias correction of every entropy.

    Each plug-in entropy of n samples occupying K bins gains ``(K - 1) / (2 n)``: H(R) with the
    N·M pooled returns, and each Hₙ with policy n's M returns, on the same edges as :func:`pic`.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    bins : int, default 100_000
        Histogram bins.

    Returns
    -------
    PICResult
        Corrected PIC, H(R) and H(R|Θ) in nats; all 0 when every return is equal.
    """
    return _plugin_and_miller_madow(validate_returns(returns), check_bins(bins))[1]


def _plugin_and_miller_madow(returns: np.ndarray, bins: int) -> tuple[PICResult, PICResult]:
    """:func:`~taskcomplexity.metrics.pic.pic` and :func:`pic_miller_madow` of validated returns from one
    histogram (each equal to its function's result)."""
    low, high = float(returns.min()), float(returns.max())
    if low == high:
        zero = PICResult(pic=0.0, h_r=0.0, h_r_given_theta=0.0, bins=bins)
        return zero, zero
    n_policies, n_episodes = returns.shape
    terms = histogram_terms(returns, bin_edges(low, high, bins))
    plugin = pic_of_terms(terms, bins)
    h_r = plugin_entropy(terms.pooled) + float(np.count_nonzero(terms.pooled) - 1) / (2 * n_policies * n_episodes)
    h_n = terms.policy_entropies() + (terms.occupied - 1) / (2 * n_episodes)
    h_r_given_theta = float(h_n.mean())
    corrected = PICResult(pic=h_r - h_r_given_theta, h_r=h_r, h_r_given_theta=h_r_given_theta, bins=bins)
    return plugin, corrected


def pic_knn(
    returns: object,
    *,
    seed: int,
    n_neighbors: int = 3,
    max_samples: int = 50_000,
    episodes_per_policy: int = 50,
) -> KNNMIResult:
    """Nearest-neighbour estimate of I(Θ; R) between the policy label and the return.

    Uses the estimator for a discrete and a continuous variable of Ross (2014) as implemented by
    :func:`sklearn.feature_selection.mutual_info_classif` (``discrete_features=False``), computed
    by sorting (:func:`~taskcomplexity.metrics.knn.mutual_info_classif_1d`, the same estimate).

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    seed : int
        Seeds both the subsample and scikit-learn's ``random_state``; the result is deterministic.
    n_neighbors : int, default 3
        Neighbours k; every policy keeps at least k + 1 episodes.
    max_samples : int, default 50_000
        Largest number of (policy, episode) samples used; the estimator costs O(n log n).
    episodes_per_policy : int, default 50
        Episodes kept per policy before the policy count is reduced (at most M).

    Returns
    -------
    KNNMIResult
        The estimate and the subsample it used.

    Notes
    -----
    Subsample: m = min(M, episodes_per_policy) episodes per policy and
    n = min(N, max_samples // m) policies, both chosen uniformly without replacement. Fewer policies
    change the estimand (the MI over n policies is at most ln n), so compare tasks at equal n.

    Ties: scikit-learn scales the returns to unit variance and adds noise of relative size 1e-10
    before the neighbour search. For integer-valued (sparse) returns this orders tied values at
    random, label-independently, so the estimate targets I(Θ; R) of the discrete return; a fixed
    ``random_state`` makes the noise, and the result, reproducible.
    """
    returns = validate_returns(returns)
    rng = np.random.default_rng(check_seed(seed))
    n_neighbors = check_int(n_neighbors, "n_neighbors", minimum=1)
    n_policies, n_episodes = returns.shape
    episodes_per_policy = check_int(episodes_per_policy, "episodes_per_policy", minimum=n_neighbors + 1)
    m = min(n_episodes, episodes_per_policy)
    if m < n_neighbors + 1:
        raise ValueError(f"n_neighbors must be at most M - 1 = {n_episodes - 1}, got {n_neighbors}")
    max_samples = check_int(max_samples, "max_samples", minimum=2 * m)
    n = min(n_policies, max_samples // m)
    policies = np.sort(rng.choice(n_policies, size=n, replace=False))
    episodes = np.sort(rng.choice(n_episodes, size=m, replace=False))
    sample = returns[np.ix_(policies, episodes)]
    labels = np.repeat(np.arange(n), m)
    mi = mutual_info_classif_1d(sample.ravel(), labels, n_neighbors=n_neighbors,
                                random_state=int(rng.integers(2**31 - 1)))
    return KNNMIResult(mi=mi, policies=n, episodes=m, n_neighbors=n_neighbors)


def _non_empty(values: Sequence[int], name: str) -> list:
    values = list(np.atleast_1d(values).tolist()) if values is not None else []
    if not values:
        raise ValueError(f"{name} must be a non-empty sequence of integers, got {values!r}")
    return values


def _subsample_sizes(sizes: Sequence[int] | None, total: int, name: str) -> list[int]:
    if sizes is None:
        return sorted({size for size in (total // 8, total // 4, total // 2, total) if size >= 2})
    sizes = _non_empty(sizes, name)
    for size in sizes:
        if isinstance(size, bool) or not isinstance(size, int) or not 2 <= size <= total:
            raise ValueError(f"{name} must be integers between 2 and {total}, got {sizes!r}")
    return [int(size) for size in sizes]
