"""Equal-width binning of returns and sparse per-policy histograms.

This is the one place that decides which bin a return falls in, so that the point estimate of PIC,
its bootstrap, the Miller–Madow correction and the reference implementation agree bin for bin.
The bins follow :func:`numpy.histogram` with explicit edges: bin ``b`` is the half-open interval
``[edges[b], edges[b + 1])`` except the last one, which is closed. Every path bins a value with
:func:`bin_of` (numba), and the per-policy entropy terms of PIC come from one parallel pass over the
return matrix (:func:`histogram_terms`), without sorting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import scipy.sparse

from taskcomplexity.metrics._validation import check_bins, validate_returns


def bin_edges(low: float, high: float, bins: int) -> np.ndarray:
    """Edges of ``bins`` equal-width bins spanning ``[low, high]``.

    Parameters
    ----------
    low, high : float
        Smallest and largest return, ``low < high``.
    bins : int
        Number of bins, >= 2.

    Returns
    -------
    numpy.ndarray, shape (bins + 1,)
        ``numpy.linspace(low, high, bins + 1)``; the first and last edges are exactly ``low`` and
        ``high``.
    """
    bins = check_bins(bins)
    if not low < high:
        raise ValueError(f"low must be smaller than high, got low={low!r}, high={high!r}")
    if not np.isfinite(high - low):
        raise ValueError(f"the returns span [{low}, {high}] is too wide to bin in float64")
    return np.linspace(low, high, bins + 1)


def bin_indices(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin index of every value, for values inside ``[edges[0], edges[-1]]``.

    Equivalent to ``numpy.searchsorted(edges, values, side="right") - 1`` with the last bin closed,
    but computed in linear time from the bin width; the few values that floating-point rounding
    puts in a neighbouring bin are detected against ``edges`` and corrected (:func:`bin_of`).

    Parameters
    ----------
    values : numpy.ndarray, any shape, float64
        Values to bin; all must lie in ``[edges[0], edges[-1]]``.
    edges : numpy.ndarray, shape (B + 1,)
        Non-decreasing edges from :func:`bin_edges`.

    Returns
    -------
    numpy.ndarray, same shape as ``values``, intp
        Bin indices in ``0 … B - 1``.
    """
    values = np.asarray(values, dtype=np.float64)
    edges = np.ascontiguousarray(edges, dtype=np.float64)
    n_bins = edges.size - 1
    scale = bin_scale(edges)
    if not np.isfinite(scale):
        return np.minimum(np.searchsorted(edges, values, side="right") - 1, n_bins - 1)
    index = np.empty(values.size, dtype=np.intp)
    _bin_values(np.ascontiguousarray(values).ravel(), scale, bin_slack(edges), edges, index)
    return index.reshape(values.shape)


def bin_scale(edges: np.ndarray) -> float:
    """Bins per unit of return, ``B / (high - low)``; inf when the span is too narrow for it."""
    with np.errstate(over="ignore", divide="ignore"):  # handled by the callers' searchsorted path
        return float(np.float64(edges.size - 1) / (edges[-1] - edges[0]))


def bin_slack(edges: np.ndarray) -> float:
    """Distance in bins from an edge beyond which :func:`bin_of` needs no look at the edges.

    ``t = (value - low)·scale`` is within 4 ε·B bins of the exact position, and each of
    numpy.linspace's edges within about 3 ε·(B + |low|·scale) bins of its exact place. A value
    whose t lies farther than 16 ε·(B + (|low| + |high|)·scale) from every integer is therefore
    inside bin ⌊t⌋ of the given edges. (Values that close to an edge are rare: they take the
    careful path.)
    """
    scale = bin_scale(edges)
    return float(16 * np.finfo(np.float64).eps * (edges.size - 1 + (abs(edges[0]) + abs(edges[-1])) * scale))


@numba.njit(cache=True, inline="always")
def bin_of(value, scale, slack, edges):
    """Bin of one value: ``⌊(value - low)·scale⌋`` when that is more than ``slack`` (:func:`bin_slack`)
    inside a bin; otherwise that guess moved to the largest ``b <= B - 1`` with ``edges[b] <= value``
    (a step or two at most, where rounding misplaced it)."""
    last = edges.size - 2
    position = (value - edges[0]) * scale
    index = int(position)
    if 0 <= index <= last and slack < position - index < 1.0 - slack:
        return index
    index = min(max(index, 0), last)
    while index > 0 and value < edges[index]:
        index -= 1
    while index < last and value >= edges[index + 1]:
        index += 1
    return index


@numba.njit(cache=True, parallel=True, nogil=True)
def _bin_values(values, scale, slack, edges, out):
    for i in numba.prange(values.size):
        out[i] = bin_of(values[i], scale, slack, edges)


@dataclass(frozen=True, eq=False)
class HistogramTerms:
    """What the plug-in entropies of PIC need from the per-policy histograms on shared edges.

    Attributes
    ----------
    pooled : numpy.ndarray, shape (B,), int64
        Counts of all N·M returns in each bin.
    xlogx : numpy.ndarray, shape (N,)
        ``Σ_b c ln c`` over the bins of each policy's histogram (counts c).
    occupied : numpy.ndarray, shape (N,), int64
        Non-empty bins of each policy.
    n_episodes : int
        Episodes per policy M.
    """

    pooled: np.ndarray
    xlogx: np.ndarray
    occupied: np.ndarray
    n_episodes: int

    def policy_entropies(self) -> np.ndarray:
        """Plug-in entropy Hₙ in nats of each policy's histogram, shape (N,)."""
        # A policy in a single bin: ln M - M ln M / M, 0 up to rounding.
        return np.maximum(np.log(self.n_episodes) - self.xlogx / self.n_episodes, 0.0)


def histogram_terms(returns: np.ndarray, edges: np.ndarray) -> HistogramTerms:
    """Histogram every policy's returns on the same edges and keep the entropy terms.

    Parameters
    ----------
    returns : numpy.ndarray, shape (N, M), float64
        Validated returns inside ``[edges[0], edges[-1]]``.
    edges : numpy.ndarray, shape (B + 1,)
        Non-decreasing bin edges, for example from :func:`bin_edges`.

    Returns
    -------
    HistogramTerms
        Equal to the terms of :func:`policy_bin_counts` up to the order of summation of each
        policy's ``c ln c``: one parallel pass counts each row in a per-thread table of B counts
        (no sort), then reads and clears the bins the row touched.
    """
    edges = np.ascontiguousarray(edges, dtype=np.float64)
    returns = np.ascontiguousarray(returns, dtype=np.float64)
    scale = bin_scale(edges)
    if not np.isfinite(scale):
        counts = histogram_rows(returns, edges)
        per_run = counts.counts * np.log(counts.counts)
        return HistogramTerms(counts.pooled_counts(), np.add.reduceat(per_run, counts.indptr[:-1]),
                              counts.occupied_bins(), returns.shape[1])
    n_policies = returns.shape[0]
    xlogx, occupied = np.empty(n_policies), np.empty(n_policies, dtype=np.int64)
    # One table per thread of the pool: numba.get_thread_id() is below NUMBA_NUM_THREADS.
    pooled = np.zeros((numba.config.NUMBA_NUM_THREADS, edges.size - 1), dtype=np.int64)
    _histogram_terms(returns, scale, bin_slack(edges), edges, xlogx, occupied, pooled)
    return HistogramTerms(pooled.sum(axis=0), xlogx, occupied, returns.shape[1])


_ROWS_PER_TASK = 64


@numba.njit(cache=True, parallel=True, nogil=True)
def _histogram_terms(returns, scale, slack, edges, xlogx, occupied, pooled):
    n_policies, n_episodes = returns.shape
    n_bins = edges.size - 1
    counts = np.zeros((pooled.shape[0], n_bins), dtype=np.int32)
    n_tasks = (n_policies + _ROWS_PER_TASK - 1) // _ROWS_PER_TASK
    for task in numba.prange(n_tasks):
        thread = numba.get_thread_id()
        count, pool = counts[thread], pooled[thread]
        index = np.empty(n_episodes, dtype=np.int64)
        for n in range(task * _ROWS_PER_TASK, min(n_policies, (task + 1) * _ROWS_PER_TASK)):
            for e in range(n_episodes):
                b = bin_of(returns[n, e], scale, slack, edges)
                index[e] = b
                count[b] += 1
                pool[b] += 1
            total, bins = 0.0, 0
            for e in range(n_episodes):
                c = count[index[e]]
                if c > 0:
                    # A count of 1 adds 1·ln 1 = +0.0, which leaves the sum's bits as they are: most
                    # bins at B = 10⁵ hold one return, and the logarithm was half the kernel's time.
                    if c > 1:
                        total += c * math.log(c)
                    bins += 1
                    count[index[e]] = 0
            xlogx[n], occupied[n] = total, bins


def plugin_entropy(counts: np.ndarray) -> float:
    """Plug-in (maximum-likelihood) entropy in nats of a histogram.

    Parameters
    ----------
    counts : numpy.ndarray, shape (K,)
        Non-negative bin counts (zeros allowed), not all zero.

    Returns
    -------
    float
        ``-sum p ln p`` with ``p = counts / counts.sum()``, computed as
        ``ln n - sum c ln c / n``.
    """
    counts = np.asarray(counts, dtype=np.float64)
    total = counts.sum()
    # The clip removes the rounding of ln n - n ln n / n when a single bin holds everything.
    return max(0.0, float(np.log(total) - sum_xlogx(counts) / total))


def sum_xlogx(counts: np.ndarray, axis: int | None = None) -> np.ndarray | float:
    """``sum c ln c`` over non-negative counts, with ``0 ln 0 = 0``.

    Parameters
    ----------
    counts : numpy.ndarray
        Non-negative counts of any shape and numeric dtype.
    axis : int, optional
        Axis to sum over; all elements when None.
    """
    values = np.asarray(counts, dtype=np.float64)
    # ln(max(c, 1)) is ln c for every count >= 1 and 0 for c = 0, which gives 0 ln 0 = 0.
    return np.sum(values * np.log(np.maximum(values, 1.0)), axis=axis)


@dataclass(frozen=True, eq=False)
class PolicyBinCounts:
    """Per-policy histograms on shared bin edges, stored sparsely (compressed rows).

    Policy ``n`` occupies the bins ``bins[indptr[n]:indptr[n + 1]]`` (increasing) with the counts
    ``counts[indptr[n]:indptr[n + 1]]``; empty bins are not stored.

    Attributes
    ----------
    indptr : numpy.ndarray, shape (N + 1,), int64
    bins : numpy.ndarray, shape (nnz,), intp
    counts : numpy.ndarray, shape (nnz,), int64
    n_bins : int
        Number of bins B of the shared edges.
    n_episodes : int
        Episodes per policy M (the sum of every policy's counts).
    """

    indptr: np.ndarray
    bins: np.ndarray
    counts: np.ndarray
    n_bins: int
    n_episodes: int

    @property
    def n_policies(self) -> int:
        """Number of policies N."""
        return self.indptr.size - 1

    def occupied_bins(self) -> np.ndarray:
        """Number of non-empty bins of each policy, shape (N,)."""
        return np.diff(self.indptr)

    def policy_entropies(self) -> np.ndarray:
        """Plug-in entropy Hₙ in nats of each policy's histogram, shape (N,)."""
        per_run = self.counts * np.log(self.counts)
        entropies = np.log(self.n_episodes) - np.add.reduceat(per_run, self.indptr[:-1]) / self.n_episodes
        return np.maximum(entropies, 0.0)  # a policy in a single bin: 0 up to rounding

    def pooled_counts(self) -> np.ndarray:
        """Counts of all N·M returns in each bin, shape (B,), int64."""
        return np.bincount(self.bins, weights=self.counts, minlength=self.n_bins).astype(np.int64)

    def bin_major(self, dtype: type = np.int64) -> scipy.sparse.csr_array:
        """The (occupied bin, policy) count matrix, shape (K, N), K = non-empty pooled bins.

        Row k holds the counts of the k-th non-empty bin over policies, so that a matrix of policy
        multiplicities ``W`` (N, R) gives the pooled histograms of R resamples as
        ``bin_major() @ W``.
        """
        by_policy = scipy.sparse.csr_array(
            (self.counts.astype(dtype), self.bins, self.indptr),
            shape=(self.n_policies, self.n_bins),
        )
        by_bin = by_policy.T.tocsr()
        occupied = np.flatnonzero(np.diff(by_bin.indptr))
        indptr = np.append(by_bin.indptr[occupied], by_bin.indptr[-1])
        return scipy.sparse.csr_array((by_bin.data, by_bin.indices, indptr), shape=(occupied.size, self.n_policies))


def policy_bin_counts(returns: np.ndarray, edges: np.ndarray) -> PolicyBinCounts:
    """Histogram every policy's returns on the same edges.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns, all inside ``[edges[0], edges[-1]]``.
    edges : numpy.ndarray, shape (B + 1,)
        Non-decreasing bin edges, for example from :func:`bin_edges`.

    Returns
    -------
    PolicyBinCounts
        The sparse (policy, bin, count) histograms; runs of equal bins are found on each policy's
        sorted bin indices, so the cost is one row-wise sort, not a loop over policies.
    """
    returns = validate_returns(returns)
    edges = np.asarray(edges, dtype=np.float64)
    if edges.ndim != 1 or edges.size < 3 or np.any(np.diff(edges) < 0):
        raise ValueError(f"edges must be a 1-D non-decreasing array of at least 3 values, got shape {edges.shape}")
    if returns.min() < edges[0] or returns.max() > edges[-1]:
        raise ValueError(
            f"edges must span every return: [{edges[0]}, {edges[-1]}] does not contain "
            f"[{returns.min()}, {returns.max()}]"
        )
    return histogram_rows(returns, edges)


def histogram_rows(returns: np.ndarray, edges: np.ndarray, *, rows_sorted: bool = False) -> PolicyBinCounts:
    """:func:`policy_bin_counts` without input checks, for callers that validated already.

    Parameters
    ----------
    returns : numpy.ndarray, shape (N, M), float64
        Finite returns inside ``[edges[0], edges[-1]]``.
    edges : numpy.ndarray, shape (B + 1,)
        Non-decreasing bin edges.
    rows_sorted : bool, default False
        True when every row of ``returns`` is already sorted, which makes the bin indices sorted
        too (binning is monotone) and skips the sort.
    """
    sorted_index = bin_indices(returns, edges)
    if not rows_sorted:
        sorted_index.sort(axis=1)
    n_bins = edges.size - 1
    n_policies, n_episodes = sorted_index.shape
    starts_run = np.ones(sorted_index.shape, dtype=bool)
    np.not_equal(sorted_index[:, 1:], sorted_index[:, :-1], out=starts_run[:, 1:])
    flat_starts = np.flatnonzero(starts_run)
    counts = np.diff(np.append(flat_starts, sorted_index.size))
    indptr = np.zeros(n_policies + 1, dtype=np.int64)
    np.cumsum(starts_run.sum(axis=1), out=indptr[1:])
    return PolicyBinCounts(
        indptr=indptr,
        bins=sorted_index.ravel()[flat_starts],
        counts=counts.astype(np.int64),
        n_bins=n_bins,
        n_episodes=n_episodes,
    )
