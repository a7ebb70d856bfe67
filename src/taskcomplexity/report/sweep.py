"""The report of a multirun sweep of a study: one cell per job (e.g. a network × prior), read from the jobs'
verdict artefacts.

Each study job of a multirun records itself in ``<job dir>/study.json`` (:data:`JOB_FILE`: the study,
its overrides, its tasks' labels, its verdict artefact and report); :func:`write_sweep_report` reads every
job of a sweep directory and writes, under ``<sweep dir>/sweep_report/``:

- ``sweep_verdict.{md,tex,csv}``: per cell and primary metric, the counts of agree / contradict / not
  significant (and uninformative or undefined when any) over the study's known relations, and the
  relations it contradicts, tasks named by their labels;
- ``sweep_correlations.{md,tex,csv}``: per cell, every metric's Pearson r with each reference score
  (Score(A), …) across the study's tasks, and the mean ± sd of r over the cells (the original PIC/POIC
  protocol's summary over its 28 architecture × prior cells);
- ``sweep_bag_correlations.{md,tex,csv}``: every metric's Pearson r with each reference score across the tasks,
  both averaged over the cells first (the cells as one bag, as the PIC paper's Table 11 treats its 56
  architectures and priors);
- ``sweep_values.{md,tex,csv}``: per task, every metric and reference score as mean ± sd over cells;
- ``sweep_values_tidy.csv`` (cell, task, quantity, value), ``sweep_correlations_tidy.csv`` (cell,
  quantity, reference, r, p, …) and ``sweep_verdict_tidy.csv`` (cell, metric, relation, outcome, p):
  everything the tables show;
- ``README.md``: the tables in one page.

A table without rows (no reference scores: no correlations; no relations: no verdict) is not written; the
README says in one line why it is missing.

A cell is named by the overrides that differ between the jobs (``network=pic_h1_4 prior=uniform``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.report.format import MISSING, mean_sd, num, plural, pvalue
from taskcomplexity.report.outcomes import OUTCOME_DISPLAY
from taskcomplexity.report.tables import write_table
from taskcomplexity.verdict.references import correlation, on_values, reference_label

JOB_FILE = "study.json"
"""What a study job of a multirun writes into its Hydra job directory."""
REPORT_DIR = "sweep_report"


def sweep_jobs(sweep_dir: Path) -> list[dict]:
    """The recorded study jobs of a sweep directory, in job order (jobs without a record are skipped)."""
    jobs = []
    for path in sorted(Path(sweep_dir).glob(f"*/{JOB_FILE}"), key=lambda p: (len(p.parent.name), p.parent.name)):
        job = json.loads(path.read_text(encoding="utf-8"))
        job["dir"] = str(path.parent)
        jobs.append(job)
    return jobs


def cell_names(jobs: Sequence[dict]) -> list[str]:
    """Each job's name: its overrides that differ between the jobs (all of them when every job has the same)."""
    pairs = [dict(o.split("=", 1) for o in job["overrides"] if "=" in o) for job in jobs]
    keys = list(dict.fromkeys(k for p in pairs for k in p))
    varying = [k for k in keys if len({p.get(k) for p in pairs}) > 1] or keys
    return [" ".join(f"{k.lstrip('+~')}={p[k]}" for k in varying if k in p) or f"job {i}"
            for i, p in enumerate(pairs)]


def task_labels(jobs: Sequence[dict]) -> dict[str, str]:
    """Task id → its label in the study, from the jobs' records (ids without one keep their id)."""
    labels: dict[str, str] = {}
    for job in jobs:
        for task, label in (job.get("labels") or {}).items():
            labels.setdefault(task, label)
    return labels


def sweep_tables(jobs: Sequence[dict], *, registry: Registry = DEFAULT_REGISTRY) -> dict[str, pd.DataFrame]:
    """The tidy tables of a sweep: ``values`` (cell, task, quantity, value), ``correlations`` (cell,
    quantity, metric, reference, tasks, pearson_r, pearson_p, spearman_r, spearman_p), metrics only, and
    ``verdict`` (cell, metric, easier, harder, kind, outcome, pvalue)."""
    values, correlated, verdicts = [], [], []
    for cell, job in zip(cell_names(jobs), jobs, strict=True):
        verdict = Path(job["verdict"])
        v = pd.read_parquet(verdict / "values.parquet").rename(columns={"metric": "quantity"})
        r = pd.read_parquet(verdict / "references.parquet").rename(columns={"reference": "quantity"})
        values.append(pd.concat([t for t in (v, r) if not t.empty], ignore_index=True).assign(cell=cell))
        c = on_values(pd.read_parquet(verdict / "correlations.parquet"))
        correlated.append(c[c["quantity"] == c["metric"]].assign(cell=cell))
        judged = pd.read_parquet(verdict / "verdict.parquet")
        verdicts.append(judged[["metric", "easier", "harder", "kind", "outcome", "pvalue"]].assign(cell=cell))
    values = pd.concat(values, ignore_index=True)[["cell", "task", "quantity", "value"]]
    correlated = pd.concat(correlated, ignore_index=True)
    verdicts = pd.concat(verdicts, ignore_index=True)
    return {"values": values, "correlations": correlated[["cell", *correlated.columns.drop("cell")]],
            "verdict": verdicts[["cell", *verdicts.columns.drop("cell")]]}


def verdict_table(verdicts: pd.DataFrame, *, registry: Registry = DEFAULT_REGISTRY,
                  labels: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Per cell and primary metric: how many known relations it agrees with, contradicts, leaves not
    significant (and, when any cell has them, uninformative or undefined), and the relations it contradicts.

    Parameters
    ----------
    verdicts : pandas.DataFrame
        The sweep's tidy verdict (:func:`sweep_tables`).
    registry : Registry
        The primary metrics (all judged metrics when none is primary) and their labels.
    labels : mapping of task id to label, optional
        How the relations name the tasks.

    Returns
    -------
    pandas.DataFrame
        ``Cell``, ``Metric``, ``Relations``, one count column per outcome shown, ``Contradicted``; no
        rows when the study gives no relation.
    """
    labels = labels or {}
    judged = registry.order(verdicts["metric"])
    metrics = [m for m in judged if m in registry and registry[m].primary] or judged
    chosen = verdicts[verdicts["metric"].isin(metrics)]
    always = ("agree", "contradict", "not significant")
    present = [o for o in OUTCOME_DISPLAY if o in always or (chosen["outcome"] == o).any()]
    present += [o for o in dict.fromkeys(chosen["outcome"]) if o not in present]
    rows = []
    for cell in dict.fromkeys(chosen["cell"]):
        for metric in metrics:
            own = chosen[(chosen["cell"] == cell) & (chosen["metric"] == metric)]
            if own.empty:
                continue
            row = {"Cell": cell, "Metric": registry.label(metric), "Relations": len(own)}
            row.update({outcome[:1].upper() + outcome[1:]: int((own["outcome"] == outcome).sum())
                        for outcome in present})
            against = own[own["outcome"] == "contradict"]
            row["Contradicted"] = "; ".join(f"{labels.get(a, a)} < {labels.get(b, b)}"
                                            for a, b in zip(against["easier"], against["harder"], strict=True)
                                            ) or MISSING
            rows.append(row)
    return pd.DataFrame(rows)


def correlation_table(correlated: pd.DataFrame, *, registry: Registry = DEFAULT_REGISTRY) -> pd.DataFrame:
    """Per cell (rows) and metric (columns), Pearson r with each reference; last rows: mean ± sd over cells."""
    rows = []
    references = list(dict.fromkeys(correlated["reference"]))
    metrics = registry.order(correlated["metric"])
    for cell, group in correlated.groupby("cell", sort=False):
        indexed = group.set_index(["reference", "metric"])["pearson_r"]
        for reference in references:
            row = {"Cell": cell, "Reference": reference_label(reference)}
            row.update({registry.label(m): num(indexed.get((reference, m), np.nan), 2) for m in metrics})
            rows.append(row)
    for reference in references:
        chosen = correlated[correlated["reference"] == reference]
        row = {"Cell": f"mean ± sd over {plural(chosen['cell'].nunique(), 'cell')}",
               "Reference": reference_label(reference)}
        for m in metrics:
            r = chosen.loc[chosen["metric"] == m, "pearson_r"].to_numpy(dtype=float)
            r = r[np.isfinite(r)]
            sd = r.std(ddof=1) if r.size > 1 else np.nan
            row[registry.label(m)] = mean_sd(r.mean(), sd, 2) if r.size else MISSING
        rows.append(row)
    return pd.DataFrame(rows)


def bag_correlation_table(values: pd.DataFrame, *, registry: Registry = DEFAULT_REGISTRY) -> pd.DataFrame:
    """Pearson r (p) across tasks between each metric's mean over the cells and each reference score's mean over
    the cells: the sweep's cells taken as one bag of policy families, as the PIC paper's Table 11 correlates its
    bag of 56 architectures and priors. No rows without reference scores.

    Parameters
    ----------
    values : pandas.DataFrame
        The sweep's tidy values (:func:`sweep_tables`): metrics by their value, reference scores by name.
    registry : Registry
        The metrics (their easiness: a metric where lower is easier is negated, as the cells' correlations are).

    Returns
    -------
    pandas.DataFrame
        ``Metric``, then ``r with <reference> (p)`` per reference score, and ``Tasks``.
    """
    means = values.groupby(["task", "quantity"], sort=False)["value"].mean().unstack("quantity")
    references = [q for q in means.columns if q not in registry and reference_label(q) != q]
    rows = []
    for metric in registry.order([q for q in means.columns if q in registry]):
        easiness = means[metric] * (1.0 if registry[metric].higher_is_easier else -1.0)
        row = {"Metric": registry.label(metric)}
        tasks = 0
        for reference in references:
            keep = np.isfinite(easiness.to_numpy(dtype=float)) & np.isfinite(means[reference].to_numpy(dtype=float))
            r, p = correlation(scipy.stats.pearsonr, means[reference].to_numpy(dtype=float)[keep],
                               easiness.to_numpy(dtype=float)[keep])
            row[f"r with {reference_label(reference)} (p)"] = f"{num(r, 2)} ({pvalue(p)})"
            tasks = max(tasks, int(keep.sum()))
        row["Tasks"] = tasks
        rows.append(row)
    return pd.DataFrame(rows) if references else pd.DataFrame()


def value_table(values: pd.DataFrame, *, registry: Registry = DEFAULT_REGISTRY,
                labels: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Per task (rows, named by ``labels``), every metric and reference score (columns) as mean ± sd over the
    cells."""
    quantities = registry.order(values["quantity"])
    rows = []
    for task, group in values.groupby("task", sort=False):
        row = {"Task": (labels or {}).get(task, task)}
        for q in quantities:
            v = group.loc[group["quantity"] == q, "value"].to_numpy(dtype=float)
            v = v[np.isfinite(v)]
            label = registry.label(q) if q in registry else reference_label(q)
            row[label] = mean_sd(v.mean(), v.std(ddof=1) if v.size > 1 else np.nan) if v.size else MISSING
        rows.append(row)
    return pd.DataFrame(rows)


def write_sweep_report(sweep_dir: Path, *, registry: Registry = DEFAULT_REGISTRY) -> Path | None:
    """Write the sweep's tables under ``<sweep_dir>/sweep_report``; return its README.md (None: no study job).

    A table without rows is not written: the README says in one line why it is missing.
    """
    jobs = sweep_jobs(sweep_dir)
    if not jobs:
        return None
    tables = sweep_tables(jobs, registry=registry)
    labels = task_labels(jobs)
    out = Path(sweep_dir) / REPORT_DIR
    out.mkdir(parents=True, exist_ok=True)
    studies = ", ".join(dict.fromkeys(j["study"] for j in jobs))
    cells = plural(len(jobs), "cell")
    primary = [registry.label(m.name) for m in registry if m.primary]
    shown = [
        ("sweep_verdict", verdict_table(tables["verdict"], registry=registry, labels=labels),
         f"Verdict per cell of the sweep of {studies}: for each primary metric ({', '.join(primary)}), how many of "
         "the study's known relations it agrees with, contradicts or leaves not significant (Welch's test), and "
         "the relations it contradicts.",
         "No verdict table: the study gives no known relation between its tasks, so no cell has a verdict."),
        ("sweep_correlations", correlation_table(tables["correlations"], registry=registry),
         f"Pearson r across tasks between each metric's easiness and each reference score, per cell of the sweep "
         f"of {studies}, and its mean ± sd over the cells.",
         "No correlation table: the study gives no reference scores (reference or algorithm_scores) to correlate "
         "the metrics with."),
        ("sweep_bag_correlations", bag_correlation_table(tables["values"], registry=registry),
         f"Pearson r (p) across tasks between each metric's easiness and each reference score, both averaged over "
         f"the {cells} first: the cells as one bag of policy families, as the PIC paper's Table 11 correlates its "
         "bag of 56 architectures and priors.",
         "No bag correlation table: the study gives no reference scores to correlate the metrics with."),
        ("sweep_values", value_table(tables["values"], registry=registry, labels=labels),
         f"Every metric (point estimate) and reference score per task: mean ± sd over the {cells}.",
         "No values table: no cell has a metric value."),
    ]
    lines = [f"# Sweep of {studies}: {cells}", ""]
    for name, table, caption, missing in shown:
        for stale in out.glob(f"{name}.*"):
            stale.unlink()
        if table.empty:
            lines += [missing, ""]
            continue
        write_table(table, out, name, caption=caption)
        lines += [f"**{caption}**", "", table.to_markdown(index=False), ""]
    lines += ["Cells and their reports:", ""] + [f"- {cell}: {job['report']}" for cell, job in
                                                  zip(cell_names(jobs), jobs, strict=True)]
    for name, tidy in tables.items():
        path = out / f"sweep_{name}_tidy.csv"
        path.unlink(missing_ok=True)
        if not tidy.empty:
            tidy.to_csv(path, index=False)
    readme = out / "README.md"
    readme.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return readme
