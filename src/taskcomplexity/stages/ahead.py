"""Compute ahead: the per-task stages that read only a task's returns, in a background process, while the
chain is still at the stages before them.

A study runs its stages one after another over all its tasks (RWG of every task, then the metrics of every
task, …). No stage keeps both cores busy all the time: RWG's serial work between its parallel kernels, the
estimators' sorting and shuffling, the report's figures leave one of them idle for a part of the run. A
process started beside the chain fills that idle time: for each task in study order, as soon as the chain
has cached the task's returns, it computes the task's artefacts of every declared stage whose only input is
RWG (the metrics, the diagnostics, the movement-primitive family: :func:`ahead_stages`), by the stages' own
``run`` over a one-task plan, so under the keys the chain will look up. It runs at the lowest CPU priority
(``nice`` 19): it takes the cores only when the chain leaves them idle, and does not slow the chain's own
stages.

Nothing about the results depends on it: an artefact is the same whichever process computes it (the same
function of the same inputs, under the same key), and the cache's per-key lock lets exactly one of the two
compute it while the other waits and reuses it. When the chain reaches a stage, the tasks the process has
done are cache hits; the others it computes itself. The process is ended when the chain ends, however it
ends (a half-written artefact of an ended process is never served: :class:`~taskcomplexity.stages.cache.Cache`).
The run log lists what it computed.

It starts only for a study whose returns are worth it (:data:`MIN_EPISODES`; its start-up, a fresh Python
with the package imported, costs a few CPU-seconds), on a machine with more than one core, for the default
registry of metrics (a custom registry may hold functions another process cannot import), and not with
``force`` (every artefact recomputed by the chain itself).
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import queue
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Any

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.processes import start_worker
from taskcomplexity.stages.stage import Stage, StudyWork

log = logging.getLogger(__name__)

MIN_EPISODES = 2_000_000
"""The least number of RWG episodes (N × M summed over the study's tasks) for which the process starts."""
POLL_SECONDS = 0.5
"""How often the process looks for the next task's returns in the cache."""
NICENESS = 19


def ahead_stages(stages: tuple[Stage, ...], rwg: str) -> tuple[Stage, ...]:
    """The declared stages whose only input is the RWG stage ``rwg``: computable per task from its returns."""
    return tuple(stage for stage in stages if stage.inputs == (rwg,))


def worth_it(plan: Any, registry: Registry) -> bool:
    """Whether to start the process for ``plan`` (module docstring)."""
    episodes = sum(r.settings.policies * r.settings.episodes for r in plan.requests)
    return (registry is DEFAULT_REGISTRY and not plan.force and (os.cpu_count() or 1) > 1
            and episodes >= MIN_EPISODES)


@contextlib.contextmanager
def computing_ahead(plan: Any, stages: tuple[Stage, ...], rwg: str, *, registry: Registry = DEFAULT_REGISTRY,
                    start: bool | None = None) -> Iterator[None]:
    """Run the block (the chain) with the process computing ahead beside it; end the process after the block.

    Parameters
    ----------
    plan : StudyPlan
        The study's plan (its tasks, settings and cache).
    stages : tuple of Stage
        The declared stages, in order; those of :func:`ahead_stages` are computed ahead.
    rwg : str
        The name of the RWG stage, whose artefacts the process waits for.
    registry : Registry
    start : bool or None
        Start the process (True), not (False), or when :func:`worth_it` (None).
    """
    names = tuple(stage.name for stage in ahead_stages(stages, rwg))
    if not names or not (worth_it(plan, registry) if start is None else start):
        yield
        return
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: no inherited threads or locks
    done = context.Queue()
    process = context.Process(target=_work, args=(plan, names, rwg, done), name="taskcomplexity-ahead",
                              daemon=True)
    process.start()
    log.debug("computing %s ahead in process %d", ", ".join(names), process.pid)
    try:
        yield
    finally:
        if process.is_alive():
            process.terminate()
        process.join(timeout=30)
        _log_outcomes(done, names)


def _log_outcomes(done: Any, names: tuple[str, ...]) -> None:
    computed: dict[str, list[tuple[str, float]]] = {name: [] for name in names}
    while True:
        try:
            stage, task_id, seconds = done.get(timeout=0.1)
        except (queue.Empty, OSError, EOFError, ValueError):
            break
        computed[stage].append((task_id, seconds))
    parts = [f"{stage} {len(items)} task{'' if len(items) == 1 else 's'} ({sum(s for _, s in items):.0f} s)"
             for stage, items in computed.items() if items]
    if parts:
        log.info("computed ahead, beside the stages before them: %s", ", ".join(parts))
    done.close()


def _work(plan: Any, names: tuple[str, ...], rwg: str, done: Any) -> None:
    """The process: lowest priority, Ctrl-C left to the chain (which ends this process; so does the chain's death,
    :func:`~taskcomplexity.processes.start_worker`), then :func:`compute_ahead`."""
    start_worker()
    with contextlib.suppress(OSError, AttributeError):  # os.nice: POSIX only
        os.nice(NICENESS)
    from taskcomplexity.tasks.step_kernel import prepare_kernels

    prepare_kernels()
    logging.getLogger("taskcomplexity").setLevel(logging.WARNING)  # the chain's log says what this did
    compute_ahead(plan, names, rwg, done.put)


def compute_ahead(plan: Any, names: tuple[str, ...], rwg: str, computed: Callable[[tuple[str, str, float]], Any]
                  ) -> None:
    """For each task of ``plan`` in study order: wait until its RWG artefact is cached, then run each stage of
    ``names`` on it (the stage's own ``run``, on a one-task plan). ``computed((stage, task id, seconds))`` is
    called for each artefact computed here rather than found in the cache."""
    from taskcomplexity.stages import stage_log
    from taskcomplexity.stages.declared import STAGES

    outcomes = logging.getLogger(stage_log.__name__)
    handler = _Computed(computed, stage_log.OUTCOME)
    level, propagate = outcomes.level, outcomes.propagate
    outcomes.setLevel(logging.DEBUG)
    outcomes.propagate = False
    outcomes.addHandler(handler)
    try:
        stages = [stage for stage in STAGES if stage.name in names]
        for entry, request in zip(plan.entries, plan.requests, strict=True):
            returns = _wait_for_returns(plan.cache, rwg, request)
            one = replace(plan, entries=(entry,), requests=(request,))
            work = StudyWork(one, DEFAULT_REGISTRY, {rwg: {entry.id: returns}}, progress=False)
            for stage in stages:
                work.done[stage.name] = stage.run(work)
    finally:
        outcomes.removeHandler(handler)
        outcomes.setLevel(level)
        outcomes.propagate = propagate


class _Computed(logging.Handler):
    """Passes on each task a stage computed (not reused), from the per-task records of
    :class:`~taskcomplexity.stages.stage_log.StageLog`, as (stage, task, seconds)."""

    def __init__(self, computed: Callable[[tuple[str, str, float]], Any], attribute: str):
        super().__init__(logging.DEBUG)
        self.computed, self.attribute = computed, attribute

    def emit(self, record: logging.LogRecord) -> None:
        stage, task_id, hit, seconds = getattr(record, self.attribute, (None, None, True, 0.0))
        if not hit:
            self.computed((stage, task_id, seconds))


def _wait_for_returns(cache: Any, rwg: str, request: Any) -> Any:
    while True:
        if cache.path(rwg, request.key).exists():
            found = cache.lookup(rwg, request.key, request.identity())
            if found is not None:
                return found
        time.sleep(POLL_SECONDS)
