"""The report of a multirun sweep of a study: one cell per job (e.g. a network × prior), read from the jobs'
verdict artefacts.

Each study job of a multirun records itself in ``<job dir>/study.json`` (:data:`JOB_FILE`: the study,
its overrides, its verdict artefact and report); :func:`write_sweep_report` reads every job of a sweep
directory and writes, under ``<sweep dir>/sweep_report/``:

- ``sweep_correlations.{md,tex,csv}``: per cell, every metric's Pearson r with each reference score
  (Score(A), …) across the study's tasks, and the mean ± sd of r over the cells (the original PIC/POIC
  protocol's summary over its 28 architecture × prior cells);
- ``sweep_values.{md,tex,csv}``: per task, every metric and reference score as mean ± sd over cells;
- ``sweep_values_tidy.csv`` (cell, task, quantity, value) and ``sweep_correlations_tidy.csv`` (cell,
  quantity, reference, r, p, …): everything the tables show;
- ``README.md``: the tables in one page.

A cell is named by the overrides that differ between the jobs (``network=pic_h1_4 prior=uniform``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.report.format import MISSING, mean_sd, num
from taskcomplexity.report.tables import write_table
from taskcomplexity.verdict.references import reference_label

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


def sweep_tables(jobs: Sequence[dict], *, registry: Registry = DEFAULT_REGISTRY) -> dict[str, pd.DataFrame]:
    """The tidy tables of a sweep: ``values`` (cell, task, quantity, value) and ``correlations`` (cell,
    quantity, metric, reference, tasks, pearson_r, pearson_p, spearman_r, spearman_p), metrics only."""
    values, correlated = [], []
    for cell, job in zip(cell_names(jobs), jobs, strict=True):
        verdict = Path(job["verdict"])
        v = pd.read_parquet(verdict / "values.parquet").rename(columns={"metric": "quantity"})
        r = pd.read_parquet(verdict / "references.parquet").rename(columns={"reference": "quantity"})
        values.append(pd.concat([v, r], ignore_index=True).assign(cell=cell))
        c = pd.read_parquet(verdict / "correlations.parquet")
        correlated.append(c[c["quantity"] == c["metric"]].assign(cell=cell))
    values = pd.concat(values, ignore_index=True)[["cell", "task", "quantity", "value"]]
    correlated = pd.concat(correlated, ignore_index=True)
    return {"values": values, "correlations": correlated[["cell", *correlated.columns.drop("cell")]]}


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
        row = {"Cell": f"mean ± sd over {chosen['cell'].nunique()} cells", "Reference": reference_label(reference)}
        for m in metrics:
            r = chosen.loc[chosen["metric"] == m, "pearson_r"].to_numpy(dtype=float)
            r = r[np.isfinite(r)]
            sd = r.std(ddof=1) if r.size > 1 else np.nan
            row[registry.label(m)] = mean_sd(r.mean(), sd, 2) if r.size else MISSING
        rows.append(row)
    return pd.DataFrame(rows)


def value_table(values: pd.DataFrame, *, registry: Registry = DEFAULT_REGISTRY) -> pd.DataFrame:
    """Per task (rows), every metric and reference score (columns) as mean ± sd over the cells."""
    quantities = registry.order(values["quantity"])
    rows = []
    for task, group in values.groupby("task", sort=False):
        row = {"Task": task}
        for q in quantities:
            v = group.loc[group["quantity"] == q, "value"].to_numpy(dtype=float)
            v = v[np.isfinite(v)]
            label = registry.label(q) if q in registry else reference_label(q)
            row[label] = mean_sd(v.mean(), v.std(ddof=1) if v.size > 1 else np.nan) if v.size else MISSING
        rows.append(row)
    return pd.DataFrame(rows)


def write_sweep_report(sweep_dir: Path, *, registry: Registry = DEFAULT_REGISTRY) -> Path | None:
    """Write the sweep's tables under ``<sweep_dir>/sweep_report``; return its README.md (None: no study job)."""
    jobs = sweep_jobs(sweep_dir)
    if not jobs:
        return None
    tables = sweep_tables(jobs, registry=registry)
    out = Path(sweep_dir) / REPORT_DIR
    studies = ", ".join(dict.fromkeys(j["study"] for j in jobs))
    correlation = correlation_table(tables["correlations"], registry=registry)
    value = value_table(tables["values"], registry=registry)
    captions = {
        "sweep_correlations": f"Pearson r across tasks between each metric's easiness and each reference score, "
                              f"per cell of the sweep of {studies}, and its mean ± sd over the cells.",
        "sweep_values": "Every metric (point estimate) and reference score per task: mean ± sd over the cells.",
    }
    lines = [f"# Sweep of {studies}: {len(jobs)} cells", ""]
    for name, table in (("sweep_correlations", correlation), ("sweep_values", value)):
        write_table(table, out, name, caption=captions[name])
        lines += [f"**{captions[name]}**", "", table.to_markdown(index=False), ""]
    lines += ["Cells and their reports:", ""] + [f"- {cell}: {job['report']}" for cell, job in
                                                  zip(cell_names(jobs), jobs, strict=True)]
    tables["values"].to_csv(out / "sweep_values_tidy.csv", index=False)
    tables["correlations"].to_csv(out / "sweep_correlations_tidy.csv", index=False)
    readme = out / "README.md"
    readme.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return readme
