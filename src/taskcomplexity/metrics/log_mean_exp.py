"""Per-policy log-mean-exp ℓₙ(λ) = ln (1/M) Σ_e exp(xₙₑ/λ) of centred returns, as a numba kernel.

The rows hold centred returns ``xₙₑ = S[n, e] - mₙ <= 0`` whose largest value is exactly 0, so every
sum is at least 1 and never underflows. A row is stored once, sorted in decreasing order, either
with one entry per episode (``weights`` empty) or as its distinct values with their multiplicities.
One pass over a row evaluates every requested temperature, so the row stays in cache; policies
run in parallel (``numba.prange``).

Exact to rounding, with two shortcuts whose error is bounded
------------------------------------------------------------
The kernel returns ``ln Σ̂ - ln M`` where Σ̂ is the sum up to a relative error of a few 1e-14 at
most (so ℓ to an absolute few 1e-14), from three sources:

1. **Truncation of the tail.** With the row sorted, the sum stops at the first value with
   ``x/λ < -c``, ``c = ln M + 37``: the dropped terms are fewer than M, each below ``e^-c``, and
   the sum is at least 1, so they change it by less than ``M e^-c = e^-37 ≈ 8.5e-17`` relative.
   (This replaces the old floor of exponents at -700, whose terms e^-700 were as invisible.)
2. **Taylor blocks.** The sorted row is cut into aligned blocks of 8, 16, …, 512 consecutive
   values. A block with centre ``c_b``, half-width ``h_b`` (half its span) and weight ``W_b`` keeps
   the normalised power sums ``Q_k = Σ w (x - c_b)^k / h_b^k`` (|u| <= 1 inside the block), so that
   ``Σ_block w e^{x/λ} = e^{c_b/λ} Σ_k Q_k z^k / k!`` with ``z = h_b/λ``. The kernel uses the
   largest aligned block with ``z <= ρ = 1`` and the series up to ``k = K = 18``. With
   ``y = (x - c_b)/λ ∈ [-z, z]``:

   * the block sum is at least ``W_b e^{c_b/λ} e^{-ρ}``;
   * the Lagrange remainder of each term is at most ``e^ρ ρ^{K+1}/(K+1)!``, so the truncated
     series is off by at most ``e^{2ρ} ρ^{K+1}/(K+1)! = e²/19! ≈ 6.1e-17`` relative;
   * every series term is bounded by ``W_b z^k/k!`` in size and the terms alternate in sign at
     worst, so absolute rounding errors of order ε W_b e^ρ are amplified by at most ``e^{2ρ} ≈ 7.4``
     relative to the block sum. Those errors are: the power sums (each element's ``u^k`` by k
     products after two roundings, summed in sub-sums of 8: at most ``(K + 2 + 7 + 512/8) ε``),
     the scaling by ``1/k!`` (ε) and Horner's rule (``2K ε``). In total at most
     ``7.4 · (18 + 2 + 7 + 64 + 1 + 36) ε ≈ 950 ε ≈ 1.1e-13`` relative for a 512-block, and
     ``7.4 · 65 ε ≈ 5e-14`` for blocks of 8 — a worst-case bound; typical errors are ~1e-16.
3. **Plain rounding** of ``exp``, of ``x/λ`` (also in the numpy reference) and of the summation of
   positive terms: leaves of 8 values are summed first, then the leaves, as numpy's pairwise sum
   does. Block sums are positive, so their relative errors do not grow when they are added.

Blocks with ``h_b = 0`` (a run of equal values, common in integer-valued rows) are exact: ``Q_0 = W_b``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

LEAF = 8
"""Values per leaf block (the direct path sums leaves of this size first)."""
LEVELS = 7
"""Block sizes LEAF · 2^l, l = 0 … LEVELS - 1 (8 … 512)."""
TAYLOR_ORDER = 18
"""K: powers 0 … K of each block's normalised values are kept."""
TAYLOR_RADIUS = 1.0
"""ρ: a block is summed by its series when its half-width is at most ρ·λ."""
TAIL_MARGIN = 37.0
"""The tail is dropped below x/λ = -(ln M + TAIL_MARGIN), at most e^-37 ≈ 8.5e-17 of the sum."""

_INVERSE_FACTORIALS = np.array([1.0 / math.factorial(k) for k in range(TAYLOR_ORDER + 1)])
_POLICIES_PER_TASK = 16
"""Policies per parallel task (one scratch allocation each)."""


def block_count(length: int) -> int:
    """Number of blocks over all levels of a row of ``length`` values."""
    return sum(-(-length // (LEAF << level)) for level in range(LEVELS))


def log_mean_exp(
    values: np.ndarray, weights: np.ndarray, indptr: np.ndarray, n_episodes: int, temperatures: np.ndarray
) -> np.ndarray:
    """ℓₙ(λ) of every row and temperature, shape (N, T).

    Parameters
    ----------
    values : numpy.ndarray, shape (nnz,), float64
        Row n is ``values[indptr[n]:indptr[n + 1]]``: centred returns in decreasing order, the first
        exactly 0.
    weights : numpy.ndarray, shape (nnz,) or (0,), float64
        Multiplicity of each value (summing to M per row), or empty for one episode per value.
    indptr : numpy.ndarray, shape (N + 1,), int64
        Row boundaries.
    n_episodes : int
        M, the episodes per policy.
    temperatures : numpy.ndarray, shape (T,), float64
        Positive temperatures λ.

    Returns
    -------
    numpy.ndarray, shape (N, T)
        ``ln (1/M) Σ_e exp(x/λ)``, in ``[-ln M, 0]`` (see the module docstring for the error bound).
    """
    temperatures = np.ascontiguousarray(temperatures, dtype=np.float64)
    out = np.empty((indptr.size - 1, temperatures.size))
    if out.size == 0:
        return out
    longest = int(np.max(np.diff(indptr)))
    cut = math.log(n_episodes) + TAIL_MARGIN
    _log_mean_exp(values, weights, indptr, temperatures, cut, math.log(n_episodes), block_count(longest),
                  _INVERSE_FACTORIALS, out)
    return out


@numba.njit(cache=True, parallel=True)
def _log_mean_exp(values, weights, indptr, temperatures, cut, log_m, max_blocks, inverse_factorials, out):
    n_rows = indptr.size - 1
    n_tasks = (n_rows + _POLICIES_PER_TASK - 1) // _POLICIES_PER_TASK
    for task in numba.prange(n_tasks):
        centre = np.empty(max_blocks)
        half = np.empty(max_blocks)
        coef = np.empty((max_blocks, TAYLOR_ORDER + 1))
        built = np.empty(max_blocks, dtype=np.bool_)
        lanes = np.empty((TAYLOR_ORDER + 3, LEAF))  # the sums, then u and the running power
        offsets = np.empty(LEVELS + 1, dtype=np.int64)
        for row in range(task * _POLICIES_PER_TASK, min(n_rows, (task + 1) * _POLICIES_PER_TASK)):
            start, stop = indptr[row], indptr[row + 1]
            x = values[start:stop]
            w = weights[start:stop] if weights.size else weights
            _block_bounds(x, offsets, centre, half, built)
            for column in range(temperatures.size):
                total = _row_sum(x, w, temperatures[column], cut, offsets, centre, half, coef, built,
                                 inverse_factorials, lanes)
                out[row, column] = math.log(total) - log_m


@numba.njit(cache=True)
def _block_bounds(x, offsets, centre, half, built):
    """Centre and half-width of every block of every level; no power sums yet."""
    length = x.size
    offsets[0] = 0
    for level in range(LEVELS):
        size = LEAF << level
        blocks = (length + size - 1) // size
        offsets[level + 1] = offsets[level] + blocks
        for b in range(blocks):
            first, last = b * size, min((b + 1) * size, length) - 1
            centre[offsets[level] + b] = 0.5 * (x[first] + x[last])
            half[offsets[level] + b] = 0.5 * (x[first] - x[last])
    built[: offsets[LEVELS]] = False


@numba.njit(cache=True)
def _build_block(x, w, first, stop, c, h, inverse_factorials, lanes, coef):
    """``Q_k / k!`` of the values ``x[first:stop]`` about ``c``, in units of ``h`` (module docstring).

    Values are taken LEAF at a time, one per lane; each lane keeps its own running power and its
    own sums, and the lanes are added pairwise at the end.
    """
    lanes[:] = 0.0
    u = lanes[TAYLOR_ORDER + 1]
    power = lanes[TAYLOR_ORDER + 2]
    for leaf in range(first, stop, LEAF):
        for j in range(LEAF):
            inside = leaf + j < stop
            u[j] = (x[leaf + j] - c) / h if inside and h > 0.0 else 0.0
            power[j] = (w[leaf + j] if w.size else 1.0) if inside else 0.0
        for k in range(TAYLOR_ORDER + 1):
            for j in range(LEAF):
                lanes[k, j] += power[j]
                power[j] *= u[j]
    for k in range(TAYLOR_ORDER + 1):
        s = lanes[k]
        coef[k] = (((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))) * inverse_factorials[k]


@numba.njit(cache=True, inline="always")
def _row_sum(x, w, temperature, cut, offsets, centre, half, coef, built, inverse_factorials, lanes):
    """Σ w e^{x/λ} of one sorted row (see the module docstring); builds the blocks it uses."""
    length = x.size
    floor = -cut * temperature
    reach = TAYLOR_RADIUS * temperature
    total = 0.0
    i = 0
    while i < length and x[i] >= floor:
        chosen = -1
        for level in range(LEVELS - 1, -1, -1):
            size = LEAF << level
            if i % size == 0 and half[offsets[level] + i // size] <= reach:
                chosen = level
                break
        if chosen >= 0:
            size = LEAF << chosen
            b = offsets[chosen] + i // size
            if not built[b]:
                _build_block(x, w, i, min(i + size, length), centre[b], half[b], inverse_factorials, lanes, coef[b])
                built[b] = True
            z = half[b] / temperature
            a = coef[b]
            poly = a[TAYLOR_ORDER]
            for k in range(TAYLOR_ORDER - 1, -1, -1):
                poly = poly * z + a[k]
            total += math.exp(centre[b] / temperature) * poly
            i += size
        else:
            leaf_sum = 0.0
            stop = min(i + LEAF, length)
            while i < stop and x[i] >= floor:
                leaf_sum += (w[i] if w.size else 1.0) * math.exp(x[i] / temperature)
                i += 1
            total += leaf_sum
            if i < stop:
                break
    return total
