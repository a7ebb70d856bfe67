"""``gymnasium.utils.seeding.np_random(seed)`` for many seeds at once: its state and its draws.

``env.reset(seed=s)`` seeds its generator with ``Generator(PCG64(SeedSequence(s)))`` and draws the
initial state from it. Making one such generator costs ~20 µs, which at N = M = 1000 is 20 s per
task; this module computes the same generators directly, in a numba loop: NumPy's ``SeedSequence``
entropy mixing (pool of four uint32 words, one entropy word for a seed below 2³²) and
``generate_state(4, uint64)``, PCG64's seeding (``srandom(initstate, initseq)``), its 128-bit LCG step
and XSL-RR output, and ``next_double`` = (next_uint64 >> 11) · 2⁻⁵³. ``Generator.uniform(low, high)``
is then ``low + (high − low) · u``.

:func:`seed_generators` gives each seed's generator as four uint64 words, :func:`draw_uniforms` its
next draws, and :func:`next_double` one draw inside another kernel (an env whose ``step`` draws from
``np_random`` continues the episode's stream after the reset's draws). A kernel module that inlines
:func:`next_double` is cached by numba against its own source file only: edit that module too (or
clear ``__pycache__``) after changing the generator here. ``tests/tasks/test_classic_resets.py`` holds
it to NumPy on many seeds.
"""

from __future__ import annotations

import numba
import numpy as np

INIT_A = np.uint32(0x43B0D7E5)
MULT_A = np.uint32(0x931E8875)
INIT_B = np.uint32(0x8B51F9DD)
MULT_B = np.uint32(0x58F38DED)
MIX_MULT_L = np.uint32(0xCA01F9DD)
MIX_MULT_R = np.uint32(0x4973F715)
PCG_MULT_HIGH = np.uint64(0x2360ED051FC65DA4)
PCG_MULT_LOW = np.uint64(0x4385DF649FCCF645)
MASK32 = np.uint64(0xFFFFFFFF)


@numba.njit(cache=True)
def _mul64(a, b):
    """Full 128-bit product of two uint64 as (high, low)."""
    a_lo, a_hi = a & MASK32, a >> np.uint64(32)
    b_lo, b_hi = b & MASK32, b >> np.uint64(32)
    lo_lo = a_lo * b_lo
    hi_lo = a_hi * b_lo
    lo_hi = a_lo * b_hi
    hi_hi = a_hi * b_hi
    cross = (lo_lo >> np.uint64(32)) + (hi_lo & MASK32) + lo_hi
    high = hi_hi + (hi_lo >> np.uint64(32)) + (cross >> np.uint64(32))
    low = (cross << np.uint64(32)) | (lo_lo & MASK32)
    return high, low


@numba.njit(cache=True)
def _step(s_hi, s_lo, inc_hi, inc_lo):
    """state·MULT + inc mod 2¹²⁸."""
    high, low = _mul64(s_lo, PCG_MULT_LOW)
    high = high + s_lo * PCG_MULT_HIGH + s_hi * PCG_MULT_LOW
    low2 = low + inc_lo
    carry = np.uint64(1) if low2 < low else np.uint64(0)
    return high + inc_hi + carry, low2


@numba.njit(cache=True)
def _hashmix(value, hash_const):
    value ^= hash_const
    hash_const = np.uint32(hash_const * MULT_A)
    value = np.uint32(value * hash_const)
    value ^= value >> np.uint32(16)
    return value, hash_const


@numba.njit(cache=True)
def _mix(x, y):
    result = np.uint32(np.uint32(MIX_MULT_L * x) - np.uint32(MIX_MULT_R * y))
    result ^= result >> np.uint32(16)
    return result


GENERATOR_WORDS = 4
"""A generator's state as uint64 words: the LCG state (high, low) and its increment (high, low)."""


@numba.njit(cache=True)
def seed_generator(seed, pool, words):
    """PCG64's state after ``np_random(seed)``: (state_high, state_low, inc_high, inc_low).

    ``pool`` (4,) and ``words`` (8,) uint32 are scratch space.
    """
    hash_const = INIT_A
    for i in range(4):  # SeedSequence.mix_entropy over the entropy [seed]
        word = np.uint32(seed) if i == 0 else np.uint32(0)
        pool[i], hash_const = _hashmix(word, hash_const)
    for i_src in range(4):
        for i_dst in range(4):
            if i_src != i_dst:
                mixed, hash_const = _hashmix(pool[i_src], hash_const)
                pool[i_dst] = _mix(pool[i_dst], mixed)
    hash_const = INIT_B
    for i in range(8):  # generate_state(4, uint64)
        value = pool[i % 4] ^ hash_const
        hash_const = np.uint32(hash_const * MULT_B)
        value = np.uint32(value * hash_const)
        value ^= value >> np.uint32(16)
        words[i] = value
    val0 = np.uint64(words[0]) | (np.uint64(words[1]) << np.uint64(32))
    val1 = np.uint64(words[2]) | (np.uint64(words[3]) << np.uint64(32))
    val2 = np.uint64(words[4]) | (np.uint64(words[5]) << np.uint64(32))
    val3 = np.uint64(words[6]) | (np.uint64(words[7]) << np.uint64(32))
    # pcg64_set_seed: initstate = (val0, val1), initseq = (val2, val3) as (high, low)
    inc_hi = (val2 << np.uint64(1)) | (val3 >> np.uint64(63))
    inc_lo = (val3 << np.uint64(1)) | np.uint64(1)
    s_hi, s_lo = _step(np.uint64(0), np.uint64(0), inc_hi, inc_lo)
    low = s_lo + val1
    s_hi = s_hi + val0 + (np.uint64(1) if low < s_lo else np.uint64(0))
    s_lo = low
    s_hi, s_lo = _step(s_hi, s_lo, inc_hi, inc_lo)
    return s_hi, s_lo, inc_hi, inc_lo


@numba.njit(cache=True)
def next_double(generator):
    """``Generator.random()``: the next U[0, 1) double of a generator, advanced in place.

    Parameters
    ----------
    generator : uint64 ndarray (GENERATOR_WORDS,)
        (state_high, state_low, inc_high, inc_low), as :func:`seed_generators` makes it.
    """
    s_hi, s_lo = _step(generator[0], generator[1], generator[2], generator[3])
    generator[0], generator[1] = s_hi, s_lo
    xored = s_hi ^ s_lo  # XSL-RR output
    rot = s_hi >> np.uint64(58)
    value = (xored >> rot) | (xored << ((np.uint64(64) - rot) & np.uint64(63)))
    return np.float64(value >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@numba.njit(cache=True)
def seed_generators(seeds):
    """The generators of ``np_random(seed)`` for every seed, before any draw.

    Parameters
    ----------
    seeds : int64 ndarray (K,), each in [0, 2³²)

    Returns
    -------
    ndarray (K, GENERATOR_WORDS) uint64
    """
    out = np.empty((seeds.shape[0], GENERATOR_WORDS), dtype=np.uint64)
    pool = np.empty(4, dtype=np.uint32)
    words = np.empty(8, dtype=np.uint32)
    for k in range(seeds.shape[0]):
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = seed_generator(seeds[k], pool, words)
    return out


@numba.njit(cache=True)
def draw_uniforms(generators, draws):
    """The next ``draws`` U[0, 1) doubles of every generator (advanced in place).

    Parameters
    ----------
    generators : uint64 ndarray (K, GENERATOR_WORDS), updated
    draws : int

    Returns
    -------
    ndarray (K, draws) float64
    """
    out = np.empty((generators.shape[0], draws))
    for k in range(generators.shape[0]):
        for d in range(draws):
            out[k, d] = next_double(generators[k])
    return out


def seed_uniforms(seeds: np.ndarray, draws: int) -> np.ndarray:
    """U[0, 1) doubles ``np_random(seed)`` draws first.

    Parameters
    ----------
    seeds : int64 ndarray (K,), each in [0, 2³²)
    draws : int

    Returns
    -------
    ndarray (K, draws) float64
    """
    return draw_uniforms(seed_generators(np.asarray(seeds, dtype=np.int64)), draws)
