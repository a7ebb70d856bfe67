"""RWG stage: sample N random policies × M episodes of one task → returns.parquet (cached).

    python pipelines/rwg.py arm=two_link reward=sparse rwg.policies=1000 rwg.episodes=100
    python pipelines/rwg.py -m arm=one_link_1m0,one_link_1m65,two_link reward=dense,sparse experiment=smoke
"""

from __future__ import annotations

import logging

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors, refuse_unread_groups, user_overrides
from taskcomplexity.commands import entry_point
from taskcomplexity.stages.declared import STAGES
from taskcomplexity.stages.rwg_stage import STAGE, run_rwg_stage
from taskcomplexity.study.plan import cache_from_config, rwg_request_from_config

log = logging.getLogger("rwg")

UNREAD = (*(stage.group for stage in STAGES if stage.group not in (None, STAGE)), "study", "report")
"""The config nodes the RWG stage of one task does not read: every other stage's group, the study, the report."""


@one_line_errors
def run(cfg: DictConfig):
    """Compute or reuse the returns artefact of the composed task and sampler."""
    refuse_unread_groups(user_overrides(), UNREAD, "the RWG stage of one task", "pipelines/study.py")
    request = rwg_request_from_config(cfg)
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
