"""Worker processes that end with their run: the one place that starts, quiets and stops them.

Three kinds of processes work beside a run's main process: the RWG's pool of environment workers
(:mod:`taskcomplexity.rwg.workers`), SAC's runs trained at once (:func:`taskcomplexity.stages.sac_stage.train_at_once`)
and the stages computed ahead (:mod:`taskcomplexity.stages.ahead`). Each calls :func:`start_worker` first, so that

- it dies with the main process whatever ends it, ``kill -9`` included (Linux's parent-death signal; elsewhere a
  thread that watches the parent), and never lives on as an orphan holding memory and a core;
- Ctrl-C, which the terminal sends to the whole process group, is the main process's to handle: a worker ignores
  it and is stopped by the main process, so one line is printed, not one traceback per worker;
- ``SIGTERM`` (what :func:`stop_pool` sends) ends it at once, without the main process's handler
  (:class:`taskcomplexity.cli.Terminated`).

The semaphores a stopped worker held (torchrl's replay buffers keep their counters in shared memory) are removed by
multiprocessing's resource tracker when the run ends, as it is built to; :func:`quiet_tracker` keeps the tracker from
also printing a warning about each of them on the interrupt path.

The main process stops its workers at once on an interrupt (:func:`stop_pool`), rather than waiting for the
chunks and runs they hold, and names a worker that died in one line
(:class:`~taskcomplexity.errors.WorkerLost`).
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import Executor

_PR_SET_PDEATHSIG = 1
"""``prctl`` option: the signal this process gets when the thread that started it ends (Linux)."""


def start_worker() -> None:
    """Make this worker process end with its parent and leave Ctrl-C to it (module docstring). Call it first in a
    worker's initializer or target."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = multiprocessing.parent_process()
    parent_pid = parent.pid if parent is not None else os.getppid()
    if not _parent_death_signal():
        threading.Thread(target=_watch_parent, args=(parent_pid,), name="taskcomplexity-watch-parent",
                         daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before the signal was armed
        os._exit(1)


def _parent_death_signal() -> bool:
    """Arm ``SIGKILL`` on the parent's death (Linux's ``prctl(PR_SET_PDEATHSIG)``); False where there is none."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent_pid: int, every: float = 1.0) -> None:
    while os.getppid() == parent_pid:
        time.sleep(every)
    os._exit(1)


_TRACKER_WARNING = "ignore::UserWarning:multiprocessing.resource_tracker"
"""A ``PYTHONWARNINGS`` filter of the tracker's warnings: the count of the semaphores it removes for workers that
were stopped. (Its one other warning, a semaphore it could not remove, shares the message's prefix, and a
``PYTHONWARNINGS`` message may not hold the colon that follows it: both are filtered.)"""


def quiet_tracker() -> None:
    """Entry points call it first (:func:`taskcomplexity.cli.one_line_errors`): the resource tracker, started with
    the process's first semaphore (a progress bar's lock) and reading ``PYTHONWARNINGS`` then, removes a stopped
    worker's semaphores without a warning."""
    current = os.environ.get("PYTHONWARNINGS", "")
    if _TRACKER_WARNING not in current.split(","):
        os.environ["PYTHONWARNINGS"] = ",".join(filter(None, [current, _TRACKER_WARNING]))


def stop_pool(pool: Executor, grace: float = 5.0) -> None:
    """Stop a process pool now (the interrupt path: what its workers finished is already saved): its queued work is
    dropped, each worker gets ``SIGTERM`` whatever it runs, and one still alive ``grace`` seconds later (inside a
    long native call) is killed. The pool's process table is read as Python 3.14's ``terminate_workers`` does."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            process.terminate()
    deadline = time.monotonic() + grace
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError, AssertionError):
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.kill()
    pool.shutdown(wait=True, cancel_futures=True)  # its workers are gone: this closes its queues
