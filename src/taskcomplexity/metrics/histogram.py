"""Equal-width binning of returns and sparse per-policy histograms.

This is the one place that decides which bin a return falls in, so that the point estimate of PIC,
its bootstrap, the Miller–Madow correction and the reference implementation agree bin for bin.
The bins follow :func:`numpy.histogram` with explicit edges: bin ``b`` is the half-open interval
``[edges[b], edges[b + 1])`` except the last one, which is closed.
"""

from __future__ import annotations

from dataclasses import dataclass

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
    puts in a neighbouring bin are detected against ``edges`` and corrected.

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
    n_bins = edges.size - 1
    low, high = edges[0], edges[-1]
    with np.errstate(over="ignore"):  # a span so narrow that B / span overflows is handled next
        scale = n_bins / (high - low)
    if not np.isfinite(scale):
        return np.minimum(np.searchsorted(edges, values, side="right") - 1, n_bins - 1)
    index = ((values - low) * scale).astype(np.intp)
    np.clip(index, 0, n_bins - 1, out=index)
    wrong = (values < edges[index]) | ((values >= edges[index + 1]) & (index != n_bins - 1))
    if wrong.any():
        exact = np.searchsorted(edges, values[wrong], side="right") - 1
        index[wrong] = np.minimum(exact, n_bins - 1)
    return index


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
