"""``tests/cpu_paths.py --above-avx2``: whether CI's second pass (the AVX2 path) has a path to differ from."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(not Path("/proc/cpuinfo").exists(), reason="no /proc/cpuinfo to compare with (not Linux)")
def test_above_avx2_answers_as_the_kernels_cpu_flags_do():
    """It names AVX-512's sets and exits 0 where the kernel lists ``avx512f`` among the CPU's flags, and exits 1
    saying the native path is the AVX2 path where it does not (llvmlite's reading of the CPU against Linux's)."""
    flags = next(line.split(":", 1)[1].split() for line in Path("/proc/cpuinfo").read_text().splitlines()
                 if line.startswith("flags"))
    done = subprocess.run([sys.executable, str(ROOT / "tests" / "cpu_paths.py"), "--above-avx2"],
                          capture_output=True, text=True, timeout=60)
    if "avx512f" in flags:
        assert done.returncode == 0, done.stdout + done.stderr
        assert "avx512f" in done.stdout.split()
    else:
        assert done.returncode == 1, done.stdout + done.stderr
        assert done.stdout.strip() == "none: the native path is the AVX2 path"
