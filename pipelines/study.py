"""The whole chain for a study: RWG → metrics (+ diagnostics) → SAC → verdict → report.

    python pipelines/study.py experiment=quick     # what `make run` does
    python pipelines/study.py experiment=paper     # the published protocol (`make paper`)
    python pipelines/study.py experiment=smoke     # seconds
    python pipelines/study.py study=ablation       # the appendix ablation (prior/network variants)

Every stage is cached by config hash, so a rerun only computes what is missing; the last line
printed says where the report is.
"""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import check_overrides
from taskcomplexity.study_run import run_study


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run_study(cfg)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
