"""Progress bars: one per stage of a study, which the work inside the stage advances.

A function that reports progress takes ``progress``: ``False`` (no bar), ``True`` (a bar of its own)
or a stage's bar (a ``tqdm`` instance that the caller opened over the whole stage, every task's work
counted in its total): then the function advances that bar and leaves it open.
"""

from __future__ import annotations

from typing import Any

from tqdm.auto import tqdm

Progress = bool | tqdm
"""What a function that reports progress accepts (module docstring)."""


class _Borrowed:
    """A stage's bar seen by one piece of its work: updates go to the bar; closing leaves it open."""

    def __init__(self, bar: tqdm):
        self._bar = bar

    def update(self, n: float = 1) -> None:
        self._bar.update(n)

    def close(self) -> None:
        pass


def progress_bar(progress: Progress, *, total: float, desc: str, unit: str, **options: Any):
    """The bar a piece of work advances: the stage's bar if ``progress`` is one, else its own.

    ``total``, ``desc``, ``unit`` and ``options`` (tqdm's keywords) describe the work's own bar; a
    stage's bar already counts the work in its total.
    """
    if isinstance(progress, tqdm):
        return _Borrowed(progress)
    return tqdm(total=total, desc=desc, unit=unit, disable=not progress, **options)


def stage_bar(stage: str, total: float, unit: str) -> tqdm:
    """The bar of one stage of a study over ``total`` units of work (tasks, episodes), with an ETA.

    The caller names the task at work with ``bar.set_postfix_str(task_id)``; an empty stage (every
    task cached) shows no bar.
    """
    return tqdm(total=total, desc=stage, unit=unit, disable=total == 0, smoothing=0.1,
                unit_scale=unit == "ep", dynamic_ncols=True)
