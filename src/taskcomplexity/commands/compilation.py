"""Say when numba compiles the kernels, and how long it took.

Every kernel of the package is compiled with ``cache=True``: the first run after an install (or after
an upgrade that changed a kernel's source) compiles them and writes machine code to disk, later runs
load it in milliseconds. Without a word, that first compilation looks like a progress bar stuck at 0 %
for half a minute. :func:`announce_compilation` listens to numba's ``numba:compile`` event, which numba
fires only on a cache miss (a real compilation, never a load from disk), and prints one line when the
first compilation of the run starts; the total goes to the run log when the run ends (the console's last
line stays the report's path).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from numba.core import event

from taskcomplexity.report.format import plural

log = logging.getLogger(__name__)

FIRST_RUN_SECONDS = 45
"""Seconds of compilation of a first ``experiment=smoke`` run on a 2-core machine; every kernel a study uses,
compiled once per install (measured from a fresh clone: 19 kernels in 42 s; docs/tutorials/reproduce-the-paper.md)."""


def cache_location() -> str:
    """Where numba writes the compiled kernels: ``NUMBA_CACHE_DIR`` or ``__pycache__`` beside the sources."""
    import numba

    if numba.config.CACHE_DIR:
        return str(Path(numba.config.CACHE_DIR).resolve())
    return f"the __pycache__ folders of {Path(__file__).resolve().parents[1]}"


class CompilationLog(event.Listener):
    """numba's ``numba:compile`` events of one run: announced at the first, summed to the last.

    Attributes
    ----------
    kernels : int
        Functions compiled (outermost compilations; the ones they pull in are counted in their time).
    seconds : float
        Wall time spent compiling, s.
    """

    def __init__(self, write: Callable[[str], None]):
        self._write = write
        self._depth = 0
        self._started = 0.0
        self.kernels = 0
        self.seconds = 0.0

    def on_start(self, event) -> None:
        """A compilation starts (numba calls this; nested ones too)."""
        if self._depth == 0:
            if self.kernels == 0:
                self._write(f"compiling the numba kernels, once per install: about {FIRST_RUN_SECONDS} s in all "
                            f"on 2 cores (cached in {cache_location()}; later runs load them)")
            self._started = time.perf_counter()
        self._depth += 1

    def on_end(self, event) -> None:
        """A compilation ends."""
        self._depth -= 1
        if self._depth == 0:
            self.kernels += 1
            self.seconds += time.perf_counter() - self._started

    def summary(self) -> str | None:
        """One line on what was compiled in the run (None if nothing was)."""
        if not self.kernels:
            return None
        return (f"numba compiled {plural(self.kernels, 'kernel')} in {self.seconds:.0f} s; "
                "they are cached on disk and load instantly in later runs")


@contextmanager
def announce_compilation(write: Callable[[str], None] | None = None) -> Iterator[CompilationLog]:
    """Within the block, numba's compilations are announced once and summed; the sum goes to the run log.

    ``write`` prints the announcement (default: ``tqdm.write``, which keeps open progress bars intact).
    """
    from tqdm.auto import tqdm

    compiled = CompilationLog(write or (lambda line: tqdm.write(line)))
    with event.install_listener("numba:compile", compiled):
        try:
            yield compiled
        finally:
            line = compiled.summary()
            if line:
                log.debug(line)
