"""The whole chain for a study: RWG → metrics (+ diagnostics) → SAC → verdict → report.

    python pipelines/study.py experiment=published                   # `make run`: the published scale, no SAC
    python pipelines/study.py experiment=published sac.enabled=true  # `make paper`: + SAC (hours)
    python pipelines/study.py experiment=quick                       # `make quick`: minutes
    python pipelines/study.py experiment=smoke                       # seconds
    python pipelines/study.py study=ablation                         # the appendix ablation (variants)

Every stage is cached by config hash, so a rerun only computes what is missing; the last line
printed says where the report is.
"""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import CONF_DIR, check_overrides, one_line_errors
from taskcomplexity.study_run import run_study


@hydra.main(version_base="1.3", config_path=str(CONF_DIR), config_name="config")
def app(cfg: DictConfig) -> None:
    one_line_errors(run_study)(cfg)


def main() -> None:
    """``taskcomplexity-study`` and ``pipelines/study.py``: a bad override in one line, else the app."""
    check_overrides(sys.argv)
    app()


if __name__ == "__main__":
    main()
