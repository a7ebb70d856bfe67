"""Everything the report reads, loaded from the stages' artefacts (the report computes no metric).

The report receives the artefacts as objects with ``key``, ``manifest`` and ``file(name)`` (the
cache's artefacts) and each task's ``task_id``, ``request``, ``rwg`` and ``metrics`` (the study's
per-task results); it reads their files and never imports the stages.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from taskcomplexity.metrics.registry import Registry
from taskcomplexity.report.labels import TaskStyle, task_styles
from taskcomplexity.study_data import Study

DIAGNOSTIC_FILES = ("null", "null_summary", "bins_sweep", "subsample_sweep", "estimators", "batches")
VERDICT_FILES = ("verdict", "summary", "references", "correlations", "values", "samples", "welch", "information",
                 "replications")
SAC_FILE = "sac_per_seed"
GROUP_FILES = ("groups", "group_relations")
"""Verdict tables of a study with ordered difficulty groups (absent otherwise: ``StudyData.verdict`` lacks them)."""


@dataclass
class StudyData:
    """The artefacts of a study, per task id in study order.

    Attributes
    ----------
    study : Study
        The study.
    registry : Registry
        The metrics (labels, units, directions).
    tasks : list of str
        Task ids with artefacts, in study order.
    styles : dict of task id to TaskStyle
        Names, colours, markers, groups.
    results : dict of task id to the task's results
        ``request``, ``rwg`` and ``metrics`` artefacts (for the methods box).
    metrics : pandas.DataFrame
        One row per task: ``task`` and the columns of ``metrics.parquet``.
    policies, returns, bootstrap : dict of task id to table or (N, M) array
        ``policies.parquet``, the return matrix, ``bootstrap.parquet``.
    diagnostics : dict of task id to dict of name to pandas.DataFrame
        The diagnostics tables of the tasks that have them.
    diagnostics_config : dict
        The diagnostics settings (from a manifest).
    verdict : dict of name to pandas.DataFrame
        The verdict stage's tables (:data:`VERDICT_FILES`).
    sac_per_seed : pandas.DataFrame or None
        Per-seed SAC summary of the verdict stage.
    verdict_key : str
        Key of the verdict artefact.
    """

    study: Study
    registry: Registry
    tasks: list[str]
    styles: dict[str, TaskStyle]
    results: dict[str, Any]
    metrics: pd.DataFrame
    policies: dict[str, pd.DataFrame]
    returns: dict[str, np.ndarray]
    bootstrap: dict[str, pd.DataFrame]
    verdict: dict[str, pd.DataFrame]
    sac_per_seed: pd.DataFrame | None = None
    verdict_key: str = ""
    diagnostics: dict[str, dict[str, pd.DataFrame]] = field(default_factory=dict)
    diagnostics_config: dict = field(default_factory=dict)

    def name(self, task: str) -> str:
        """Display name of a task id."""
        return self.styles[task].name if task in self.styles else task


def return_matrix(artefact: Any) -> np.ndarray:
    """The (N, M) return matrix of an RWG artefact's ``returns.parquet`` (tidy policy, episode, return)."""
    frame = pd.read_parquet(artefact.file("returns.parquet"), columns=["policy", "episode", "return"])
    matrix = np.full((int(frame["policy"].max()) + 1, int(frame["episode"].max()) + 1), np.nan)
    matrix[frame["policy"].to_numpy(), frame["episode"].to_numpy()] = frame["return"].to_numpy()
    return matrix


def load_study_data(
    results: Sequence[Any],
    study: Study,
    verdict: Any,
    *,
    registry: Registry,
    diagnostics: Mapping[str, Any] | None = None,
) -> StudyData:
    """Read every artefact of the study; tasks without a diagnostics artefact have no diagnostics."""
    order = {task_id: i for i, task_id in enumerate(study.ids)}
    ordered = sorted(results, key=lambda r: order.get(r.task_id, len(order)))
    tasks = [r.task_id for r in ordered]
    diagnostics = {t: a for t, a in (diagnostics or {}).items() if t in tasks}
    loaded = {t: {name: pd.read_parquet(a.file(f"{name}.parquet")) for name in DIAGNOSTIC_FILES}
              for t, a in diagnostics.items()}
    tables = {name: pd.read_parquet(verdict.file(f"{name}.parquet")) for name in VERDICT_FILES}
    if study.groups is not None:
        tables.update({name: pd.read_parquet(verdict.file(f"{name}.parquet")) for name in GROUP_FILES})
    sac = verdict.file(f"{SAC_FILE}.parquet")
    return StudyData(
        study=study,
        registry=registry,
        tasks=tasks,
        styles=task_styles(study, tasks),
        results={r.task_id: r for r in ordered},
        metrics=pd.concat([pd.read_parquet(r.metrics.file("metrics.parquet")).assign(task=r.task_id)
                           for r in ordered], ignore_index=True),
        policies={r.task_id: pd.read_parquet(r.metrics.file("policies.parquet")) for r in ordered},
        returns={r.task_id: return_matrix(r.rwg) for r in ordered},
        bootstrap={r.task_id: pd.read_parquet(r.metrics.file("bootstrap.parquet")) for r in ordered},
        verdict=tables,
        sac_per_seed=pd.read_parquet(sac) if sac.is_file() else None,
        verdict_key=verdict.key,
        diagnostics=loaded,
        diagnostics_config=next((a.manifest.get("config", {}) for a in diagnostics.values()), {}),
    )
