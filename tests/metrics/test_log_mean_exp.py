"""The numba log-mean-exp ℓₙ(λ) against the plain numpy definition over the whole temperature range."""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.metrics.log_mean_exp import LEAF, LEVELS, log_mean_exp
from taskcomplexity.metrics.poic import PolicyLogMeans

TEMPERATURES = np.geomspace(1e-4, 2e4, 301)
"""The default POIC range, about 36 temperatures per decade."""

# The kernel's sum has a worst-case relative error of about 1.1e-13 (the bound derived in the
# module docstring of taskcomplexity.metrics.log_mean_exp, dominated by the cancellation bound of
# its Taylor blocks), and the reference's own exp, division and pairwise sum add a few ulps. ℓ is
# the log of the sum, so its absolute error is the sum's relative error: 2e-13 covers both.
# Observed errors are ~1e-15.
TOLERANCE = 2e-13


def reference(returns: np.ndarray, temperatures: np.ndarray) -> np.ndarray:
    """The definition, ln (1/M) Σ_e exp((S[n, e] - mₙ)/λ), one numpy expression per temperature."""
    centred = returns - returns.max(axis=1, keepdims=True)
    return np.stack([np.log(np.exp(centred / t).mean(axis=1)) for t in temperatures], axis=1)


def rows(kind: str, rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """Return matrices of the kinds the kernel must handle."""
    n, m = shape
    if kind == "normal":
        return rng.normal(-100.0, 30.0, size=(n, 1)) + rng.lognormal(np.log(5.0), 1.0, size=(n, 1)) * rng.standard_normal(shape)
    if kind == "integer":  # sparse rewards: few distinct values, most repeated
        return -rng.binomial(50, rng.uniform(0.0, 1.0, size=(n, 1)), size=shape).astype(np.float64)
    if kind == "heavy_tailed":  # Cauchy rows: a few far outliers stretch every block
        return rng.standard_cauchy(shape) * rng.uniform(0.1, 100.0, size=(n, 1))
    if kind == "constant":
        return np.full(shape, -7.25)
    if kind == "mixed_scales":  # spans from 1e-9 to 1e5 in one matrix, a few ties
        scale = 10.0 ** rng.uniform(-9, 5, size=(n, 1))
        values = scale * rng.standard_normal(shape)
        values[:, : m // 4] = values[:, :1]
        return values
    raise ValueError(kind)


KINDS = ("normal", "integer", "heavy_tailed", "constant", "mixed_scales")
# M = 2, 3, a leaf minus one, a few leaves, the published 500 and more than the largest block (512).
SHAPES = ((40, 2), (40, 3), (30, LEAF - 1), (30, 37), (12, 500), (4, 1500))


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: f"{s[0]}x{s[1]}")
@pytest.mark.parametrize("kind", KINDS)
def test_log_means_equal_the_numpy_definition(kind, shape):
    returns = rows(kind, np.random.default_rng(sum(map(ord, kind)) + shape[1]), shape)
    values = PolicyLogMeans(returns).evaluate(TEMPERATURES)
    expected = reference(returns, TEMPERATURES)
    assert np.all((values <= 0.0) & (values >= -np.log(shape[1]) - TOLERANCE))
    np.testing.assert_allclose(values, expected, rtol=0, atol=TOLERANCE)


def test_both_storage_paths_agree():
    # Integer rows are stored as distinct values with multiplicities; the same rows with one entry
    # per episode (empty weights) must give the same ℓ.
    returns = rows("integer", np.random.default_rng(3), (25, 300))
    centred = returns - returns.max(axis=1, keepdims=True)
    ordered = np.ascontiguousarray(np.sort(centred, axis=1)[:, ::-1])
    indptr = np.arange(26, dtype=np.int64) * 300
    per_episode = log_mean_exp(ordered.ravel(), np.empty(0), indptr, 300, TEMPERATURES)
    np.testing.assert_allclose(PolicyLogMeans(returns).evaluate(TEMPERATURES), per_episode, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(per_episode, reference(returns, TEMPERATURES), rtol=0, atol=TOLERANCE)


def test_every_block_level_is_exercised_on_long_rows():
    # With M = 1500 the largest blocks (512 values) are used at large λ and leaves at small λ;
    # temperatures beyond the published range check the limits ℓ -> ln(mean) and ℓ -> -ln M·(share).
    assert LEAF << (LEVELS - 1) < 1500
    returns = rows("normal", np.random.default_rng(8), (3, 1500))
    temperatures = np.geomspace(1e-7, 1e9, 97)
    np.testing.assert_allclose(
        PolicyLogMeans(returns).evaluate(temperatures), reference(returns, temperatures), rtol=0, atol=TOLERANCE
    )


def test_ties_at_the_best_return_give_the_exact_small_temperature_limit():
    # As λ -> 0 only the returns equal to the row's best survive: ℓ = ln(count of ties / M).
    returns = np.array([[0.0, 0.0, -1.0, -2.0, -3.0], [5.0, 4.0, 4.0, 4.0, 4.0]])
    values = PolicyLogMeans(returns).evaluate(np.array([1e-4, 1e-3]))
    np.testing.assert_allclose(values, np.log([[2 / 5, 2 / 5], [1 / 5, 1 / 5]]), rtol=0, atol=1e-15)


def test_no_temperatures_and_single_rows():
    source = PolicyLogMeans(np.array([[1.0, 2.0], [3.0, 3.0]]))
    assert source.evaluate(np.empty(0)).shape == (2, 0)
    np.testing.assert_allclose(source.evaluate(np.array([1.0]))[:, 0], [np.log((np.exp(-1) + 1) / 2), 0.0], atol=1e-15)


PINNED_TEMPERATURES = np.ldexp(np.tile([1.0, 1.5], 24), np.repeat(np.arange(-10, 14), 2))
"""48 temperatures from 2⁻¹⁰ ≈ 1e-3 to 1.5·2¹³ ≈ 1.2e4, exact in binary: no libm or vector kernel computes them
(``np.geomspace`` does, and NumPy's AVX-512 and AVX2 ``power`` differ in the last bit of some of its values)."""


@pytest.mark.parametrize(("kind", "digest"), [("continuous", "fd53fccbaa3c4d96"), ("integer", "36f199f709d34ac7")])
def test_the_kernel_arithmetic_is_pinned(kind, digest):
    # A golden digest of ℓ on fixed rows (every block level, both storage paths): a change that only
    # reorganises the kernel (e.g. bit operations for the block search) must keep every bit; one that moves
    # the numbers changes this digest and needs a new version and key (design.md, Performance). The inputs
    # are CPU-independent (NumPy's generators are scalar code, the temperatures exact), and the kernel's
    # arithmetic is glibc's scalar exp and log and the fused multiply-adds its fastmath contract asks for:
    # the same bits on every x86-64 CPU with FMA, AVX2 or AVX-512 alike (CI runs both paths).
    import hashlib

    from cpu_paths import numba_target

    if "+fma" not in numba_target()[1]:
        pytest.skip("the digest is of x86-64 with FMA; without it no multiply-add is fused (the tests above "
                    f"hold the values to {TOLERANCE} of the definition)")
    rng = np.random.default_rng(2024)
    continuous = rng.normal(-50.0, 20.0, size=(40, 1)) + rng.gamma(2.0, 5.0, size=(40, 600)) * -1.0
    integer = -np.round(rng.uniform(0, 50, size=(40, 1)) * rng.uniform(0.5, 1.0, size=(40, 600)))
    source = PolicyLogMeans(continuous if kind == "continuous" else integer)
    assert bool(source._weights.size) == (kind == "integer")
    values = source.evaluate(PINNED_TEMPERATURES)
    assert hashlib.sha256(values.tobytes()).hexdigest()[:16] == digest
