"""``Generator.permutation`` of a 1-D array, bit for bit NumPy's, in numba.

The permutation null shuffles all N·M returns once per repeat; NumPy's Fisher–Yates loop takes about
0.4 s for 5·10⁶ returns, interleaving each random draw (a serial chain through the generator's
state) with a swap at a random place of a 40 MB array (a cache miss). :func:`permutation` draws the
same random indices first — NumPy's PCG64 (128-bit LCG, XSL-RR output), its buffered 32-bit draws and
the masked rejection of ``random_interval`` — and then performs the same swaps in the same order, a
loop whose cache misses the processor overlaps. The result and the generator's state afterwards are
exactly those of ``rng.permutation(values)`` (tested); other bit generators are passed to NumPy.

:func:`shuffled_ahead` gives a sequence of such permutations of a return matrix, each drawn (and
optionally prepared) in one background thread while the caller works on the previous one: the
draws and swaps are a serial chain, so on a multi-core machine they otherwise leave every core but
one idle between the parallel estimators. The kernels release the GIL, and the permutations are the
same, in the same order, as drawing them one after another.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

import numba
import numpy as np

Prepared = TypeVar("Prepared")

_MASK32 = np.uint64(0xFFFFFFFF)
_MULT_HIGH = np.uint64(0x2360ED051FC65DA4)
_MULT_LOW = np.uint64(0x4385DF649FCCF645)


def permutation(rng: np.random.Generator, values: np.ndarray) -> np.ndarray:
    """``rng.permutation(values)`` for a 1-D array, advancing ``rng`` exactly as NumPy does.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator; its state moves on as if ``rng.permutation(values)`` had been called.
    values : numpy.ndarray, shape (n,)
        The values to permute (not modified).

    Returns
    -------
    numpy.ndarray, shape (n,)
        A permuted copy.
    """
    values = np.asarray(values)
    bit_generator = rng.bit_generator
    if type(bit_generator) is not np.random.PCG64 or values.ndim != 1 or values.size >= 2**32:
        return rng.permutation(values)
    out = values.copy()
    if out.size < 2:
        return out
    state = bit_generator.state
    words = np.array([state["state"]["state"] >> 64, state["state"]["state"] & (2**64 - 1),
                      state["state"]["inc"] >> 64, state["state"]["inc"] & (2**64 - 1),
                      state["has_uint32"], state["uinteger"]], dtype=np.uint64)
    targets = np.empty(out.size, dtype=np.int64)
    _draw_targets(words, targets)
    _swap(out, targets)
    state["state"]["state"] = (int(words[0]) << 64) | int(words[1])
    state["has_uint32"], state["uinteger"] = int(words[4]), int(words[5])
    bit_generator.state = state
    return out


@numba.njit(cache=True, inline="always")
def _mul64(a, b):
    """Full 128-bit product of two uint64 as (high, low)."""
    a_lo, a_hi = a & _MASK32, a >> np.uint64(32)
    b_lo, b_hi = b & _MASK32, b >> np.uint64(32)
    lo_lo, hi_lo, lo_hi, hi_hi = a_lo * b_lo, a_hi * b_lo, a_lo * b_hi, a_hi * b_hi
    cross = (lo_lo >> np.uint64(32)) + (hi_lo & _MASK32) + lo_hi
    return hi_hi + (hi_lo >> np.uint64(32)) + (cross >> np.uint64(32)), (cross << np.uint64(32)) | (lo_lo & _MASK32)


@numba.njit(cache=True, inline="always")
def _next64(state):
    """PCG64: state = state·MULT + inc mod 2¹²⁸, then the XSL-RR output of the new state."""
    s_hi, s_lo, inc_hi, inc_lo = state[0], state[1], state[2], state[3]
    high, low = _mul64(s_lo, _MULT_LOW)
    high = high + s_lo * _MULT_HIGH + s_hi * _MULT_LOW
    new_lo = low + inc_lo
    new_hi = high + inc_hi + (np.uint64(1) if new_lo < low else np.uint64(0))
    state[0], state[1] = new_hi, new_lo
    rotation = new_hi >> np.uint64(58)
    mixed = new_hi ^ new_lo
    return (mixed >> rotation) | (mixed << ((np.uint64(64) - rotation) & np.uint64(63)))


@numba.njit(cache=True, inline="always")
def _next32(state):
    """NumPy's buffered 32-bit draw: the low half of a 64-bit draw, the high half kept for next time."""
    if state[4] != 0:
        state[4] = np.uint64(0)
        return state[5]
    draw = _next64(state)
    state[4], state[5] = np.uint64(1), draw >> np.uint64(32)
    return draw & _MASK32


def shuffled_ahead(
    rng: np.random.Generator,
    returns: np.ndarray,
    repeats: int,
    prepare: Callable[[np.ndarray], Prepared] | None = None,
) -> Iterator[tuple[np.ndarray, Prepared | None]]:
    """``repeats`` permutations of all of ``returns`` across its cells, each one ahead in a background thread.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the permutations, one after another (only the background thread uses it meanwhile).
    returns : numpy.ndarray, shape (N, M)
        The matrix whose N·M values are permuted (not modified).
    repeats : int
        Number of permutations.
    prepare : callable, optional
        ``prepare(permuted)`` is also computed in the background (for example the sorted rows the
        POIC search needs); None prepares nothing.

    Yields
    ------
    (numpy.ndarray, object)
        ``permutation(rng, returns.ravel()).reshape(returns.shape)`` of each repeat in order, and what
        ``prepare`` made of it (None without ``prepare``).
    """

    def make() -> tuple[np.ndarray, Prepared | None]:
        permuted = permutation(rng, returns.ravel()).reshape(returns.shape)
        return permuted, (prepare(permuted) if prepare is not None else None)

    if repeats < 1:
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="shuffled-ahead") as worker:
        pending = worker.submit(make)
        for repeat in range(repeats):
            made = pending.result()
            if repeat + 1 < repeats:
                pending = worker.submit(make)
            yield made


@numba.njit(cache=True, nogil=True)
def _draw_targets(state, targets):
    """``targets[i] = random_interval(i)`` for i = n - 1 … 1, in NumPy's order of draws."""
    for i in range(targets.size - 1, 0, -1):
        bound = np.uint64(i)
        mask = bound
        mask |= mask >> np.uint64(1)
        mask |= mask >> np.uint64(2)
        mask |= mask >> np.uint64(4)
        mask |= mask >> np.uint64(8)
        mask |= mask >> np.uint64(16)
        value = _next32(state) & mask
        while value > bound:
            value = _next32(state) & mask
        targets[i] = np.int64(value)


@numba.njit(cache=True, nogil=True)
def _swap(values, targets):
    """Fisher–Yates swaps ``values[i] <-> values[targets[i]]`` for i = n - 1 … 1, in that order."""
    for i in range(values.size - 1, 0, -1):
        j = targets[i]
        values[i], values[j] = values[j], values[i]
