"""Running a stage built on SAC's trained actors over a study's tasks: the occupancy and learning-path stages.

Both need, per task, the key of its SAC artefact and the artefact's ``actors.npz``
(``curves.attrs["sac_actors"]`` of :func:`~taskcomplexity.stages.sac_stage.study_sac_curves`); a task
without one (SAC skips it, SAC has not trained it, or its SAC artefact is older than the snapshots) is
left out, and the log says which of these it is.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from taskcomplexity.stages.cache import Artefact
from taskcomplexity.stages.sac_stage import ACTORS_ATTR, MISSING_ATTR, SKIPPED_ATTR
from taskcomplexity.stages.stage_log import each_task

if TYPE_CHECKING:
    import pandas as pd

log = logging.getLogger(__name__)

def trained_actors(sac_curves: pd.DataFrame | None) -> dict[str, tuple[str, str]]:
    """Task id → (SAC key, path of its ``actors.npz``) of every task SAC's curves hold a trained actor for."""
    return {} if sac_curves is None else dict(sac_curves.attrs.get(ACTORS_ATTR, {}))


def unavailable_actors(sac_curves: pd.DataFrame) -> dict[str, str]:
    """Why a task has no SAC actor (task id → reason), from the SAC stage's curves: SAC skips it (discrete
    actions), or it has no cached curves (``sac.enabled=false``)."""
    why = {task_id: "SAC is not trained with sac.enabled=false, and the cache holds no SAC curves for it"
           for task_id in sac_curves.attrs.get(MISSING_ATTR) or []}
    for task_id, reason in (sac_curves.attrs.get(SKIPPED_ATTR) or {}).items():
        why[task_id] = f"SAC skips tasks with {reason}"
    return why


OLDER_THAN_SNAPSHOTS = "its SAC artefact is older than actor snapshots: force=true retrains it"
"""Why a task SAC trained has no actor: its artefact was written before SAC kept actor snapshots."""


def over_actor_tasks(
    stage: str,
    tasks: list[str],
    actors: Mapping[str, tuple[str, Path]],
    run: Callable[[str, str, Path, Callable[[float], object] | None], tuple[Artefact, bool]],
    *,
    episodes: Callable[[str], int],
    progress: bool = False,
    unavailable: Mapping[str, str] | None = None,
) -> dict[str, Artefact]:
    """``run(task_id, sac_key, actors_file, advance)`` for every task of ``tasks`` that has an actor.

    Parameters
    ----------
    stage : str
        The stage's name (its bar and log lines).
    tasks : list of str
        Study task ids, in order.
    actors : mapping of task id to (SAC key, path of ``actors.npz``)
    run : callable
        Computes or reuses one task's artefact; ``advance(n)`` moves the stage's bar by n episodes
        (None without a bar). Returns (artefact, cache hit).
    episodes : callable
        Episodes a task's artefact costs (the bar's total; a cache hit advances it at once).
    progress : bool
        Show one bar over the stage's episodes.
    unavailable : mapping of task id to str, optional
        Why a task has no actor, for the log (e.g. "SAC skips tasks with discrete actions"); a task
        without an actor and without a reason has a SAC artefact older than actor snapshots.

    Returns
    -------
    dict of task id to Artefact, for the tasks with an actor.
    """
    missing = [t for t in tasks if t not in actors]
    chosen = [t for t in tasks if t in actors]
    if missing and chosen:
        reasons: dict[str, list[str]] = {}
        for task_id in missing:
            reasons.setdefault((unavailable or {}).get(task_id, OLDER_THAN_SNAPSHOTS), []).append(task_id)
        for reason, ids in reasons.items():
            log.info("%-12s no SAC actor for %s (%s); left out", stage, ", ".join(ids), reason)
    if not chosen:
        return {}

    def run_one(task_id: str, actor: tuple[str, Path], bar) -> tuple[Artefact, bool]:
        sac_key, actors_file = actor
        return run(task_id, sac_key, Path(actors_file), None if bar is None else bar.update)

    return each_task(stage, {t: actors[t] for t in chosen}, run_one, work=lambda task_id, _: episodes(task_id),
                     progress=progress)
