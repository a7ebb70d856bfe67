"""The whole chain of a study from a composed config: its artefacts (:mod:`taskcomplexity.stages.chain`),
then its report (:mod:`taskcomplexity.report`). The only module that joins the two, so that neither
imports the other."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.report.build import build_report
from taskcomplexity.stages.chain import StudyArtefacts, study_artefacts

log = logging.getLogger(__name__)


def write_report(artefacts: StudyArtefacts, out_dir: Path, title: str, *, registry: Registry = DEFAULT_REGISTRY
                 ) -> Path:
    """The report of a study's artefacts under ``out_dir``; returns its ``index.html``."""
    study, results = artefacts.study, artefacts.results
    ablation = None
    if study.kind == "variants":
        ablation = {f"{study.label(results[0].task_id)}: prior and network variants":
                    {study.label(r.task_id): r for r in results}}
    return build_report(results, study=study, verdict=artefacts.verdict, diagnostics=artefacts.diagnostics,
                        sac_curves=artefacts.sac_curves, out_dir=out_dir, title=title, ablation=ablation,
                        alpha=artefacts.alpha, registry=registry)


def run_study(cfg: Any, *, registry: Registry = DEFAULT_REGISTRY) -> Path:
    """Compute or reuse every artefact of the study and write its report; return index.html."""
    started = time.time()
    artefacts = study_artefacts(cfg, registry=registry)
    name = artefacts.name
    title = cfg.report.get("title") or f"How hard is each task? ({name})"
    index = write_report(artefacts, Path(cfg.paths.outputs) / "reports" / name, title, registry=registry)
    elapsed = time.time() - started
    print(f"\nStudy '{name}' finished in {elapsed:.0f} s.\nReport: {index.resolve()}", flush=True)
    return index
