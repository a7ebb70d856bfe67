"""Metrics stage: every registered metric of the metrics stage, its bootstrap and batch estimates, per task.

    python pipelines/metrics.py experiment=smoke                  # every task of the study
    python pipelines/metrics.py metrics.scope=task task=pendulum  # one task

Pulls (computes if missing) the RWG artefact each task needs, logs where each metrics artefact is, and
prints the point estimates (one row per task, one column per metric). The study's tables (Table 1,
intervals, Welch matrices) are the report's: ``python pipelines/study.py`` writes them once, under
``<paths.outputs>/reports/<study>/<run id>/tables/``.
"""

from __future__ import annotations

import logging

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors, user_overrides
from taskcomplexity.commands import entry_point
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY
from taskcomplexity.stages.metrics_stage import RECORD, STAGE
from taskcomplexity.study.plan import (
    cache_from_config,
    metrics_settings_from_config,
    refuse_entry,
    run_name,
    rwg_request_from_config,
    study_requests,
)
from taskcomplexity.tasks.from_config import task_from_config

log = logging.getLogger("metrics")


@one_line_errors
def run(cfg: DictConfig):
    refuse_entry(cfg)
    scope = cfg.metrics.get("scope", "study")
    if scope not in ("study", "task"):
        raise ConfigError(f"metrics.scope must be one of ['study', 'task'], got {scope!r}")
    settings = metrics_settings_from_config(cfg)
    if scope == "study":
        entries, requests = zip(*study_requests(cfg), strict=True)
        names = [entry.id for entry in entries]
    else:
        names, requests = None, [rwg_request_from_config(cfg, task_from_config(cfg))]
    RECORD.check(settings, None, requests, user_overrides())  # against every task's N and M, before any work
    from taskcomplexity.stages.task_artefacts import metrics_frame, study_metrics

    cache = cache_from_config(cfg)
    results = study_metrics(
        cache, list(requests), settings, names=list(names) if names else None, force=bool(cfg.force), progress=True
    )
    for result in results:
        log.info("%s: %s", result.task_id, result.metrics.file("metrics.parquet"))
    names = ["task", *(m.name for m in DEFAULT_REGISTRY.of_stage(STAGE))]
    frame = metrics_frame(results)
    heading = f"study {run_name(cfg)}" if scope == "study" else f"task {requests[0].label}"
    print(f"{heading}:\n" + frame[[c for c in names if c in frame.columns]].to_string(index=False), flush=True)
    return results


main = entry_point(run)


if __name__ == "__main__":
    main()
