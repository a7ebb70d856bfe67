"""What a study's stage says: one DEBUG line per task (the run log), one INFO summary (the console); and the
loop over a study's tasks that every per-task stage runs (:func:`each_task`)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from typing import Any, TypeVar

from tqdm.auto import tqdm

from taskcomplexity.progress import stage_bar

log = logging.getLogger(__name__)

T = TypeVar("T")


OUTCOME = "task_outcome"
"""The attribute of each per-task log record that holds (stage, task, cache hit, wall seconds)."""


def outcome(hit: bool, seconds: float) -> str:
    """A stage's outcome in the one-line summaries: ``cache hit`` or ``computed in 12 s``."""
    return "cache hit" if hit else f"computed in {seconds:.0f} s"


@dataclass
class TaskOutcome:
    """One task's pass through a stage: its artefact, whether the cache held it, wall seconds."""

    name: str
    artefact: Any = None
    hit: bool = False
    seconds: float = 0.0


class StageLog:
    """The outcomes of one stage over a study's tasks, in the order the tasks ran.

    ``with log.task(name) as record:`` times the block; the block sets ``record.artefact`` and
    ``record.hit``. :meth:`summarise` logs ``rwg          7 tasks: 5 computed in 301 s, 2 cache hits``.
    """

    def __init__(self, stage: str):
        self.stage = stage
        self.records: list[TaskOutcome] = []

    @contextmanager
    def task(self, name: str) -> Iterator[TaskOutcome]:
        record = TaskOutcome(name)
        started = time.perf_counter()
        yield record
        record.seconds = time.perf_counter() - started
        self.records.append(record)
        log.debug("%-26s %s %s", name, self.stage, outcome(record.hit, record.seconds),
                  extra={OUTCOME: (self.stage, name, record.hit, record.seconds)})

    @property
    def artefacts(self) -> list[Any]:
        return [r.artefact for r in self.records]

    def summary(self) -> str:
        """The stage's one line (without the stage name)."""
        computed = [r for r in self.records if not r.hit]
        hits = len(self.records) - len(computed)
        parts = []
        if computed:
            parts.append(f"{len(computed)} computed in {sum(r.seconds for r in computed):.0f} s")
        if hits:
            parts.append(f"{hits} cache hit{'' if hits == 1 else 's'}")
        count = len(self.records)
        return f"{count} task{'' if count == 1 else 's'}: " + ", ".join(parts)

    def summarise(self) -> None:
        log.info("%-12s %s", self.stage, self.summary())


def each_task(
    stage: str,
    tasks: Mapping[str, T],
    run: Callable[[str, T, tqdm | None], tuple[Any, bool]],
    *,
    work: Callable[[str, T], int] | None = None,
    progress: bool = False,
) -> dict[str, Any]:
    """``run(name, task, bar)`` for every task of a study's stage, in order: the one per-task loop of the stages.

    Parameters
    ----------
    stage : str
        The stage's name (its bar and its log lines).
    tasks : mapping of str to anything
        Study task id → what ``run`` needs of that task (an RWG request, an artefact, …), in study order.
    run : callable
        Computes or reuses one task's artefact; returns (artefact, cache hit). ``bar`` is the stage's bar
        (None without one), which ``run`` may advance as its work goes (by at most the task's ``work``).
    work : callable, optional
        Units of work of a task: its episodes, the bar's unit then being ``ep``; None counts tasks. However
        much ``run`` advanced the bar, it ends a task at the sum of the tasks' work so far, so a cache hit
        advances it at once. Asked once per task, before the first runs.
    progress : bool
        Show one bar over the stage.

    Returns
    -------
    dict of task id to artefact, in the order of ``tasks``. Each task's outcome goes to the run log
    (DEBUG), the stage's summary line to the console (INFO).
    """
    amounts = {name: 1 if work is None else work(name, task) for name, task in tasks.items()}  # once, before any runs
    log_ = StageLog(stage)
    unit = "task" if work is None else "ep"
    with stage_bar(stage, sum(amounts.values()), unit) if progress else nullcontext() as bar:
        for name, task in tasks.items():
            if bar is not None:
                bar.set_postfix_str(name)
            before = bar.n if bar is not None else 0
            with log_.task(name) as record:
                record.artefact, record.hit = run(name, task, bar)
            if bar is not None:
                bar.update(before + amounts[name] - bar.n)
    log_.summarise()
    return {r.name: r.artefact for r in log_.records}
