"""The whole chain for a study: RWG → metrics (+ diagnostics) → SAC → verdict → report.

    python pipelines/study.py experiment=published                   # `make run`: the published scale, no SAC
    python pipelines/study.py experiment=published sac.enabled=true  # `make paper`: + SAC (hours)
    python pipelines/study.py experiment=quick                       # `make quick`: minutes
    python pipelines/study.py experiment=smoke                       # about a minute
    python pipelines/study.py study=ablation                         # the appendix ablation (variants)

Every stage is cached by config hash, so a rerun only computes what is missing; the last line
printed says where the report is.
"""

from __future__ import annotations

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors
from taskcomplexity.commands import entry_point


@one_line_errors
def run(cfg: DictConfig):
    """The whole chain for ``cfg`` (:func:`taskcomplexity.study.run.run_study`)."""
    from taskcomplexity.study.run import run_study

    return run_study(cfg)


main = entry_point(run)

if __name__ == "__main__":
    main()
