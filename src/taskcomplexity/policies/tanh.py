"""The forward pass's tanh: NumPy's where NumPy runs its AVX-512 loop, a numba kernel of the CPU's width elsewhere.

The MLPs' forward pass (:meth:`taskcomplexity.policies.mlp.PolicyBatch.act`) spends most of its time in tanh:
128 values per environment step for classic control's 2 × 64 tanh units. NumPy's float64 tanh is a vector loop
whose 16-entry coefficient lookups take one instruction with AVX-512 and a sequence of permutes without: on the
AVX2 path it costs 3.7 times its AVX-512 time per value (``bench/bench_classic.py`` measures both), while its
numbers are the same to the bit on both. Where NumPy runs its AVX-512 loop, :func:`tanh` is NumPy's, so the
returns there are what they always were; elsewhere (AVX2 laptops and most cloud VMs, ARM) it is
:func:`taskcomplexity.policies.tanh_kernel.tanh_kernel`, which runs at the CPU's vector width whatever it is and
rounds differently from NumPy in the last bits of some values (both are within 2 units in the last place of the
exact tanh, ``tests/policies/test_tanh.py``). :func:`implementation` names the one a process uses, and a network
that computes a tanh keys its results with it where it is the kernel
(:meth:`taskcomplexity.policies.mlp.NetworkSpec.identity`): no result of one is served for the other.
"""

from __future__ import annotations

import functools

import numpy as np

NUMPY = "numpy"
KERNEL = "kernel"


@functools.cache
def implementation() -> str:
    """:data:`NUMPY` where NumPy runs its AVX-512 float64 tanh in this process (the CPU has AVX-512 and
    ``NPY_DISABLE_CPU_FEATURES`` leaves it on), :data:`KERNEL` elsewhere."""
    from numpy._core._multiarray_umath import __cpu_features__

    return NUMPY if __cpu_features__.get("AVX512_SKX") else KERNEL


def tanh(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """tanh of an array, into ``out`` (may be ``x``; a new array when omitted): float64 arrays with
    :func:`implementation`'s, any other dtype with NumPy's."""
    x = np.asarray(x)
    if x.dtype == np.float64 and implementation() == KERNEL:
        from taskcomplexity.policies.tanh_kernel import tanh_kernel

        return tanh_kernel(x, out)
    return np.tanh(x, out=out)
