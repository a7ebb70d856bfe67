"""Across tasks: pull every task's RWG and metrics artefacts, and write the study's tables."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from taskcomplexity import metrics as est
from taskcomplexity.pipeline.cache import Artefact, Cache
from taskcomplexity.pipeline.metrics_stage import MetricsSettings, run_metrics_stage
from taskcomplexity.pipeline.rwg_stage import RWGRequest, run_rwg_stage
from taskcomplexity.report.tables import table1, write_table

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TaskMetrics:
    """One task's artefacts."""

    task_id: str
    request: RWGRequest
    rwg: Artefact
    metrics: Artefact

    def table(self, name: str) -> pd.DataFrame:
        return pd.read_parquet(self.metrics.file(name))


def study_metrics(
    cache: Cache,
    requests: list[RWGRequest],
    settings: MetricsSettings,
    *,
    names: list[str] | None = None,
    force: bool = False,
    progress: bool = False,
) -> list[TaskMetrics]:
    """Compute or reuse the RWG and metrics artefacts of every task, in the order given.

    ``names`` are the entries' ids (default: their task ids).
    """
    names = names or [r.task.task_id for r in requests]
    results = []
    for i in range(len(requests)):
        request = requests[i]
        rwg, rwg_hit = run_rwg_stage(cache, request, force=force, progress=progress)
        metrics, hit = run_metrics_stage(cache, rwg, settings, label=request.label, force=force, progress=progress)
        log.info(
            "%s: rwg %s, metrics %s", request.task.task_id, "cache hit" if rwg_hit else "computed",
            "cache hit" if hit else "computed",
        )
        results.append(TaskMetrics(names[i], request, rwg, metrics))
    return results


def metrics_frame(results: list[TaskMetrics]) -> pd.DataFrame:
    """One row per task: point estimates and bootstrap summaries."""
    return pd.concat([r.table("metrics.parquet").assign(task=r.task_id) for r in results], ignore_index=True)


def welch_tables(results: list[TaskMetrics], metric: str, *, alpha: float) -> pd.DataFrame:
    """Tidy Welch tests of ``metric`` between every pair of tasks, on their 5 batch estimates."""
    samples = {r.task_id: r.table("batches.parquet")[metric].to_numpy() for r in results}
    return est.welch_matrix(samples, alpha=alpha)


def write_metrics_tables(results: list[TaskMetrics], outputs: str | Path, study: str, *, alpha: float) -> list[Path]:
    """Table 1 and the Welch matrices of PIC and POIC under ``<outputs>/tables/<study>/``."""
    directory = Path(outputs) / "tables" / study
    frame = metrics_frame(results)
    written = write_table(
        table1(frame), directory, "table1_pic_poic",
        caption="PIC and POIC of random policies (bootstrap mean ± sd, nats)",
    )
    for metric in ("pic", "poic"):
        tests = welch_tables(results, metric, alpha=alpha)
        matrix = est.format_welch_matrix(tests)
        matrix.index.name = "task"
        written += write_table(
            matrix, directory, f"welch_{metric}",
            caption=f"Welch's t-test on 5 batch estimates of {metric.upper()}: statistic (p-value), row vs column",
        )
        tests.to_csv(directory / f"welch_{metric}_tidy.csv", index=False)
    return written
