"""SAC stage: train SAC (and SAC + HER with sac.her=true) on one task → curves.parquet (cached).

    python pipelines/sac.py arm=one_link_1m0 reward=dense sac=smoke
    python pipelines/sac.py arm=two_link reward=sparse sac.her=true sac.seeds=[0,1,2,3,4]
    python pipelines/sac.py task=pendulum sac.total_steps=20000
    python pipelines/sac.py experiment=smoke reward=sparse sac.her=true

The budget is ``sac.total_steps`` when set; otherwise the ``sac_steps`` of the selected study's entry
for this task (``study=seven_tasks`` by default: the reference budgets of sac.md). A task with neither fails
with one line naming ``sac.total_steps``. An interrupted run resumes from its last checkpoint.
"""

from __future__ import annotations

import logging
from typing import Any

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors
from taskcomplexity.commands import entry_point
from taskcomplexity.compose import entry_config
from taskcomplexity.plan import cache_from_config, study_from
from taskcomplexity.rl import with_budget
from taskcomplexity.rl.train import refuse_untrainable
from taskcomplexity.stages.sac_stage import CURVES, run_sac_stage, sac_settings_from_config
from taskcomplexity.tasks.from_config import task_from_config
from taskcomplexity.tasks.spec import TaskSpec

log = logging.getLogger("sac")


@one_line_errors
def run(cfg: DictConfig):
    task = task_from_config(cfg)
    settings = sac_settings_from_config(cfg.sac)
    # refused before the cache holds anything of the run (training refuses it too, but only once its
    # scratch directory and lock exist)
    refuse_untrainable(task, settings)
    # The study entry gives the budget (when sac.total_steps is unset) and, for a gym task, solved_return.
    needs_entry = settings.total_steps is None or not isinstance(task, TaskSpec)
    entry = study_entry_for(cfg, task) if needs_entry else None
    settings = with_budget(settings, None if entry is None else entry.sac_steps, task_id=task.task_id)
    cache = cache_from_config(cfg)
    solved = None if entry is None else entry.solved_return
    artefact, hit = run_sac_stage(cache, task, settings, solved_return=solved, force=bool(cfg.force), progress=True)
    log.info("%s curves %s: %s", "cache hit" if hit else "trained", task.task_id, artefact.file(CURVES))
    return artefact


def study_entry_for(cfg: Any, task) -> Any:
    """The entry of the selected study (``cfg.study``) whose task is ``task``, or None.

    Each entry is composed from its own choices (its config groups, env id, kwargs, max steps) and the
    study's ``max_steps``, as the study composes it, and matched on the task's type and
    ``identity()``. The command line's overrides are not applied to the entries: they chose ``task``
    (``arm=two_link`` picks the study's two-link entry; a modified arm matches no entry).
    """
    study = study_from(cfg)
    wanted = (type(task).__name__, task.identity())
    for i, entry in enumerate(study.tasks):
        candidate = task_from_config(entry_config(cfg, entry, [], f"study.tasks[{i}]"))
        if (type(candidate).__name__, candidate.identity()) == wanted:
            return entry
    return None


main = entry_point(run)


if __name__ == "__main__":
    main()
