"""Metrics stage: PIC, POIC, statistics, bootstrap and batch tests per task, and the study's tables.

    python pipelines/metrics.py experiment=smoke                  # every task of the study + tables
    python pipelines/metrics.py metrics.scope=task arm=two_link   # one task

Pulls (computes if missing) the RWG artefact each task needs. Tables go to
``<paths.outputs>/tables/<study.name>/`` as Markdown, LaTeX and CSV.
"""

from __future__ import annotations

import logging
import sys

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import (
    cache_from_config,
    check_overrides,
    metrics_settings_from_config,
    one_line_errors,
    run_name,
    rwg_request_from_config,
    study_requests,
)
from taskcomplexity.config import task_from_config
from taskcomplexity.errors import ConfigError
from taskcomplexity.pipeline.study import study_metrics, write_metrics_tables

log = logging.getLogger("metrics")


@one_line_errors
def run(cfg: DictConfig):
    scope = cfg.metrics.get("scope", "study")
    if scope not in ("study", "task"):
        raise ConfigError(f"metrics.scope must be one of ['study', 'task'], got {scope!r}")
    if scope == "study":
        entries, requests = zip(*study_requests(cfg), strict=True)
        names = [entry.id for entry in entries]
    else:
        names, requests = None, [rwg_request_from_config(cfg, task_from_config(cfg))]
    settings = metrics_settings_from_config(cfg)
    cache = cache_from_config(cfg)
    results = study_metrics(
        cache, list(requests), settings, names=list(names) if names else None, force=bool(cfg.force), progress=True
    )
    if len(results) >= 2:
        written = write_metrics_tables(results, cfg.paths.outputs, run_name(cfg), alpha=settings.alpha)
        for path in written:
            log.info("table: %s", path)
    return results


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run(cfg)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
