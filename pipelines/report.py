"""Report stage: pull every artefact of the study (computing what is missing) and write the report.

    python pipelines/report.py experiment=quick
    → outputs/reports/<study>-<tag>/index.html, report.md, figures/, tables/
"""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import check_overrides
from taskcomplexity.pipeline.chain import run_study


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run_study(cfg)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
