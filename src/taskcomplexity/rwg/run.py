"""Algorithm 1 over a shard's policies: sample each chunk from the family, run its episodes on the backend.

:func:`run_rwg` resolves the backend (refusing one the task or the family cannot run, before any work), splits
the shard into chunks (:mod:`taskcomplexity.rwg.chunking`) and runs each through
:func:`taskcomplexity.rwg.batch.simulate_chunk` (on a pool of ``rwg.workers`` processes where the backend steps
Python environments, :mod:`taskcomplexity.rwg.workers`), which samples the chunk's policies
(:func:`taskcomplexity.policies.families.sample_family`) and hands them to the backend's runner
(:func:`taskcomplexity.rwg.batch.run_batch`), opened once for the run.
"""

from __future__ import annotations

from collections.abc import Callable

from threadpoolctl import threadpool_limits

from taskcomplexity.policies.families import FamilySpec
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.progress import Progress, progress_bar
from taskcomplexity.rwg.backends import BACKENDS, resolve_backend
from taskcomplexity.rwg.batch import simulate_chunk
from taskcomplexity.rwg.chunking import ReturnChunk, chunks
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.rwg.workers import run_on_workers, worker_count
from taskcomplexity.tasks.base import Task


def run_rwg(
    task: Task,
    network: FamilySpec,
    prior: PriorSpec,
    settings: RWGSettings,
    backend: str = "auto",
    *,
    completed: dict[tuple[int, int], ReturnChunk] | None = None,
    on_chunk: Callable[[tuple[int, int], ReturnChunk], None] | None = None,
    progress: Progress = False,
) -> ReturnChunk:
    """Algorithm 1 over this shard's policies.

    Parameters
    ----------
    task : Task
    network : FamilySpec
        The policy family (``network.*``).
    prior : PriorSpec
    settings : RWGSettings
    backend : str
        ``auto`` or one of :data:`taskcomplexity.rwg.backends.BACKENDS`; one the task or the family cannot run
        is refused (:class:`~taskcomplexity.errors.ConfigError`) before any work.
    completed : dict, optional
        Chunks already computed (by an interrupted run), keyed by (start, stop); they are reused.
    on_chunk : callable, optional
        Called with each newly computed chunk (e.g. to save it for resumption).
    progress : bool or tqdm
        Show a bar over environment episodes, or advance a study stage's bar
        (:mod:`taskcomplexity.progress`).

    Returns
    -------
    ReturnChunk
        The shard's returns (P, M), policies in order.
    """
    settings.validate()
    backend = resolve_backend(task, backend, network)
    completed = dict(completed or {})
    ranges = chunks(task, network, settings, backend)
    total = sum(b - a for a, b in ranges) * settings.episodes
    bar = progress_bar(progress, total=total, unit="ep", desc=f"rwg {task.task_id} [{backend}]", smoothing=0.1)
    pending = [key for key in ranges if key not in completed]
    declared = BACKENDS[backend]
    workers = worker_count(settings, len(pending)) if declared.worker_processes else 1
    runner = declared.open(task) if workers == 1 and pending else None

    def done(key: tuple[int, int], chunk: ReturnChunk) -> None:
        completed[key] = chunk
        if on_chunk is not None:
            on_chunk(key, chunk)
        bar.update((key[1] - key[0]) * settings.episodes)

    bar.update(sum(b - a for a, b in ranges if (a, b) in completed) * settings.episodes)
    # The policy forward pass already runs one thread per core (PolicyBatch.act): BLAS threads inside those
    # workers would only spin against them. One BLAS thread per worker computes the same products.
    blas = threadpool_limits(limits=1, user_api="blas")
    try:
        if workers > 1:  # Python environments: the chunks on a pool of processes, each stepping its own
            run_on_workers(task, network, prior, settings, backend, pending, workers, done)
        for key in pending:
            if key not in completed:
                done(key, simulate_chunk(task, network, prior, settings, *key, backend=backend,
                                         progress=progress is True, runner=runner))
    finally:
        blas.restore_original_limits()
        bar.close()
        if runner is not None:
            runner.close()
    return ReturnChunk.concatenate([completed[k] for k in ranges])
