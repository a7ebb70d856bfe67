"""The SAC summary table: mean ± sd across seeds per (task, variant), tasks named by the study."""

from __future__ import annotations

import numpy as np
import pandas as pd

from taskcomplexity.metrics.sac import sac_summary
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.tables import task_columns


def format_sac_summary(data: StudyData, *, digits: int = 3) -> pd.DataFrame:
    """Human-readable mean ± sd of :func:`~taskcomplexity.metrics.sac.sac_summary` of the verdict's per-seed
    table, tasks in study order."""
    def pm(mean: float, sd: float, fmt: str) -> str:
        if not np.isfinite(mean):
            return "–"
        return format(mean, fmt) if not np.isfinite(sd) else f"{format(mean, fmt)} ± {format(sd, fmt)}"

    summary = sac_summary(data.sac_per_seed)
    order = {t: i for i, t in enumerate(data.tasks)}
    summary = summary.sort_values("task", key=lambda s: s.map(lambda t: order.get(t, len(order))), kind="stable")
    rows = []
    for _, r in summary.iterrows():
        rows.append({
            **task_columns(data, r["task"]),
            "Variant": r["variant"],
            "Seeds": int(r["seeds"]),
            "Budget (steps)": f"{int(r['budget']):,}",
            "Final return": pm(r["final_return_mean"], r["final_return_sd"], ".2f"),
            "Final (normalised)": pm(r["final_normalised_mean"], r["final_normalised_sd"], f".{digits}f"),
            "AUC (normalised)": pm(r["auc_normalised_mean"], r["auc_normalised_sd"], f".{digits}f"),
            "Steps to 90 %": pm(r["steps_to_90_mean"], r["steps_to_90_sd"], ",.0f")
            + ("" if r["improved"] == r["seeds"] else f" ({int(r['improved'])}/{int(r['seeds'])} improved)"),
        })
    return pd.DataFrame(rows)
