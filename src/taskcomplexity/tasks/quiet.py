"""Silence a C library's writes to the process's standard streams for the span of a ``with`` block.

PyBullet prints its build time to standard error when imported and ``argv[0]=`` to standard output on
every connection, from C, so Python's ``sys.stdout`` redirection cannot catch them; this redirects the
file descriptors themselves. What Python code printed before the block is flushed first.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys


@contextlib.contextmanager
def c_output_silenced(*fds: int):
    """Send everything written to the file descriptors ``fds`` (default: 1, standard output) inside the
    block to ``/dev/null``; a descriptor that is not open is left alone."""
    fds = fds or (1,)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = {}
    try:
        with open(os.devnull, "wb") as null:
            for fd in fds:
                try:
                    saved[fd] = os.dup(fd)
                except OSError:  # not open (a daemonised worker): nothing to silence
                    continue
                os.dup2(null.fileno(), fd)
        yield
    finally:
        ctypes.CDLL(None).fflush(None)  # C's buffered writes go to /dev/null, not to the restored stream
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
