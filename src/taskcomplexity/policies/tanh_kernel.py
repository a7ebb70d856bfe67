"""tanh of float64 arrays as a numba loop of the CPU's vector width: the forward pass's tanh where NumPy's is slow.

:mod:`taskcomplexity.policies.tanh` says where it runs. Its arithmetic is its own: within :data:`MAX_ULPS` units in
the last place of the exact tanh (NumPy's is within 2), the same numbers at every vector width
(``tests/policies/test_tanh.py``).

The algorithm, per value x, with a = |x| and y = 2a (clamped at :data:`CLAMP`, beyond which the result is 1 in
double precision):

- E = e^y − 1 without cancellation: e^y = 2ⁿ·e^r with n = round(y/ln 2) and r = y − n·ln 2 in two parts (Cody and
  Waite: n·LN2_HI is exact, so r carries no rounding, |r| ≤ ln 2 / 2); e^r − 1 = r + r²·P(r), P the degree-10
  polynomial (:data:`EXPM1_COEFFICIENTS`) that interpolates (e^r − 1 − r)/r² at the Chebyshev nodes of
  [−ln 2 / 2, ln 2 / 2] (fitted in 50-digit arithmetic, within 3·10⁻¹⁸ of it; ``tests/policies/test_tanh.py``
  refits it); E = 2ⁿ·(e^r − 1) + (2ⁿ − 1) in one fused multiply-add, 2ⁿ built from its exponent bits;
- tanh(a) = 1 − s with s = 2/(E + 2), where s is carried with its error: the rounding of E + 2 (Fast2Sum, exact) and
  the residual of the division (one fused multiply-add, exact) give s's next bits, so that 1 − s, exact for
  small a, keeps them;
- the sign of x is put back: NaN stays NaN, ±∞ gives ±1, −0 gives −0.

Each step is a multiply, fused multiply-add, add, divide, comparison or selection, with no branch: the compiler
turns the loop into vector instructions of the CPU's width (``NUMBA_CPU_NAME``: 4 doubles with AVX2, 8 with
AVX-512), and each value's result is the same at every width. The fused multiply-adds are IEEE's (one rounding),
so a CPU without them (where LLVM calls the C library's ``fma``) gets the same numbers, slower.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

EXPM1_COEFFICIENTS = (
    0.5, 0.1666666666666667, 0.04166666666666667, 0.008333333333326141, 0.0013888888888883752,
    0.00019841269874800493, 2.4801587325533363e-05, 2.7557255425746435e-06, 2.7557273661348637e-07,
    2.510520637395701e-08, 2.0914679376583935e-09,
)
"""P(r) = Σ cₖ rᵏ, the interpolant of (e^r − 1 − r)/r² at 11 Chebyshev nodes of [−ln 2 / 2, ln 2 / 2]."""
LN2_HI = 6.93147180369123816490e-01
"""ln 2 rounded to 32 significant bits (0x3FE62E42FEE00000): n·LN2_HI is exact for |n| < 2²⁰."""
LN2_LO = 1.90821492927058770002e-10
"""ln 2 − LN2_HI."""
LOG2_E = 1.4426950408889634
"""1/ln 2."""
CLAMP = 40.0
"""y = 2|x| beyond which tanh(x) rounds to ±1: 2/(e⁴⁰ + 1) < 10⁻¹⁷, below half the spacing of doubles under 1."""
MAX_ULPS = 2
"""The kernel's largest distance from the exact tanh, in units in the last place (tests/policies/test_tanh.py)."""


@intrinsic
def _double_from_bits(typingctx, bits):
    """The double whose IEEE bits are the int64 ``bits``."""
    if not isinstance(bits, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@intrinsic
def _fma(typingctx, a, b, c):
    """a·b + c rounded once (the CPU's fused multiply-add)."""
    if not all(isinstance(v, types.Float) for v in (a, b, c)):
        return None

    def codegen(context, builder, signature, args):
        args = [context.cast(builder, v, t, types.float64) for v, t in zip(args, signature.args, strict=True)]
        double = ir.DoubleType()
        fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(double, [double] * 3), "llvm.fma.f64")
        return builder.call(fma, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@numba.njit(inline="always", cache=True, error_model="numpy")
def _tanh(x):
    c = EXPM1_COEFFICIENTS
    a = abs(x)
    y = 2.0 * a if 2.0 * a < CLAMP else CLAMP  # NaN takes the clamp, and is put back below
    n = np.floor(y * LOG2_E + 0.5)
    r = _fma(-n, LN2_LO, _fma(-n, LN2_HI, y))
    p = c[10]
    for k in range(9, -1, -1):
        p = _fma(p, r, c[k])
    scale = _double_from_bits((np.int64(n) + 1023) << 52)
    e = _fma(scale, _fma(r * r, p, r), scale - 1.0)
    d = e + 2.0
    d_low = (max(e, 2.0) - d) + min(e, 2.0)  # e + 2 − d, exactly (Fast2Sum)
    s = 2.0 / d
    s_low = (_fma(-s, d, 2.0) - s * d_low) * (0.5 * s)  # 2/(e + 2) − s, to a few bits: 1/d = s/2
    q = (1.0 - s) - s_low
    out = math.copysign(q, x)
    return out if x == x else x


@numba.njit(nogil=True, cache=True, error_model="numpy")
def _tanh_flat(src, dst):
    for i in range(src.shape[0]):
        dst[i] = _tanh(src[i])


@numba.njit(nogil=True, cache=True, error_model="numpy")
def _tanh_in_place(values):
    # one array: the compiler's vector loop needs no check that two arrays overlap (for src is dst, _tanh_flat's
    # check fails and it runs its scalar loop)
    for i in range(values.shape[0]):
        values[i] = _tanh(values[i])


def tanh_kernel(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """tanh of every value of the float64 array ``x`` (module docstring), into ``out``.

    Parameters
    ----------
    x : ndarray of float64
    out : ndarray of float64, optional
        Same shape as ``x`` (may be ``x`` itself); a new array when omitted.

    Returns
    -------
    ndarray: ``out``.
    """
    x = np.asarray(x)
    if x.dtype != np.float64:
        raise TypeError(f"tanh_kernel computes float64, got an array of {x.dtype}")
    if out is None:
        out = np.empty_like(x, order="C")
    if out.shape != x.shape or out.dtype != np.float64:
        raise ValueError(f"out must be a float64 array of shape {x.shape}, got {out.dtype} {out.shape}")
    if out is x and x.flags.c_contiguous:
        _tanh_in_place(x.reshape(-1))
    elif x.flags.c_contiguous and out.flags.c_contiguous and not np.may_share_memory(x, out):
        _tanh_flat(x.reshape(-1), out.reshape(-1))
    else:
        result = np.empty(x.shape)
        _tanh_flat(np.ascontiguousarray(x).reshape(-1), result.reshape(-1))
        out[...] = result
    return out
