"""A backend that steps Python environments on several processes (``rwg.workers``): each worker runs whole chunks.

A chunk's returns depend only on (task, policy n, episode e, seed), so chunks run on any worker, in any order, give
the returns one process gives. The backends whose chunks run on workers declare it
(:attr:`taskcomplexity.rwg.backends.Backend.worker_processes`: ``gym``, ``vector``); the others run in one process.
Workers start the platform's way (``fork`` on Linux, so an env registered by the calling script is registered in
them too, and a worker costs no new interpreter), whatever a library imported earlier set as multiprocessing's
global default (importing TorchRL sets ``spawn``; a SAC run, or a test, before the RWG stage imports it). As
PyTorch's data-loader workers do, they run their policies' forward pass on one thread (a forked OpenMP pool is not
used); each opens the backend's runner once for the whole run (the ``gym`` backend's pool of
environments), so W workers keep W cores stepping environments.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool

import torch
from threadpoolctl import threadpool_limits

from taskcomplexity.cores import usable_cores
from taskcomplexity.errors import WorkerLost
from taskcomplexity.policies.families import FamilySpec
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.processes import start_worker, stop_pool
from taskcomplexity.rwg.backends import BACKENDS, Runner
from taskcomplexity.rwg.batch import simulate_chunk
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.tasks.base import Task

_RUNNER: Runner | None = None
"""The backend's runner of this worker process (opened by :func:`_start`)."""


def platform_start_method() -> str:
    """The platform's own default start method (``fork`` on Linux before Python 3.14), which the first of
    :func:`multiprocessing.get_all_start_methods` is, not the global default a library may have set."""
    return multiprocessing.get_all_start_methods()[0]


def worker_count(settings: RWGSettings, chunks: int) -> int:
    """Processes to step ``chunks`` chunks: ``rwg.workers`` (0: one per usable core), at most one per chunk."""
    return max(1, min(settings.workers or usable_cores(), chunks))


def _start(task: Task, backend: str) -> None:
    global _RUNNER
    start_worker()
    torch.set_num_threads(1)
    threadpool_limits(limits=1)
    _RUNNER = BACKENDS[backend].open(task)
    atexit.register(_RUNNER.close)


def _chunk(task: Task, network: FamilySpec, prior: PriorSpec, settings: RWGSettings, backend: str, start: int,
           stop: int) -> ReturnChunk:
    return simulate_chunk(task, network, prior, settings, start, stop, backend=backend, runner=_RUNNER)


def run_on_workers(task: Task, network: FamilySpec, prior: PriorSpec, settings: RWGSettings, backend: str,
                   keys: Sequence[tuple[int, int]], workers: int,
                   done: Callable[[tuple[int, int], ReturnChunk], None]) -> None:
    """Run the chunks ``keys`` ([start, stop) policy ranges) on ``workers`` processes; ``done(key, chunk)`` is
    called in this process as each finishes (in the order they finish). An error in a worker (an env check's
    refusal, a bug) cancels the chunks not started, lets the running ones finish and hands them to ``done`` (so
    nothing computed is lost), then is raised here. A worker that dies (killed, out of memory) is one
    :class:`~taskcomplexity.errors.WorkerLost` naming the chunks saved; an interrupt (Ctrl-C, ``SIGTERM``) stops
    the workers at once (:func:`~taskcomplexity.processes.stop_pool`): the chunks they held are computed again by
    the rerun."""
    context = multiprocessing.get_context(platform_start_method())
    error: BaseException | None = None
    finished = 0
    pool = concurrent.futures.ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_start,
                                                  initargs=(task, backend))
    try:
        futures = {pool.submit(_chunk, task, network, prior, settings, backend, *key): key for key in keys}
        for future in concurrent.futures.as_completed(futures):
            if future.cancelled():
                continue
            failed = future.exception()
            if failed is None:
                done(futures[future], future.result())
                finished += 1
            elif error is None:
                error = failed
                for other in futures:
                    other.cancel()  # those not started; the running ones finish and are kept
    except BaseException:
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)
    if isinstance(error, BrokenProcessPool):
        raise WorkerLost(f"an RWG worker process of {task.env_id} died (killed, or out of memory) with "
                         f"{len(keys) - finished} of {len(keys)} chunks unfinished; the {finished} finished are "
                         "saved: rerun the same command to resume") from None
    if error is not None:
        raise error
