"""RWG stage: sample N random policies × M episodes of one task → returns.parquet (cached).

    python pipelines/rwg.py arm=two_link reward=sparse rwg.policies=1000 rwg.episodes=100
    python pipelines/rwg.py -m arm=one_link_1m0,one_link_1m65,two_link reward=dense,sparse experiment=smoke

``rwg.entry=<study task id>`` runs that task of the selected study (``study=…``) as the study composes it, at the
study's N and M, into the key the study looks up. A multirun over the ids and shards sends a study's RWG out as jobs
(``make atlas-cluster``); the study then reads every artefact from the cache::

    python pipelines/rwg.py -m hydra/launcher=cluster hydra.launcher.partition=<yours> experiment=atlas \
        rwg.entry=cartpole,pendulum rwg.shards=4 'rwg.shard=range(4)'
"""

from __future__ import annotations

import logging

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors, refuse_unread_groups, user_overrides
from taskcomplexity.commands import entry_point
from taskcomplexity.errors import ConfigError
from taskcomplexity.rwg.backends import refuse_workers
from taskcomplexity.stages.declared import STAGES
from taskcomplexity.stages.rwg_stage import STAGE, RWGRequest, run_rwg_stage
from taskcomplexity.study.plan import cache_from_config, rwg_request_from_config, study_from, study_requests

log = logging.getLogger("rwg")

UNREAD = (*(stage.group for stage in STAGES if stage.group not in (None, STAGE)), "report")
"""The config nodes the RWG stage of one task does not read: every other stage's group, the report (and the study,
unless ``rwg.entry`` names one of its tasks)."""


def entry_request(cfg: DictConfig, task_id: str) -> RWGRequest:
    """The RWG request the study of ``cfg`` makes for its task ``task_id`` (this job's shard of it), composed alone:
    a job of the sweep composes its own task, not the study's every task."""
    study = study_from(cfg)
    ids = [entry.id for entry in study.tasks]
    if task_id not in ids:
        raise ConfigError(f"rwg.entry={task_id} is not a task of study {cfg.study.name} (allowed: {', '.join(ids)})")
    [(_, request)] = study_requests(cfg, study, only=task_id)
    return request


@one_line_errors
def run(cfg: DictConfig):
    """Compute or reuse the returns artefact of the composed task and sampler (or of the study task ``rwg.entry``)."""
    entry = cfg.rwg.get("entry")
    unread = UNREAD if entry is not None else (*UNREAD, "study")
    refuse_unread_groups(user_overrides(), unread, "the RWG stage of one task", "pipelines/study.py")
    request = entry_request(cfg, str(entry)) if entry is not None else rwg_request_from_config(cfg)
    if entry is None:  # one task alone: rwg.workers must reach its backend (a study's job takes the study's value)
        refuse_workers(request.settings.workers, [request.backend], f"task {request.task.task_id}")
    cache = cache_from_config(cfg)
    artefact, hit = run_rwg_stage(
        cache, request, force=bool(cfg.force), progress=True, compute_missing=request.settings.shards == 1
    )
    if artefact is None:
        log.info("shard %d/%d done for %s", request.settings.shard, request.settings.shards, request.label)
        return None
    log.info("%s returns %s: %s", "cache hit" if hit else "computed", request.label, artefact.file("returns.parquet"))
    return artefact


main = entry_point(run)


if __name__ == "__main__":
    main()
