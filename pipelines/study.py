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

import os

# Before torch and NumPy load their thread pools: OpenMP threads that spin-wait after a parallel region
# would steal the cores from numba's kernels (2x slower RWG on 2 cores). The process is this entry
# point's to configure; the library itself sets nothing at import.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import sys

import hydra
from omegaconf import DictConfig

from taskcomplexity.cli import check_overrides, one_line_errors
from taskcomplexity.study_run import run_study


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    one_line_errors(run_study)(cfg)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
