"""Pooled-histogram entropies of many policy resamples at once (the numba kernels of the bootstrap PIC).

A resample is a vector of policy multiplicities w (N,); its pooled histogram is ``Σₙ wₙ cₙ`` with
``cₙ`` policy n's histogram on the resample's bin edges, and its H(R) needs ``Σ_b c_b ln c_b`` of
that pooled histogram (:func:`pooled_xlogx`). Counts are integers, so every pooled count is exact;
only the order in which the ``c ln c`` terms are added differs from a sparse matrix product followed
by :func:`numpy.sum` (compensated sums keep that difference at the level of one rounding).

All N·M returns are sorted once (:class:`SortedReturns`), with the policy of each. On given edges
the sorted returns fall into consecutive runs, one per occupied bin, so a sweep over them forms the
pooled counts of a bin for 64 resamples at once (each return adds its policy's multiplicities, packed
in bytes so that a block of them stays in cache) and adds ``c ln c`` when the bin ends. Nothing is
built per set of edges but the run boundaries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from taskcomplexity.metrics.histogram import bin_of, bin_scale, bin_slack

RESAMPLES_PER_BLOCK = 64
"""Resamples whose pooled counts one sweep over the sorted returns forms."""
_TABLE_SIZE = 4096
"""``c ln c`` is looked up for counts below this (almost every bin) and computed above it."""
_XLOGX = np.arange(_TABLE_SIZE, dtype=np.float64) * np.log(np.maximum(np.arange(_TABLE_SIZE, dtype=np.float64), 1.0))


@dataclass(frozen=True, eq=False)
class SortedReturns:
    """All returns of a matrix in increasing order, with the policy (row) of each.

    Attributes
    ----------
    values : numpy.ndarray, shape (N·M,), float64
    policy : numpy.ndarray, shape (N·M,), int32
    """

    values: np.ndarray
    policy: np.ndarray

    @classmethod
    def of(cls, returns: np.ndarray) -> SortedReturns:
        """Sort the returns (N, M) of N < 2**31 policies."""
        order = np.argsort(returns, axis=None)  # ties may come in any order: they share a bin
        policy = (order // returns.shape[1]).astype(np.int32)
        return cls(np.ascontiguousarray(returns.ravel()[order]), policy)


def pooled_xlogx(returns: SortedReturns, edges: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``Σ_b c ln c`` of every resample's pooled histogram, shape (R,).

    Parameters
    ----------
    returns : SortedReturns
        The sorted returns of the N policies the resamples draw from.
    edges : numpy.ndarray, shape (B + 1,)
        Bin edges with a finite :func:`~taskcomplexity.metrics.histogram.bin_scale`; every return of
        a policy drawn by some resample lies inside them (others may not: their weight is 0).
    weights : numpy.ndarray, shape (R, N), integer
        Multiplicity of each policy in each resample.
    """
    edges = np.ascontiguousarray(edges, dtype=np.float64)
    # Bin b holds the values with edges[b] <= v < edges[b + 1] (the last bin closed): in the sorted
    # returns it starts at the first value >= edges[b] (the same bins as bin_of).
    bounds = np.empty(edges.size, dtype=np.int64)
    _bin_starts(returns.values, edges, 4 * numba.get_num_threads(), bounds)
    runs = bounds[np.append(np.diff(bounds) > 0, True)]  # empty bins dropped, the end kept

    n_resamples, n_policies = weights.shape
    blocks = -(-n_resamples // RESAMPLES_PER_BLOCK)
    # Block k, policy n: the multiplicities of policy n in the k-th block of resamples, contiguous.
    dtype = np.uint8 if weights.max(initial=0) <= np.iinfo(np.uint8).max else np.float64
    blocked = _aligned_zeros((blocks, n_policies, RESAMPLES_PER_BLOCK), dtype)
    for block in range(blocks):
        part = weights[block * RESAMPLES_PER_BLOCK:(block + 1) * RESAMPLES_PER_BLOCK]
        blocked[block, :, : part.shape[0]] = part.T
    # Chunks of runs (bins) with about equal numbers of returns, several per thread for balance.
    chunks = max(1, min(32 * numba.get_num_threads(), (runs[-1] - runs[0]) // 4096))
    bounds = np.searchsorted(runs, np.linspace(runs[0], runs[-1], chunks + 1), side="left")
    bounds[0], bounds[-1] = 0, runs.size - 1
    sums = np.zeros((chunks, blocks * RESAMPLES_PER_BLOCK))
    errors = np.zeros_like(sums)
    # Pooled counts are at most N·M: 32-bit integers when that fits (faster than float64).
    counts = np.empty((chunks, RESAMPLES_PER_BLOCK), dtype=np.int32 if returns.values.size < 2**31 else np.float64)
    _sweep(runs, returns.policy, blocked, bounds, _XLOGX, counts, sums, errors)
    return (sums + errors).sum(axis=0)[:n_resamples]


def _aligned_zeros(shape: tuple[int, ...], dtype: type) -> np.ndarray:
    """Zeros whose first element starts a 64-byte cache line, so that a policy's block of
    multiplicities (64 bytes) is one line, not two."""
    size = int(np.prod(shape)) * np.dtype(dtype).itemsize
    raw = np.zeros(size + 64, dtype=np.uint8)
    offset = -raw.ctypes.data % 64
    return raw[offset:offset + size].view(dtype).reshape(shape)


def sorted_row_xlogx(ordered: np.ndarray, rows: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """``Σ_b c ln c`` of the histograms of ``ordered[rows]``, shape (len(rows),).

    Parameters
    ----------
    ordered : numpy.ndarray, shape (N, M), float64
        Rows sorted in increasing order.
    rows : numpy.ndarray, shape (K,), int
        The rows to histogram; their values lie inside the edges.
    edges : numpy.ndarray, shape (B + 1,)
        Bin edges with a finite :func:`~taskcomplexity.metrics.histogram.bin_scale`.
    """
    edges = np.ascontiguousarray(edges, dtype=np.float64)
    out = np.empty(len(rows))
    _sorted_row_xlogx(np.ascontiguousarray(ordered, dtype=np.float64), np.asarray(rows, dtype=np.int64),
                      bin_scale(edges), bin_slack(edges), edges, _XLOGX, out)
    return out


@numba.njit(cache=True, inline="always")
def _xlogx(c, table):
    return table[int(c)] if c < table.size else c * math.log(c)


@numba.njit(cache=True, parallel=True)
def _bin_starts(values, edges, tasks, out):
    """``out[b]`` = first index of the sorted ``values`` with ``values[i] >= edges[b]`` for b < B, and
    ``out[B]`` = one past the last value <= ``edges[B]`` (the last bin is closed)."""
    n_edges = edges.size
    for task in numba.prange(tasks):
        first, stop = task * n_edges // tasks, (task + 1) * n_edges // tasks
        if first == stop:
            continue
        low, high = 0, values.size  # binary search for the first value >= edges[first]
        while low < high:
            middle = (low + high) // 2
            if values[middle] < edges[first]:
                low = middle + 1
            else:
                high = middle
        i = low
        for b in range(first, stop):
            if b == n_edges - 1:
                while i < values.size and values[i] <= edges[b]:
                    i += 1
            else:
                while i < values.size and values[i] < edges[b]:
                    i += 1
            out[b] = i


@numba.njit(cache=True, parallel=True)
def _sorted_row_xlogx(ordered, rows, scale, slack, edges, table, out):
    for k in numba.prange(rows.size):
        total, run, previous = 0.0, 0.0, -1
        for value in ordered[rows[k]]:
            b = bin_of(value, scale, slack, edges)
            if b != previous:
                total += _xlogx(run, table)
                run, previous = 0.0, b
            run += 1.0
        out[k] = total + _xlogx(run, table)


@numba.njit(cache=True, parallel=True)
def _sweep(runs, policy, blocked, bounds, table, counts, sums, errors):
    """Per chunk of bins and resample: Neumaier-compensated ``Σ c ln c`` of the pooled counts."""
    for chunk in numba.prange(bounds.size - 1):
        pooled = counts[chunk]
        for block in range(blocked.shape[0]):
            weights = blocked[block]
            total = sums[chunk, block * RESAMPLES_PER_BLOCK:(block + 1) * RESAMPLES_PER_BLOCK]
            error = errors[chunk, block * RESAMPLES_PER_BLOCK:(block + 1) * RESAMPLES_PER_BLOCK]
            for run in range(bounds[chunk], bounds[chunk + 1]):
                for j in range(RESAMPLES_PER_BLOCK):
                    pooled[j] = 0
                for i in range(runs[run], runs[run + 1]):
                    w = weights[policy[i]]
                    for j in range(RESAMPLES_PER_BLOCK):
                        pooled[j] += w[j]
                for j in range(RESAMPLES_PER_BLOCK):
                    term, before = _xlogx(np.float64(pooled[j]), table), total[j]
                    after = before + term
                    error[j] += (before - after) + term if before >= term else (term - after) + before
                    total[j] = after
