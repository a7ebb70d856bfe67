"""The whole chain of a study from a composed config: its plan, read once (:mod:`taskcomplexity.study.plan`), its
artefacts (:mod:`taskcomplexity.study.chain`), then its report (:mod:`taskcomplexity.report`). The only
module that joins the chain and the report, so that neither imports the other. The plan is read before either is
imported: a study its config refuses loads neither the stages' numerics nor the report's plotting libraries."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path
from typing import Any

from taskcomplexity.cli import user_overrides
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages.declared import STAGES
from taskcomplexity.study.plan import StudyPlan, read_plan

log = logging.getLogger(__name__)


def run_study(cfg: Any, *, registry: Registry = DEFAULT_REGISTRY) -> Path:
    """Read the study's plan from the composed config ``cfg`` (every setting checked, before any work), then
    :func:`run_plan`; return the report's index.html."""
    started = time.time()
    plan = read_plan(cfg, registry=registry)
    return run_plan(plan, registry=registry, started=started)


def run_plan(plan: StudyPlan, *, registry: Registry = DEFAULT_REGISTRY, started: float | None = None) -> Path:
    """Compute or reuse every artefact of the study and write its report; return index.html.

    The report goes to ``<paths.outputs>/reports/<study>[-<tag>]/<run id>/``, one directory per run identity, and
    the index of every report is rebuilt (:mod:`taskcomplexity.report.runs`); a job of a multirun writes it into
    its own job directory instead (``<sweep dir>/<job>/report``, so the cells of a sweep do not overwrite
    one another) and records itself there for the sweep report (:mod:`taskcomplexity.report.sweep`).
    ``started``: when the run began (the time it prints counts from there; default: now).
    """
    from taskcomplexity.report.build import build_report
    from taskcomplexity.report.runs import keep_run, run_directory
    from taskcomplexity.study.chain import study_artefacts

    started = time.time() if started is None else started
    artefacts = study_artefacts(plan, registry=registry)
    name = artefacts.name
    job = plan.job_dir
    reports = plan.outputs / "reports"
    out_dir = job / "report" if job is not None else run_directory(reports, name, artefacts.verdict.key, plan.title)
    study, results = artefacts.study, artefacts.results
    ablation = None
    if study.kind == "variants":
        ablation = {f"{study.label(results[0].task_id)}: prior and network variants":
                    {study.label(r.task_id): r for r in results}}
    index = build_report(results, study=study, verdict=artefacts.verdict, diagnostics=artefacts.diagnostics,
                         sac_curves=artefacts.sac_curves, out_dir=out_dir, title=plan.title, ablation=ablation,
                         alpha=artefacts.alpha, registry=registry, further=artefacts.further,
                         missing={stage.name: stage.missing for stage in STAGES if stage.missing})
    if job is not None:
        from taskcomplexity.report.labels import task_styles
        from taskcomplexity.report.sweep import JOB_FILE

        labels = {t: style.name for t, style in task_styles(artefacts.study, [r.task_id for r in artefacts.results])
                  .items()}
        record = {"study": name, "overrides": list(plan.overrides), "labels": labels,
                  "verdict": str(artefacts.verdict.path.resolve()), "report": str(index.resolve())}
        (job / JOB_FILE).write_text(json.dumps(record, indent=1), encoding="utf-8")
    else:
        every = keep_run(out_dir, name=name, overrides=user_overrides(), verdict_key=artefacts.verdict.key)
    elapsed = time.time() - started
    print(f"\nStudy '{name}' finished in {elapsed:.0f} s.\nReport: {index.resolve()}", flush=True)
    if job is None:
        print(f"Every report: {every.resolve()}", flush=True)
    return index
