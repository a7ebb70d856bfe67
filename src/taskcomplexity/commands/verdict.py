"""Verdict stage: every registered metric against every known relation of the study (cached).

    python pipelines/verdict.py experiment=smoke                  # the seven tasks, in about a minute
    python pipelines/verdict.py study=mine hydra.searchpath=[file://DIR]

Pulls (computes if missing) every upstream artefact of the study — RWG, metrics, diagnostics and, when
``sac.enabled``, SAC — and writes ``<paths.outputs>/cache/verdict/<key>/verdict.parquet`` (one row per
metric × relation) and ``summary.parquet`` (per metric); the log names the files, and a rerun is a
cache hit.
"""

from __future__ import annotations

import logging

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors
from taskcomplexity.commands import entry_point
from taskcomplexity.study.plan import read_plan

log = logging.getLogger("verdict")


@one_line_errors
def run(cfg: DictConfig):
    """The study's verdict artefact (computed or reused); prints its per-metric summary."""
    plan = read_plan(cfg)  # every setting checked before the stages' modules are imported
    import pandas as pd

    from taskcomplexity.study.chain import study_artefacts

    artefact = study_artefacts(plan).verdict
    summary = pd.read_parquet(artefact.file("summary.parquet"))
    log.info("verdict: %s", artefact.file("verdict.parquet"))
    print(summary.to_string(index=False), flush=True)
    return artefact


main = entry_point(run)

if __name__ == "__main__":
    main()
