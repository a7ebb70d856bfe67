"""What a study's stage says: one DEBUG line per task (the run log), one INFO summary (the console)."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

log = logging.getLogger(__name__)


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
        log.debug("%-26s %s %s", name, self.stage, outcome(record.hit, record.seconds))

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
