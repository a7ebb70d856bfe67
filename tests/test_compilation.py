"""The numba compilation announcement (taskcomplexity.commands.compilation)."""

import logging

import numba
import numpy as np

from taskcomplexity.commands.compilation import FIRST_RUN_SECONDS, announce_compilation


def _fresh_kernels():
    """Two njit functions no process has compiled yet (new objects each call), one calling the other."""

    @numba.njit
    def inner(x):
        return x * 2.0

    @numba.njit
    def outer(a):
        total = 0.0
        for v in a:
            total += inner(v)
        return total

    return inner, outer


def test_first_compilation_is_announced_once_and_summed(caplog):
    inner, outer = _fresh_kernels()
    lines = []
    with caplog.at_level(logging.DEBUG, logger="taskcomplexity"):
        with announce_compilation(lines.append) as compiled:
            assert outer(np.arange(4.0)) == 12.0   # compiles outer, and inner inside it
            assert outer(np.arange(3.0)) == 6.0    # same types: no compilation
            assert inner(2) == 4                   # new argument types: a compilation of its own
    assert len(lines) == 1
    assert "once per install" in lines[0] and f"about {FIRST_RUN_SECONDS} s" in lines[0]
    # inner compiled inside outer counts in outer's time: two outermost compilations
    assert compiled.kernels == 2
    assert compiled.seconds > 0
    assert any("numba compiled 2 kernels in" in r.getMessage() for r in caplog.records)


def test_nothing_said_when_nothing_compiles(caplog):
    inner, outer = _fresh_kernels()
    outer(np.arange(2.0))  # compiled before the block
    lines = []
    with caplog.at_level(logging.DEBUG, logger="taskcomplexity"):
        with announce_compilation(lines.append) as compiled:
            outer(np.arange(5.0))
    assert lines == [] and compiled.kernels == 0 and compiled.summary() is None
    assert not any("numba compiled" in r.getMessage() for r in caplog.records)
