"""The whole chain of a study from a composed config: RWG → metrics → diagnostics → SAC → report."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from taskcomplexity.cli import (
    cache_from_config,
    metrics_settings_from_config,
    one_line_errors,
    run_name,
    study_from,
    study_requests,
)
from taskcomplexity.config import build
from taskcomplexity.pipeline.diagnostics_stage import DiagnosticsSettings, study_diagnostics
from taskcomplexity.pipeline.study import study_metrics, write_metrics_tables

log = logging.getLogger("study")


def _sac_curves(cfg: Any, cache, results):
    """Learning curves of every task of the study (None when SAC is switched off or unavailable).

    Tasks SAC skips (discrete actions) are listed in ``curves.attrs["sac_skipped"]`` ({id: reason}).
    """
    if not cfg.sac.get("enabled", True):
        return None
    try:
        from taskcomplexity.pipeline.sac_stage import study_sac_curves
    except ImportError:  # pragma: no cover - the SAC stage is optional at import time
        log.warning("SAC stage unavailable; the report will say so")
        return None
    study = study_from(cfg)  # each entry carries its SAC budget (sac_steps) and solved_return
    tasks = [(study.task(r.task_id), r.request.task) for r in results]
    return study_sac_curves(cache, tasks, cfg.sac, force=bool(cfg.force), progress=True)


@one_line_errors
def run_study(cfg: Any) -> Path:
    """Compute or reuse every artefact of the study and write its report; return index.html."""
    from taskcomplexity.report.build import build_report

    started = time.time()
    study = study_from(cfg)
    entries, requests = zip(*study_requests(cfg, study), strict=True)
    names = [entry.id for entry in entries]
    settings = metrics_settings_from_config(cfg)
    cache = cache_from_config(cfg)
    results = study_metrics(cache, list(requests), settings, names=list(names), force=bool(cfg.force), progress=True)
    name = run_name(cfg)
    write_metrics_tables(results, cfg.paths.outputs, name, alpha=settings.alpha)
    diagnostics = study_diagnostics(
        cache,
        {r.task_id: r.rwg for r in results},
        settings,
        build(DiagnosticsSettings, cfg.diagnostics, "diagnostics"),
        force=bool(cfg.force),
        progress=True,
    )
    ablation = None
    if study.kind == "variants":
        ablation = {f"{results[0].request.task.task_id}: prior and network variants":
                    {study.label(r.task_id): r for r in results}}
        sac = None
    else:
        sac = _sac_curves(cfg, cache, results)
    out_dir = Path(cfg.paths.outputs) / "reports" / name
    title = cfg.report.get("title") or f"How hard is each reaching task? ({name})"
    index = build_report(
        results, study=study, diagnostics=diagnostics, sac_curves=sac, out_dir=out_dir, title=title,
        ablation=ablation, alpha=settings.alpha,
    )
    elapsed = time.time() - started
    log.info("study %s done in %.0f s", name, elapsed)
    print(f"\nStudy '{name}' finished in {elapsed:.0f} s.\nReport: {index.resolve()}", flush=True)
    return index
