"""The CPU code paths the numerical libraries choose, and a command run on the AVX2 path of an AVX-512 machine.

numba compiles for the host CPU, NumPy dispatches its loops by the CPU's features, torch picks its ATen kernels
by its capability, and the BLAS libraries (NumPy's and SciPy's OpenBLAS, torch's MKL and oneDNN) pick theirs by
core type.
A result that differs between an AVX2 laptop and an AVX-512 server comes from one of these choices, so CI runs
the tests that pin numbers twice: natively, and under :func:`avx2_environment`, which asks each library for its
AVX2 path. On an AVX2 machine the second run would take the path it already has, so CI skips it there
(``--above-avx2`` tells). Run a command on that path::

    .venv/bin/python tests/cpu_paths.py -- .venv/bin/python -m pytest tests/golden

:func:`describe` names the kernels a process uses; ``conftest.py`` prints it in pytest's summary.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

AVX2_TARGET = "haswell"
"""The LLVM CPU numba compiles for on the AVX2 path: AVX2 with FMA, no AVX-512 (what AVX2 laptops and most
cloud VMs run)."""
WIDER_THAN_AVX2 = ("avx512", "amx", "avx10", "evex512")
"""LLVM feature names of the instruction sets above AVX2, switched off for numba on the AVX2 path."""
NUMPY_AVX512 = "X86_V4 AVX512F AVX512CD AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR"
"""NumPy's AVX-512 dispatch targets (its builds name them as groups, ``X86_V4``, or one by one)."""


def _numba_features() -> str:
    """The host's LLVM features with every instruction set above AVX2 switched off."""
    from llvmlite import binding

    features = binding.get_host_cpu_features()
    return ",".join(("-" if name.startswith(WIDER_THAN_AVX2) else "+" if on else "-") + name
                    for name, on in sorted(features.items()))


def _numpy_avx512_targets() -> str:
    """The names of :data:`NUMPY_AVX512` that this NumPy build dispatches to (it refuses unknown names)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__

    return " ".join(name for name in NUMPY_AVX512.split() if name in __cpu_dispatch__)


def above_avx2() -> list[str]:
    """The host's instruction sets above AVX2 (LLVM feature names starting with one of :data:`WIDER_THAN_AVX2`):
    empty on an AVX2 machine, whose native path is the AVX2 path."""
    from llvmlite import binding

    return sorted(name for name, on in binding.get_host_cpu_features().items()
                  if on and name.startswith(WIDER_THAN_AVX2))


def avx2_environment(numba_cache: str) -> dict[str, str]:
    """Environment variables that put numba, NumPy, torch, OpenBLAS, MKL and oneDNN on their AVX2 paths.

    ``numba_cache`` is a directory for numba's cache: kernels compiled for the host must not be loaded.
    """
    return {
        "NUMBA_CPU_NAME": AVX2_TARGET,
        "NUMBA_CPU_FEATURES": _numba_features(),
        "NUMBA_CACHE_DIR": numba_cache,
        "NPY_DISABLE_CPU_FEATURES": _numpy_avx512_targets(),
        "ATEN_CPU_CAPABILITY": "avx2",
        "OPENBLAS_CORETYPE": "Haswell",
        "MKL_ENABLE_INSTRUCTIONS": "AVX2",
        "ONEDNN_MAX_CPU_ISA": "AVX2",
    }


def numba_target() -> tuple[str, str]:
    """The CPU name and LLVM features numba compiles for in this process (``NUMBA_CPU_*`` or the host's)."""
    from numba.core.codegen import JITCPUCodegen

    codegen = JITCPUCodegen("target")
    return codegen._get_host_cpu_name(), codegen._get_host_cpu_features()


def describe() -> str:
    """The kernels this process computes with: numba's target, NumPy's dispatch, torch's capability, the BLAS."""
    import numba
    import numpy as np
    import torch
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    from threadpoolctl import threadpool_info

    name, features = numba_target()
    numpy_targets = [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]
    blas = [f"{i['internal_api']} {i.get('architecture') or ''}".strip() for i in threadpool_info()
            if i["user_api"] == "blas"]
    return (f"numba {numba.__version__}: {name}, AVX-512 {'on' if '+avx512f' in features else 'off'}; "
            f"NumPy {np.__version__} dispatches to {', '.join(numpy_targets) or 'its baseline only'}; "
            f"torch {torch.__version__}: {torch.backends.cpu.get_cpu_capability()}; "
            f"BLAS: {', '.join(blas) or 'none loaded'}")


def main(argv: list[str]) -> int:
    if argv == ["--above-avx2"]:  # exit 0 and name them where the host has instruction sets above AVX2, else 1
        wider = above_avx2()
        print(" ".join(wider) or "none: the native path is the AVX2 path")
        return 0 if wider else 1
    parser = argparse.ArgumentParser(prog="cpu_paths.py",
                                     usage="%(prog)s [--numba-cache DIR] -- COMMAND [ARG…] | --above-avx2",
                                     description="Run COMMAND on the AVX2 path.")
    parser.add_argument("--numba-cache", metavar="DIR",
                        help="where numba caches the AVX2 kernels (default: a new temporary directory); a "
                             "directory kept between runs loads them instead of compiling them again")
    if "--" not in argv or argv.index("--") == len(argv) - 1:
        parser.error("no COMMAND after --")
    options = parser.parse_args(argv[:argv.index("--")])
    command = argv[argv.index("--") + 1:]
    cache = os.path.abspath(options.numba_cache) if options.numba_cache else tempfile.mkdtemp(prefix="numba-avx2-")
    os.makedirs(cache, exist_ok=True)
    os.environ.update(avx2_environment(cache))
    os.execvp(command[0], command)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
