"""The report's tables of metrics, and the one writer of every table (Markdown, LaTeX and CSV side by side).

Rows are tasks in study order, named by the study (:mod:`taskcomplexity.report.labels`): indexed by
(group, task) when the study's tasks have groups, by task otherwise. Numbers use the formats of
:mod:`taskcomplexity.report.format`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import MISSING, latex_text, mean_sd, num, percent, pvalue, statistic
from taskcomplexity.report.labels import has_groups


def write_table(table: pd.DataFrame, directory: Path, name: str, *, caption: str = "") -> list[Path]:
    """Write ``name.md``, ``name.tex`` (pdflatex-safe) and ``name.csv``; return their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    flat = table.reset_index() if not isinstance(table.index, pd.RangeIndex) else table
    md, tex, csv = (directory / f"{name}.{suffix}" for suffix in ("md", "tex", "csv"))
    md.write_text((f"**{caption}**\n\n" if caption else "") + flat.to_markdown(index=False) + "\n", encoding="utf-8")
    latex = flat.to_latex(index=False, caption=caption or None, label=f"tab:{name}", escape=True)
    tex.write_text(latex_text(latex.replace("±", r"$\pm$")), encoding="utf-8")
    flat.to_csv(csv, index=False)
    return [md, tex, csv]


def task_columns(data: StudyData, task: str) -> dict[str, str]:
    """The columns naming a task: ``Group`` and ``Task`` (its label) when the study has groups, else ``Task``."""
    style = data.styles.get(task)
    if style is None:
        return {"Task": task}
    if has_groups(data.styles):
        return {"Group": style.group or "", "Task": style.label}
    return {"Task": style.name}


def table1(data: StudyData) -> pd.DataFrame:
    """Table 1 of the paper: every bootstrapped metric as bootstrap mean ± sd, one row per task, and beside
    each metric with a permutation null the share of its value that the null gives (its estimator's bias,
    from the verdict's information check; missing without diagnostics)."""
    metrics = [m for m in data.registry.of_stage("metrics") if m.bootstrapped]
    shares = null_shares(data)
    rows = []
    for _, r in data.metrics.iterrows():
        row = task_columns(data, r["task"])
        for m in metrics:
            row[m.label] = mean_sd(r.get(f"{m.name}_mean", np.nan), r.get(f"{m.name}_sd", np.nan))
            if m.information is not None and m.information.null and not m.information.net_of_null:
                row[f"{m.short} null share"] = percent(shares.get((m.name, r["task"]), np.nan))
        rows.append(row)
    return pd.DataFrame(rows)


def null_shares(data: StudyData) -> dict[tuple[str, str], float]:
    """(metric, task) → the share of the value its permutation null gives (the verdict's information table)."""
    checked = data.verdict.get("information")
    if checked is None or checked.empty:
        return {}
    return {(m, t): float(v) for m, t, v in zip(checked["metric"], checked["task"], checked["null_share"], strict=True)}


def interval_table(data: StudyData) -> pd.DataFrame:
    """Point estimate and bootstrap percentile 95 % interval of every bootstrapped metric, and the details
    that are not plotted (e.g. λ*, flagged when on a boundary of its search range)."""
    metrics = [m for m in data.registry.of_stage("metrics") if m.bootstrapped]
    rows = []
    for _, r in data.metrics.iterrows():
        row = task_columns(data, r["task"])
        for m in metrics:
            row[m.label] = num(r[m.name])
            low, high = (num(r.get(f"{m.name}_ci_{side}", np.nan), like=r[m.name]) for side in ("low", "high"))
            row[f"{m.label} 95 % interval"] = f"[{low}, {high}]"
        if "temperature" in r and "temperature_at_boundary" in r:
            row["λ*"] = f"{r['temperature']:.3g}" + (" (boundary)" if bool(r["temperature_at_boundary"]) else "")
        rows.append(row)
    return pd.DataFrame(rows)


def statistics_table(data: StudyData) -> pd.DataFrame:
    """N, M, and every metric of the metrics stage that is not bootstrapped with its details, per task."""
    metrics = data.registry.of_stage("metrics")
    columns = [(d.name, d.label) for m in metrics for d in m.details if m.bootstrapped and d.shown]
    columns = [(d.name, d.label) for m in metrics for d in m.details if not m.bootstrapped] + [
        (m.name, m.label) for m in metrics if not m.bootstrapped] + columns
    rows = []
    for _, r in data.metrics.iterrows():
        row = {**task_columns(data, r["task"]), "N": int(r["policies"]), "M": int(r["episodes"])}
        row.update({label: num(r[name]) for name, label in columns if name in r})
        rows.append(row)
    return pd.DataFrame(rows)


def welch_display(data: StudyData, metric: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(display matrix with task names, tidy tests) of the verdict stage's Welch tests of ``metric``."""
    tests = data.verdict["welch"]
    tests = tests[tests["metric"] == metric].drop(columns="metric")
    tasks = [t for t in data.tasks if t in set(tests["task_a"])]
    cells = tests.assign(cell=[MISSING if not np.isfinite(p) else f"{statistic(t)} ({pvalue(p)})"
                               for t, p in zip(tests["statistic"], tests["pvalue"], strict=True)])
    matrix = cells.pivot(index="task_a", columns="task_b", values="cell").reindex(index=tasks, columns=tasks)
    matrix = matrix.fillna("").rename(index=data.name, columns=data.name)
    matrix.columns.name = None
    matrix.index.name = "row vs column"
    return matrix.reset_index(), tests


def diagnostics_display(data: StudyData) -> pd.DataFrame:
    """Per task: histogram PIC and POIC against their permutation null, and every diagnostics-stage metric."""
    metrics = data.registry.of_stage("diagnostics")
    rows = []
    for task in data.tasks:
        if task not in data.diagnostics:
            continue
        e = data.diagnostics[task]["estimators"].iloc[0]
        z = data.diagnostics[task]["null_summary"].set_index("metric")["z"]
        row = {**task_columns(data, task), "PIC": num(e["pic"]),
               "PIC null": mean_sd(e["pic_null_mean"], e["pic_null_sd"])}
        for m in metrics:
            row[m.label] = num(e[m.name], like=e["pic"]) if m.name in e else MISSING
        row["PIC − null (z)"] = num(z.get("pic", np.nan), 2)
        row["POIC"] = num(e["poic"])
        row["POIC − null (z)"] = f"{num(e['poic_minus_null'], like=e['poic'])} ({num(z.get('poic', np.nan), 2)})"
        rows.append(row)
    return pd.DataFrame(rows)


def bins_display(data: StudyData) -> pd.DataFrame:
    """Histogram PIC (Miller–Madow in parentheses) per task and number of bins."""
    rows = []
    for task in data.tasks:
        if task not in data.diagnostics:
            continue
        row = task_columns(data, task)
        for _, s in data.diagnostics[task]["bins_sweep"].iterrows():
            row[f"B = {int(s['bins']):,}"] = f"{num(s['pic'], 2)} ({num(s['pic_miller_madow'], 2)})"
        rows.append(row)
    return pd.DataFrame(rows)
