"""Report stage: pull every artefact of the study from the cache (computing what is missing) and
write ``outputs/reports/<study>-<tag>/`` (index.html, report.md, figures/, tables/).

The report needs every upstream artefact, so this runs the study chain itself; when everything is
cached it only draws the figures and writes the page.

    python pipelines/report.py experiment=quick
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
