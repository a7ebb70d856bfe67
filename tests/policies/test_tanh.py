"""The forward pass's tanh: the numba kernel's arithmetic pinned, its accuracy, and where it replaces NumPy's.

The kernel's numbers are pinned to the bit by a digest of its values on a fixed grid: CI runs this file on both CPU
paths (``make test-avx2``), so a vector width or an instruction set that changed one bit of one value fails here.
Its accuracy is measured against the exact tanh (mpmath, 40 digits): within ``MAX_ULPS`` units in the last place,
as NumPy's float64 tanh is within 2 (measured here at 1.17, the kernel's at 1.75). Classic control's returns with
the kernel's tanh are NumPy's within ``RETURNS_RTOL`` (the reason is given there).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from taskcomplexity.policies import tanh as tanh_module
from taskcomplexity.policies.tanh_kernel import EXPM1_COEFFICIENTS, MAX_ULPS, tanh_kernel

SPECIAL = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 1e-8,
                    0.17328679513998632, 0.3465735902799726, 19.0, 19.06, 20.0, 20.000000000000004, 22.0, 1e300])
"""Zeros, infinities, NaN, subnormals, the ends of the range reduction's first intervals (ln 2 / 4, ln 2 / 2),
the last values below 1 in double precision and the clamp."""


def grid() -> np.ndarray:
    """A fixed grid, the same doubles on every CPU (built by exact operations: no NumPy ``power``, whose last bits
    depend on the instruction set): 32 values per binade from 2⁻¹⁰⁰⁰ to 2⁵, both signs, dense on [−20, 20], and
    :data:`SPECIAL`."""
    binades = np.ldexp(np.linspace(1, 2, 32, endpoint=False)[None, :], np.arange(-1000, 5)[:, None]).ravel()
    dense = np.linspace(-20, 20, 400001)
    return np.concatenate([binades, -binades, dense, SPECIAL])


def ulps(values: np.ndarray, x: np.ndarray) -> np.ndarray:
    """|values − tanh(x)| in units in the last place of the exact tanh (mpmath, 40 digits)."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 40
    out = np.empty(len(x))
    for i, (v, xi) in enumerate(zip(values, x, strict=True)):
        exact = mpmath.tanh(mpmath.mpf(float(xi)))
        spacing = np.spacing(abs(float(exact))) if exact != 0 else 5e-324
        out[i] = float(abs(mpmath.mpf(float(v)) - exact)) / spacing
    return out


def test_the_kernel_computes_the_same_bits_on_every_cpu_path():
    """A digest of the kernel's values on :func:`grid`: the same with AVX2 and AVX-512, at any vector width, and in
    the loop's scalar remainder as in its vector body (each value alone)."""
    x = grid()
    values = tanh_kernel(x)
    one_at_a_time = np.array([tanh_kernel(x[i : i + 1])[0] for i in range(0, len(x), 997)])
    np.testing.assert_array_equal(one_at_a_time, values[::997])
    digest = hashlib.sha256(values.tobytes()).hexdigest()[:16]
    assert digest == "7f51e994bff2bc1a", f"the kernel's values on the grid changed: digest {digest}"


def test_the_kernel_is_within_its_bound_of_the_exact_tanh_as_numpy_is_within_2():
    rng = np.random.default_rng(0)
    x = np.concatenate([10.0 ** rng.uniform(-12, 1.31, 6000), rng.uniform(0, 1.5, 6000), SPECIAL[5:]])
    x = x[np.isfinite(x)]
    x = np.concatenate([x, -x])
    kernel, numpy = ulps(tanh_kernel(x), x), ulps(np.tanh(x), x)
    assert kernel.max() <= MAX_ULPS, f"{kernel.max():.2f} ulp at x = {x[kernel.argmax()]!r}"
    assert numpy.max() <= 2  # the bound the kernel is held to is NumPy's own
    assert kernel.mean() < 0.4  # mostly correctly rounded, as NumPy's (0.31 ulp on average here)


def test_the_kernel_keeps_zeros_signs_infinities_and_nan():
    values = tanh_kernel(SPECIAL)
    np.testing.assert_array_equal(values[:4], [0.0, -0.0, 1.0, -1.0])
    assert np.signbit(values[1]) and not np.signbit(values[0])
    assert np.isnan(values[4])
    assert values[5] == 5e-324 and values[6] == -5e-324  # tanh(x) = x below 10⁻⁸
    np.testing.assert_array_equal(values[-4:], 1.0)
    assert values[SPECIAL == 19.0][0] < 1.0  # tanh(19) is the double below 1


def test_the_kernel_writes_in_place_and_into_any_layout():
    x = np.random.default_rng(1).normal(0, 3, (5, 7, 3))
    expected = tanh_kernel(x.copy())
    strided = np.asfortranarray(x)
    out = np.empty_like(x)
    np.testing.assert_array_equal(tanh_kernel(strided, out), expected)
    y = x.copy()
    assert tanh_kernel(y, y) is y
    np.testing.assert_array_equal(y, expected)
    with pytest.raises(TypeError, match="float64"):
        tanh_kernel(x.astype(np.float32))


@pytest.mark.parametrize("mpmath_digits", [50])
def test_the_polynomial_is_the_chebyshev_interpolant_of_expm1(mpmath_digits):
    """Refit P: the interpolant of (e^r − 1 − r)/r² at 11 Chebyshev nodes of [−ln 2 / 2, ln 2 / 2]."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = mpmath_digits
    half = mpmath.log(2) / 2
    n = len(EXPM1_COEFFICIENTS)
    nodes = [half * mpmath.cos(mpmath.pi * (k + mpmath.mpf(1) / 2) / n) for k in range(n)]

    def f(r):  # its Taylor series near 0, where the quotient would cancel
        return mpmath.mpf(1) / 2 + r / 6 if abs(r) < mpmath.mpf(10) ** -30 else (mpmath.expm1(r) - r) / r**2

    matrix = mpmath.matrix([[t**j for j in range(n)] for t in nodes])
    coefficients = mpmath.lu_solve(matrix, mpmath.matrix([f(t) for t in nodes]))
    assert tuple(float(c) for c in coefficients) == EXPM1_COEFFICIENTS
    error = max(abs(sum(c * t**j for j, c in enumerate(coefficients)) - f(t)) / f(t)
                for t in mpmath.linspace(-half, half, 401))
    assert error < 3e-18  # the docstring's bound; half an ulp of P's smallest value is 5e-17


def test_tanh_is_numpys_where_numpy_has_its_avx512_loop_and_the_kernels_elsewhere():
    x = np.random.default_rng(2).normal(0, 3, 1000)
    values = tanh_module.tanh(x)
    if tanh_module.implementation() == tanh_module.NUMPY:
        np.testing.assert_array_equal(values, np.tanh(x))
    else:
        np.testing.assert_array_equal(values, tanh_kernel(x))
    np.testing.assert_array_equal(tanh_module.tanh(x.astype(np.float32)), np.tanh(x.astype(np.float32)))


def test_a_process_without_numpys_avx512_loop_takes_the_kernel_and_keys_its_networks_with_it():
    """NumPy's AVX-512 loop switched off (as on the AVX2 path): the kernel computes, and an MLP's identity, hence
    every key that holds it, says so; with the loop (or on this machine, if it has none) nothing changes."""
    from numpy._core._multiarray_umath import __cpu_dispatch__

    script = ("from taskcomplexity.policies.tanh import implementation; from taskcomplexity.policies.mlp import "
              "NetworkSpec; print(implementation(), NetworkSpec().identity().get('tanh'))")
    disabled = " ".join(n for n in ("X86_V4", "AVX512F", "AVX512CD", "AVX512_SKX") if n in __cpu_dispatch__)
    env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": disabled}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == ["kernel", "kernel"]
    assert ("tanh" in __import__("taskcomplexity.policies.mlp").policies.mlp.NetworkSpec().identity()) == (
        tanh_module.implementation() == tanh_module.KERNEL)


RETURNS_RTOL = 1e-12
"""How far classic control's returns may move when the forward pass's tanh is the kernel's instead of NumPy's.
The two differ by at most 2 units in the last place of some hidden units (1e-16 relative); an action is the argmax
of the outputs (Discrete: it changes only on a tie to 1e-16) or the float32 of tanh(output) (Box: a float64
difference of 1e-16 moves the float32 with probability about 2⁻²⁹ per step). Measured: every return of these runs
is the same to the bit; the bound allows a rare moved action, and is 10⁶ times below any change of a setting or a
seed."""


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Pendulum-v1", "MountainCarContinuous-v0", "Acrobot-v1"])
def test_classic_returns_with_the_kernels_tanh_are_numpys(env_id, monkeypatch):
    import torch

    from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
    from taskcomplexity.rwg.kernel_backend import run_kernel
    from taskcomplexity.tasks.gym_task import GymTask

    task = GymTask(env_id)
    network = NetworkSpec(hidden=(64, 64), activation="tanh", output="linear")
    returns = {}
    for kind in (tanh_module.NUMPY, tanh_module.KERNEL):
        monkeypatch.setattr(tanh_module, "implementation", lambda kind=kind: kind)
        with torch.no_grad(), network.sample(task, PriorSpec(), 0, np.arange(24)) as policies:
            returns[kind] = run_kernel(task, policies, seed=0, episodes=6)[0]
    np.testing.assert_allclose(returns[tanh_module.KERNEL], returns[tanh_module.NUMPY], rtol=RETURNS_RTOL)


def test_this_file_is_pinned_on_both_cpu_paths():
    makefile = (Path(__file__).parents[2] / "Makefile").read_text()
    assert "tests/policies/test_tanh.py" in makefile.partition("PINNED_TESTS :=")[2].partition("\n\n")[0]
