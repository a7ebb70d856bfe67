"""SAC stage: train SAC (and SAC + HER with sac.her=true) on one task → curves.parquet (cached).

    python pipelines/sac.py arm=one_link_1m0 reward=dense sac=smoke
    python pipelines/sac.py arm=two_link reward=sparse sac.her=true sac.seeds=[0,1,2,3,4]
    python pipelines/sac.py experiment=smoke reward=sparse sac.her=true

An interrupted run resumes from its last checkpoint.
"""

from __future__ import annotations

import logging
import sys

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import cache_from_config, check_overrides, one_line_errors
from taskcomplexity.config import task_from_config
from taskcomplexity.pipeline.sac_stage import CURVES, run_sac_stage, sac_settings_from_config

log = logging.getLogger("sac")


@one_line_errors
def run(cfg: DictConfig):
    task = task_from_config(cfg)
    settings = sac_settings_from_config(cfg.sac)
    cache = cache_from_config(cfg)
    artefact, hit = run_sac_stage(cache, task, settings, force=bool(cfg.force), progress=True)
    log.info("%s curves %s: %s", "cache hit" if hit else "trained", task.task_id, artefact.file(CURVES))
    return artefact


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run(cfg)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
