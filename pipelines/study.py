"""The whole chain for a study: RWG → metrics (+ diagnostics) → SAC → report.

    python pipelines/study.py                      # experiment=quick (what `make run` does)
    python pipelines/study.py experiment=paper     # the published protocol (`make paper`)
    python pipelines/study.py experiment=smoke     # seconds

Every stage is cached by config hash, so a rerun only computes what is missing.
"""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import (
    cache_from_config,
    check_overrides,
    metrics_settings_from_config,
    one_line_errors,
    run_name,
    study_requests,
)
from taskcomplexity.pipeline.study import study_metrics, write_metrics_tables

log = logging.getLogger("study")


@one_line_errors
def run(cfg: DictConfig) -> Path:
    started = time.time()
    names, requests = zip(*study_requests(cfg), strict=True)
    settings = metrics_settings_from_config(cfg)
    cache = cache_from_config(cfg)
    results = study_metrics(cache, list(requests), settings, names=list(names), force=bool(cfg.force), progress=True)
    tables = write_metrics_tables(results, cfg.paths.outputs, run_name(cfg), alpha=settings.alpha)
    out = Path(tables[0]).parent
    log.info("study %s done in %.0f s; tables in %s", cfg.study.name, time.time() - started, out)
    print(f"\nStudy '{cfg.study.name}' finished in {time.time() - started:.0f} s. Tables: {out}")
    return out


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run(cfg)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
