"""SAC stage: train SAC (and SAC + HER with sac.her=true) on one task → curves.parquet (cached).

    python pipelines/sac.py arm=one_link_1m0 reward=dense sac=smoke
    python pipelines/sac.py arm=two_link reward=sparse sac.her=true sac.seeds=[0,1,2,3,4]
    python pipelines/sac.py task=pendulum sac.total_steps=20000
    python pipelines/sac.py experiment=smoke reward=sparse sac.her=true

The budget is ``sac.total_steps`` when set; otherwise the ``sac_steps`` of the selected study's entry
for this task (``study=seven_tasks`` by default: the reference budgets of
``docs/explanation/sac-protocol.md``). A task with neither fails with one line naming ``sac.total_steps``.
An interrupted run resumes from its last checkpoint.

``sac.entry=<study task id>`` trains what the study's chain trains on that task instead: the task composed
as the study composes it, every variant of ``docs/explanation/sac-protocol.md`` (SAC; + HER on a sparse
reaching task) at its budget, into the keys the study looks up. A multirun over the ids is ``make paper``
spread over jobs (``make paper-jobs``, e.g. on a cluster through ``hydra/launcher=cluster``); ``make paper``
then reads every run from the cache::

    python pipelines/sac.py -m experiment=published sac.entry=one_link_1m0-dense,two_link-sparse \
        hydra/launcher=local_submitit
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors, user_overrides
from taskcomplexity.commands import entry_point
from taskcomplexity.config import plain
from taskcomplexity.errors import ConfigError
from taskcomplexity.rl import with_budget
from taskcomplexity.stages.sac_stage import (
    CURVES,
    SKIPPED_ATTR,
    run_sac_stage,
    sac_settings_from_config,
    study_sac_curves,
)
from taskcomplexity.study.compose import Composer, entry_base, entry_config, study_family
from taskcomplexity.study.plan import cache_from_config, study_from
from taskcomplexity.tasks.from_config import task_from_config
from taskcomplexity.tasks.spec import TaskSpec

if TYPE_CHECKING:
    import pandas as pd

log = logging.getLogger("sac")


@one_line_errors
def run(cfg: DictConfig):
    settings = sac_settings_from_config(cfg.sac)
    if settings.entry is not None:
        return train_study_task(cfg, settings.entry)
    from taskcomplexity.rl.train import refuse_untrainable

    task = task_from_config(cfg)
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


def train_study_task(cfg: Any, task_id: str) -> pd.DataFrame:
    """Every SAC run the study of ``cfg`` makes on its task ``task_id``; returns their tidy curves.

    The entry is composed as the study composes it (:func:`~taskcomplexity.study.compose.entry_config`: the typed
    overrides, the study's policy family, the entry's own choices) and trained through the study's own
    function (:func:`~taskcomplexity.stages.sac_stage.study_sac_curves`), so each run lands under the key the
    study looks up. A typed group the entry chooses itself (``arm=…``) is refused, as the study refuses it; a
    task SAC skips (discrete actions) is logged and skipped, as the study skips it.
    """
    study = study_from(cfg)
    ids = [entry.id for entry in study.tasks]
    if task_id not in ids:
        raise ConfigError(f"sac.entry={task_id} is not a task of study {study.name} (allowed: {', '.join(ids)})")
    index = ids.index(task_id)
    typed = user_overrides()
    family = study_family(study, typed)
    node = entry_config(entry_base(plain(cfg)), study.tasks[index], typed, f"study.tasks[{index}]", family)
    task = task_from_config(node)
    curves = study_sac_curves(cache_from_config(cfg), [(study.tasks[index], task)], cfg.sac, force=bool(cfg.force),
                              progress=True)
    if task_id in curves.attrs[SKIPPED_ATTR]:  # as in the study: logged, not an error, so a sweep's job succeeds
        log.info("SAC skips %s (%s): nothing to train", task_id, curves.attrs[SKIPPED_ATTR][task_id])
    else:
        log.info("SAC runs of %s (%s): %s", task_id, ", ".join(sorted(curves["variant"].unique())),
                 cache_from_config(cfg).root / "sac")
    return curves


def study_entry_for(cfg: Any, task) -> Any:
    """The entry of the selected study (``cfg.study``) whose task is ``task``, or None.

    Each entry is composed from its own choices (its config groups, env id, kwargs, max steps) and the
    study's ``max_steps``, as the study composes it, and matched on the task's type and
    ``identity()``. The command line's overrides are not applied to the entries: they chose ``task``
    (``arm=two_link`` picks the study's two-link entry; a modified arm matches no entry).
    """
    study, base, composer = study_from(cfg), entry_base(plain(cfg)), Composer()
    wanted = (type(task).__name__, task.identity())
    for i, entry in enumerate(study.tasks):
        candidate = task_from_config(entry_config(base, entry, [], f"study.tasks[{i}]", None, composer))
        if (type(candidate).__name__, candidate.identity()) == wanted:
            return entry
    return None


main = entry_point(run)


if __name__ == "__main__":
    main()
