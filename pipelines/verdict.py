"""Verdict stage: every registered metric against every known relation of the study (cached).

    python pipelines/verdict.py experiment=smoke                  # the seven tasks, in seconds
    python pipelines/verdict.py study=mine hydra.searchpath=[file://DIR]

Pulls (computes if missing) every upstream artefact of the study — RWG, metrics, diagnostics and, when
``sac.enabled``, SAC — and writes ``<paths.outputs>/cache/verdict/<key>/verdict.parquet`` (one row per
metric × relation) and ``summary.parquet`` (per metric); the log names the files, and a rerun is a
cache hit.
"""

from __future__ import annotations

import os

# Before torch and NumPy load their thread pools: OpenMP threads that spin-wait after a parallel region
# would steal the cores from numba's kernels (2x slower RWG on 2 cores). The process is this entry
# point's to configure; the library itself sets nothing at import.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import logging
import sys

import hydra
import pandas as pd
from omegaconf import DictConfig

from taskcomplexity.cli import check_overrides, one_line_errors
from taskcomplexity.stages.chain import run_verdict

log = logging.getLogger("verdict")


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    artefact = one_line_errors(run_verdict)(cfg)
    summary = pd.read_parquet(artefact.file("summary.parquet"))
    log.info("verdict: %s", artefact.file("verdict.parquet"))
    print(summary.to_string(index=False), flush=True)


if __name__ == "__main__":
    check_overrides(sys.argv)
    main()
