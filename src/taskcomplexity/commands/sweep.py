"""Hydra callback: after a multirun of studies, the sweep's report (:mod:`taskcomplexity.report.sweep`).

Declared in ``conf/config.yaml`` (``hydra.callbacks.sweep_report``), so every multirun of
``pipelines/study.py`` ends with ``<sweep dir>/sweep_report/README.md``: per cell, each metric's
correlation with the study's reference scores, and the mean over the cells. Multiruns of the other
entry points record no study job, and the callback writes nothing.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback
from omegaconf import DictConfig

log = logging.getLogger("taskcomplexity")


class SweepReport(Callback):
    """Writes the sweep report once every job of a multirun has returned."""

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        from taskcomplexity.report.sweep import write_sweep_report

        readme = write_sweep_report(Path(config.hydra.sweep.dir))
        if readme is not None:
            print(f"\nSweep report: {readme.resolve()}", flush=True)
