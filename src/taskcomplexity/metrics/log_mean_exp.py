"""Per-policy log-mean-exp ℓₙ(λ) = ln (1/M) Σ_e exp(xₙₑ/λ) of centred returns, as a numba kernel.

The rows hold centred returns ``xₙₑ = S[n, e] - mₙ <= 0`` whose largest value is exactly 0, so every
sum is at least 1 and never underflows. A row is stored once, sorted in decreasing order, either
with one entry per episode (``weights`` empty) or as its distinct values with their multiplicities.
One pass over a row evaluates every requested temperature, so the row stays in cache; policies
run in parallel (``numba.prange``).

Exact to rounding, with two shortcuts whose error is bounded
------------------------------------------------------------
The kernel returns ``ln Σ̂ - ln M`` where Σ̂ is the sum up to a relative error of at most about
1.3e-13 in the worst case (so ℓ to an absolute 1.3e-13; typical errors are a few 1e-16), from:

1. **Truncation of the tail.** With the row sorted, the sum stops at the first value with
   ``x/λ < -c``, ``c = ln M + 37``: the dropped terms are fewer than M, each below ``e^-c``, and
   the sum is at least 1, so they change it by less than ``M e^-c = e^-37 ≈ 8.5e-17`` relative.
   (This replaces the old floor of exponents at -700: terms below e^-700 were as invisible, and
   no exponent below -c ever reaches ``exp``.)
2. **Taylor blocks.** The sorted row is cut into aligned blocks of 8, 16, …, 512 consecutive
   values. A block with centre ``c_b``, half-width ``h_b`` (half its span) and weight ``W_b`` keeps
   the normalised power sums ``Q_k = Σ w u^k``, ``u = (x - c_b)/h_b ∈ [-1, 1]``, so that
   ``Σ_block w e^{x/λ} = e^{c_b/λ} Σ_k (Q_k/k!) z^k`` with ``z = h_b/λ``. The kernel uses the
   largest aligned block with ``z <= ρ = 1`` and the series up to ``k = K = 18``. With
   ``y = (x - c_b)/λ ∈ [-z, z]``:

   * the block sum is at least ``W_b e^{c_b/λ} e^{-ρ}``, and every series term is at most
     ``W_b z^k/k!`` in size (their sum at most ``W_b e^ρ``): absolute errors of order ``ε W_b e^ρ``
     are amplified by at most ``e^{2ρ} ≈ 7.39`` relative to the block sum;
   * the Lagrange remainder of each term is at most ``e^ρ ρ^{K+1}/(K+1)!``, so the truncated
     series is off by at most ``e^{2ρ} ρ^{K+1}/(K+1)! = e²/19! ≈ 6.1e-17`` relative;
   * rounding, in units of ε = 2^-53 relative to ``W_b e^ρ``: each ``u^k`` (two roundings in u,
     k products: ``3K = 54``), the power sums (each of 8 lanes adds at most 64 leaves, then the
     lanes pairwise: ``67``), ``1/k!`` (2) and the polynomial (even and odd halves by Horner's rule
     in z², fused multiply-adds where the CPU has them: at most ``2K = 36``): 159 ε, so at most
     ``7.39 · 159 ε ≈ 1.3e-13`` relative for a 512-block (``7.39 · 99 ε ≈ 8e-14`` for 8 values).
3. **Plain rounding** of ``exp``, of ``x/λ`` (also in the numpy reference) and of the summation of
   positive terms: leaves of 8 values are summed first, then the leaves, as numpy's pairwise sum
   does. Block sums are positive, so their relative errors do not grow when they are added.

Blocks with ``h_b = 0`` (a run of equal values, common in integer-valued rows) are exact: ``Q_0 = W_b``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_LEAF_BITS = 3
LEAF = 1 << _LEAF_BITS
"""Values per leaf block (the direct path sums leaves of this size first); the power sums use one
lane per value of a leaf, written out for 8."""
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


@numba.njit(cache=True, parallel=True, nogil=True, fastmath={"contract"})
def _log_mean_exp(values, weights, indptr, temperatures, cut, log_m, max_blocks, inverse_factorials, out):
    n_rows = indptr.size - 1
    n_tasks = (n_rows + _POLICIES_PER_TASK - 1) // _POLICIES_PER_TASK
    for task in numba.prange(n_tasks):
        centre = np.empty(max_blocks)
        half = np.empty(max_blocks)
        coef = np.empty((max_blocks, TAYLOR_ORDER + 1))
        built = np.empty(max_blocks, dtype=np.bool_)
        lanes = np.empty((TAYLOR_ORDER + 1, LEAF))
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


@numba.njit(cache=True, inline="always")
def _u(x, i, stop, c, h):
    """Normalised value of element i of a block (0 past its end)."""
    return (x[i] - c) / h if i < stop and h > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def _w(w, i, stop):
    """Weight of element i of a block (0 past its end)."""
    return (w[i] if w.size else 1.0) if i < stop else 0.0


@numba.njit(cache=True)
def _build_block(x, w, first, stop, c, h, inverse_factorials, lanes, coef):
    """``Q_k / k!`` of the values ``x[first:stop]`` about ``c``, in units of ``h`` (module docstring).

    The values are taken LEAF = 8 at a time, one per lane: each lane keeps its running power in a
    register and its own sums in ``lanes``; the lanes are added pairwise at the end.
    """
    lanes[:] = 0.0
    for i in range(first, stop, LEAF):
        u0, u1 = _u(x, i, stop, c, h), _u(x, i + 1, stop, c, h)
        u2, u3 = _u(x, i + 2, stop, c, h), _u(x, i + 3, stop, c, h)
        u4, u5 = _u(x, i + 4, stop, c, h), _u(x, i + 5, stop, c, h)
        u6, u7 = _u(x, i + 6, stop, c, h), _u(x, i + 7, stop, c, h)
        p0, p1, p2, p3 = _w(w, i, stop), _w(w, i + 1, stop), _w(w, i + 2, stop), _w(w, i + 3, stop)
        p4, p5, p6, p7 = _w(w, i + 4, stop), _w(w, i + 5, stop), _w(w, i + 6, stop), _w(w, i + 7, stop)
        for k in range(TAYLOR_ORDER + 1):
            a = lanes[k]
            a[0], a[1], a[2], a[3] = a[0] + p0, a[1] + p1, a[2] + p2, a[3] + p3
            a[4], a[5], a[6], a[7] = a[4] + p4, a[5] + p5, a[6] + p6, a[7] + p7
            p0, p1, p2, p3, p4, p5, p6, p7 = p0 * u0, p1 * u1, p2 * u2, p3 * u3, p4 * u4, p5 * u5, p6 * u6, p7 * u7
    for k in range(TAYLOR_ORDER + 1):
        a = lanes[k]
        coef[k] = (((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))) * inverse_factorials[k]


@numba.njit(cache=True, inline="always", fastmath={"contract"})
def _row_sum(x, w, temperature, cut, offsets, centre, half, coef, built, inverse_factorials, lanes):
    """Σ w e^{x/λ} of one sorted row (see the module docstring); builds the blocks it uses."""
    length = x.size
    floor = -cut * temperature
    reach = TAYLOR_RADIUS * temperature
    total = 0.0
    i = 0
    while i < length and x[i] >= floor:
        chosen = -1
        # The largest aligned block at i whose half-width is within reach; block sizes are powers of 2,
        # so alignment and block index are bit operations (an integer division per level cost 8–24 %).
        for level in range(LEVELS - 1, -1, -1):
            bits = _LEAF_BITS + level
            if (i & ((1 << bits) - 1)) == 0 and half[offsets[level] + (i >> bits)] <= reach:
                chosen = level
                break
        if chosen >= 0:
            size = LEAF << chosen
            b = offsets[chosen] + (i >> (_LEAF_BITS + chosen))
            if not built[b]:
                _build_block(x, w, i, min(i + size, length), centre[b], half[b], inverse_factorials, lanes, coef[b])
                built[b] = True
            # Σ a_k z^k as its even and odd halves in z² (two independent chains of Horner's rule).
            z = half[b] / temperature
            a = coef[b]
            z2 = z * z
            even = a[TAYLOR_ORDER]
            odd = a[TAYLOR_ORDER - 1]
            for k in range(TAYLOR_ORDER - 2, 0, -2):
                even = even * z2 + a[k]
                odd = odd * z2 + a[k - 1]
            poly = (even * z2 + a[0]) + odd * z
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
