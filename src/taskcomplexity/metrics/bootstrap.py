"""Bootstrap of PIC and POIC over policies (``docs/explanation/estimators.md`` § Uncertainty).

A resample draws N policies with replacement, each keeping all M episodes, and re-estimates PIC and
POIC exactly as on the original sample: bin edges and S* come from the resample itself. The
estimates equal running :func:`~taskcomplexity.metrics.pic.pic` and
:func:`~taskcomplexity.metrics.poic.poic` on ``returns[indices]`` for the indices of
:func:`bootstrap_indices` (up to floating-point summation order), but are computed without
rebuilding anything per resample:

* A resample is a vector of policy multiplicities w (N,). Its H(R|Θ) is ``w · Hₙ / N``.
* Its bin edges depend only on the smallest and largest return of the policies it contains, so
  resamples are grouped by their (min, max) pair — a handful of distinct pairs over 1000 resamples,
  because the extremes of the whole sample are in 63 % of resamples — and the sparse per-policy
  histograms are built once per group, stored bin by bin. The pooled histograms of the group's
  resamples are formed bin by bin, 16 resamples per pass, by a numba kernel
  (:mod:`~taskcomplexity.metrics.resampled_histograms`); counts are integers, so they are exact.
* For POIC the expensive per-policy log-mean-exp ℓₙ(λ) does not depend on S*; a resample with
  reference S*_b only shifts ``ln pₙ`` by ``(mₙ - S*_b)/λ``. The mutual-information curves of all
  resamples are then matrix products of the multiplicities with per-policy N × (temperatures)
  arrays, one set per distinct S*_b (see :func:`~taskcomplexity.metrics.poic.search_poic`). On the
  refinement, each such group is computed only at the union of its resamples' own brackets: at
  N = 10⁴, 1000 resamples' brackets cover about 870 fine temperatures, one resample's about 160 and
  one group's 190–500 (two_link-dense), which takes the fine curves from about 3.3 to 2.3 CPU-s. The
  products' shapes change with the brackets, so the BLAS may round a sum differently in its last
  bits (there: 0.9 % of the curve values visited, by at most 5.4e-15 nats; every draw unchanged).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

import numpy as np
import pandas as pd

from taskcomplexity.metrics._validation import (
    check_bins,
    check_fraction,
    check_int,
    check_real,
    check_seed,
    validate_returns,
)
from taskcomplexity.metrics.histogram import bin_edges, bin_scale, histogram_rows, sum_xlogx
from taskcomplexity.metrics.pic import DEFAULT_BINS
from taskcomplexity.metrics.poic import PolicyLogMeans, SearchResult, search_poic, shared_log_means
from taskcomplexity.metrics.resampled_histograms import SortedReturns, pooled_xlogx, sorted_row_xlogx
from taskcomplexity.metrics.temperature import DEFAULT_SEARCH, POICSearch, TemperatureLattice, check_search
from taskcomplexity.progress import Progress, progress_bar

BOOTSTRAP_COLUMNS = (
    "resample",
    "pic",
    "h_r",
    "h_r_given_theta",
    "poic",
    "temperature",
    "at_boundary",
    "h_o",
    "h_o_given_theta",
)
"""Columns of the table :func:`bootstrap` returns."""


def bootstrap_indices(n_policies: int, *, resamples: int, seed: int) -> Iterator[np.ndarray]:
    """Policy indices of each bootstrap resample, in order.

    Parameters
    ----------
    n_policies : int
        Number of policies N in the sample.
    resamples : int
        Number of resamples.
    seed : int
        Seed of the :class:`numpy.random.Generator`; resample b is its b-th draw of N integers.

    Yields
    ------
    numpy.ndarray, shape (N,), int64
        Indices drawn uniformly with replacement from ``0 … N - 1``.
    """
    n_policies = check_int(n_policies, "n_policies", minimum=1)
    resamples = check_int(resamples, "resamples", minimum=1)
    rng = np.random.default_rng(check_seed(seed))
    for _ in range(resamples):
        yield rng.integers(0, n_policies, size=n_policies)


def bootstrap_multiplicities(n_policies: int, *, resamples: int, seed: int) -> np.ndarray:
    """How many times each policy appears in each resample of :func:`bootstrap_indices`.

    Returns
    -------
    numpy.ndarray, shape (resamples, N), int32
        Row b counts the policies of resample b; every row sums to N.
    """
    weights = np.empty((resamples, n_policies), dtype=np.int32)
    for row, indices in enumerate(bootstrap_indices(n_policies, resamples=resamples, seed=seed)):
        weights[row] = np.bincount(indices, minlength=n_policies)
    return weights


def bootstrap(
    returns: object,
    *,
    seed: int,
    resamples: int = 1000,
    bins: int = DEFAULT_BINS,
    search: POICSearch = DEFAULT_SEARCH,
    optimal_return: float | None = None,
    confidence: float = 0.95,
    progress: Progress = False,
    log_means: PolicyLogMeans | None = None,
) -> pd.DataFrame:
    """Bootstrap distribution of PIC and POIC over resampled policies.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n, column e is episode e.
    seed : int
        Seed of the resampling (see :func:`bootstrap_indices`); the result is a pure function of
        the arguments.
    resamples : int, default 1000
        Number of resamples.
    bins : int, default 100_000
        Histogram bins of PIC (see :func:`~taskcomplexity.metrics.pic.pic`).
    search, optimal_return
        The POIC temperature search and known optimal return (see :func:`~taskcomplexity.metrics.poic.poic`).
    confidence : float, default 0.95
        Level of the percentile interval; stored in ``attrs`` for :func:`summarise_bootstrap`.
    progress : bool or tqdm, default False
        No bar, a bar of its own, or a stage's bar that the resamples advance (:mod:`taskcomplexity.progress`).
    log_means : PolicyLogMeans, optional
        ``PolicyLogMeans(returns)`` shared with the point estimate
        (:func:`~taskcomplexity.metrics.poic.poic`), so that the temperatures it evaluated are not
        evaluated again.

    Returns
    -------
    pandas.DataFrame, one row per resample
        ``resample`` (0-based), ``pic``, ``h_r``, ``h_r_given_theta``, ``poic``, ``temperature``,
        ``at_boundary``, ``h_o``, ``h_o_given_theta`` (entropies in nats). ``attrs`` records the
        seed, the number of resamples, the bins, the temperature search and the confidence.
    """
    returns = validate_returns(returns)
    bins = check_bins(bins)
    resamples = check_int(resamples, "resamples", minimum=1)
    seed = check_seed(seed)
    lattice = check_search(search)
    if optimal_return is not None:
        optimal_return = check_real(optimal_return, "optimal_return")
    confidence = check_fraction(confidence, "confidence")

    weights = bootstrap_multiplicities(returns.shape[0], resamples=resamples, seed=seed)
    bar = progress_bar(progress, total=2 * resamples, desc="bootstrap", unit="estimate")
    try:
        h_r, h_r_given_theta = _bootstrap_pic(returns, weights, bins, bar.update)
        found = _bootstrap_poic(shared_log_means(returns, log_means), weights, lattice, optimal_return)
        bar.update(resamples)
    finally:
        bar.close()

    draws = pd.DataFrame(
        {
            "resample": np.arange(resamples),
            "pic": h_r - h_r_given_theta,
            "h_r": h_r,
            "h_r_given_theta": h_r_given_theta,
            "poic": found.poic,
            "temperature": found.temperature,
            "at_boundary": found.at_boundary,
            "h_o": found.h_o,
            "h_o_given_theta": found.h_o_given_theta,
        }
    )
    draws.attrs.update(
        seed=seed,
        resamples=resamples,
        bins=bins,
        temperature_range=(lattice.low, lattice.high),
        grid_points=lattice.grid_points,
        refine_points=lattice.refine_points,
        refine_peaks=lattice.refine_peaks,
        confidence=confidence,
    )
    return draws


def summarise_bootstrap(
    draws: pd.DataFrame, point: Mapping[str, float], *, confidence: float | None = None
) -> pd.DataFrame:
    """Point estimate, bootstrap mean, standard deviation and percentile interval per metric.

    Parameters
    ----------
    draws : pandas.DataFrame
        Bootstrap draws, one column per metric (for example from :func:`bootstrap`).
    point : mapping of str to float
        Point estimate of each metric to summarise, e.g. ``{"pic": 4.1, "poic": 0.02}``; every key
        must be a column of ``draws``.
    confidence : float, optional
        Level of the percentile interval; defaults to ``draws.attrs["confidence"]`` or 0.95.

    Returns
    -------
    pandas.DataFrame, one row per metric in the order of ``point``
        ``metric``, ``point``, ``mean``, ``sd`` (ddof 1), ``ci_low``, ``ci_high`` (the
        ``(1 - confidence)/2`` and ``(1 + confidence)/2`` quantiles of the draws).
    """
    if confidence is None:
        confidence = draws.attrs.get("confidence", 0.95)
    confidence = check_fraction(confidence, "confidence")
    missing = [metric for metric in point if metric not in draws.columns]
    if missing:
        raise ValueError(f"point must name columns of draws ({', '.join(map(str, draws.columns))}), got {missing}")
    if len(draws) < 2:
        raise ValueError(f"draws must hold at least 2 resamples, got {len(draws)}")
    tails = [(1 - confidence) / 2, (1 + confidence) / 2]
    rows = []
    for metric, value in point.items():
        values = draws[metric].to_numpy(dtype=np.float64)
        low, high = np.quantile(values, tails)
        rows.append(
            {
                "metric": metric,
                "point": float(value),
                "mean": float(values.mean()),
                "sd": float(values.std(ddof=1)),
                "ci_low": float(low),
                "ci_high": float(high),
            }
        )
    return pd.DataFrame(rows, columns=["metric", "point", "mean", "sd", "ci_low", "ci_high"])


def _bootstrap_pic(
    returns: np.ndarray, weights: np.ndarray, bins: int, advance: Callable[[int], object]
) -> tuple[np.ndarray, np.ndarray]:
    """H(R) and H(R|Θ) of every resample, each of shape (R,)."""
    n_policies, n_episodes = returns.shape
    total = n_policies * n_episodes
    ordered = np.sort(returns, axis=1)
    present = weights > 0
    low = np.where(present, ordered[:, :1].T, np.inf).min(axis=1)
    high = np.where(present, ordered[:, -1:].T, -np.inf).max(axis=1)
    extremes, group = np.unique(np.column_stack((low, high)), axis=0, return_inverse=True)
    group = group.ravel()

    h_r = np.zeros(weights.shape[0])
    h_r_given_theta = np.zeros(weights.shape[0])
    everything = None  # all returns sorted, once, when a group needs them
    for label, (group_low, group_high) in enumerate(extremes):
        rows = np.flatnonzero(group == label)
        if group_low < group_high:
            # Only policies drawn by some resample of the group lie inside its edges.
            used = np.flatnonzero(present[rows].any(axis=0))
            group_weights = weights[np.ix_(rows, used)]
            edges = bin_edges(group_low, group_high, bins)
            if np.isfinite(bin_scale(edges)):
                if everything is None:
                    everything = SortedReturns.of(returns)
                xlogx = pooled_xlogx(everything, edges, weights[rows])
                entropies = np.maximum(np.log(n_episodes) - sorted_row_xlogx(ordered, used, edges) / n_episodes, 0.0)
            else:  # a span too narrow for B bins: the sparse-matrix path, which bins by searchsorted
                counts = histogram_rows(ordered[used], edges, rows_sorted=True)
                entropies = counts.policy_entropies()
                xlogx = sum_xlogx(counts.bin_major() @ group_weights.T.astype(np.int64), axis=0)
            h_r_given_theta[rows] = group_weights @ entropies / n_policies
            h_r[rows] = np.maximum(np.log(total) - xlogx / total, 0.0)
        advance(rows.size)
    return h_r, h_r_given_theta


def _bootstrap_poic(
    source: PolicyLogMeans, weights: np.ndarray, lattice: TemperatureLattice, optimal_return: float | None
) -> SearchResult:
    """POIC search of every resample."""
    s_star = np.where(weights > 0, source.row_max, -np.inf).max(axis=1)
    if optimal_return is not None:
        s_star = np.maximum(s_star, optimal_return)
    return search_poic(source, lattice, weights, s_star)
