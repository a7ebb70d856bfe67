"""The methods box: sampling, estimators, tests, directions, diagnostics, SAC and software, from the manifests."""

from __future__ import annotations

import numpy as np
import pandas as pd

from taskcomplexity.metrics.registry import Metric
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import joined, plural


def direction(metric: Metric) -> str:
    """"higher = easier" or "lower = easier": the one wording of a metric's direction."""
    return f"{'higher' if metric.higher_is_easier else 'lower'} = easier"


def computed_metrics(data: StudyData) -> list[Metric]:
    """The registered metrics with a finite value for some task of this study (the verdict's ``values``)."""
    values = data.verdict["values"]
    finite = set(values.loc[np.isfinite(values["value"].to_numpy(dtype=np.float64)), "metric"])
    return [m for m in data.registry if m.name in finite]


def directions_text(data: StudyData) -> str:
    """The direction of every metric this study computed, metrics sharing a direction and a reason together."""
    groups: dict[tuple[str, str], list[str]] = {}
    for metric in computed_metrics(data):
        groups.setdefault((direction(metric), metric.why), []).append(metric.label)
    if not groups:
        return "no metric has a value in this study"
    return "; ".join(f"{', '.join(labels)}: {way}" + (f" ({why})" if why else "")
                     for (way, why), labels in groups.items())


def float32_note(requests) -> str:
    """The methods box's words for tasks whose returns come from a float32 forward pass (``rwg.precision``), or ""."""
    narrow = sum(getattr(r.settings, "precision", "float64") != "float64" for r in requests)
    if not narrow:
        return ""
    rest = "" if narrow == len(requests) else " (the others float64)"
    return f"; the policies' forward pass in float32 on {narrow} of {len(requests)} tasks{rest}"


def _span(jobs: list[str]) -> str:
    """Job ids, one array's tasks as a range: ``12_0–12_7`` (else listed)."""
    arrays = {job.split("_")[0] for job in jobs}
    tasks = [job.split("_", 1)[1] for job in jobs if "_" in job]
    if len(arrays) == 1 and len(tasks) == len(jobs) > 2 and all(t.isdigit() for t in tasks):
        ordered = sorted(jobs, key=lambda job: int(job.split("_")[1]))
        return f"{ordered[0]}–{ordered[-1]}"
    return ", ".join(jobs)


def where_it_ran(data: StudyData, records: dict[str, list[dict]], stage: str) -> str:
    """The methods box's line on where a stage's artefacts were computed, from their manifests' ``jobs``
    (``records``: study task id → :class:`taskcomplexity.jobs.JobRecord` dicts, one per process that computed a part;
    a requeued or rerun job has one per attempt): per scheduler its jobs, nodes and tasks, how many attempts resumed
    saved work, and the CPU the jobs recorded for their parts (``stage``: the stage's name in the sentence)."""
    parts = []
    for scheduler in dict.fromkeys(r["scheduler"] for rows in records.values() for r in rows):
        mine = {task: [r for r in rows if r["scheduler"] == scheduler] for task, rows in records.items()}
        mine = {task: rows for task, rows in mine.items() if rows}
        jobs = list(dict.fromkeys(r["job"] for rows in mine.values() for r in rows))
        nodes = ", ".join(dict.fromkeys(r["node"] for rows in mine.values() for r in rows))
        per_task = {len({r["job"] for r in rows}) for rows in mine.values()}
        what = (f"{plural(len(jobs), 'SLURM job')} ({_span(jobs)})" if scheduler == "slurm"
                else f"{plural(len(jobs), 'process', 'processes')} ({', '.join(jobs)})")
        if len(mine) > 1 and len(per_task) == 1 and per_task != {1}:
            what += f", {per_task.pop()} per task"
        tasks = "every task" if len(mine) == len(records) else "; ".join(data.name(t) for t in mine)
        resumed = sum(1 for rows in mine.values() for r in rows if r.get("reused", 0))
        parts.append(f"{what} on {nodes} ({tasks})" + (f", {plural(resumed, 'attempt')} resumed saved work"
                                                      if resumed else ""))
    unrecorded = [data.name(t) for t, rows in records.items() if not rows]
    if unrecorded:
        parts.append(f"not recorded ({'; '.join(unrecorded)})")
    cpu = sum(r.get("cpu_seconds", 0.0) for rows in records.values() for r in rows)
    return "; ".join(parts) + f"; {cpu:,.1f} CPU-s of {stage} in all, as the jobs recorded it"


def methods(data: StudyData, sac_curves: pd.DataFrame | None, *, alpha: float) -> tuple[tuple[str, str], ...]:
    """(what, value) pairs of the methods box."""
    requests = [data.results[t].request for t in data.tasks]
    metrics_config = data.results[data.tasks[0]].metrics.manifest.get("config", {})
    network = "; ".join(dict.fromkeys(r.network.describe() for r in requests))  # descriptions hold commas
    prior = joined(r.prior.kind + (f" (variance {r.prior.variance:g})" if r.prior.kind == "normal" else "")
                   for r in requests)
    steps = joined(getattr(r.task, "max_steps", None) or "the env's own limit of" for r in requests)
    directions = directions_text(data)
    items = [
        ("Tasks", f"{len(data.tasks)}: " + "; ".join(data.name(t) for t in data.tasks)),
        ("Random policies", f"{network}; weight prior {prior}; deterministic actions"),
        ("Sampling", f"N = {joined(r.settings.policies for r in requests)} policies × M = "
                     f"{joined(r.settings.episodes for r in requests)} episodes per task, {steps} steps per "
                     f"episode, seed {joined(r.settings.seed for r in requests)}, "
                     f"backend {joined(r.backend for r in requests)}"
                     + ("; contacts from the batched contact model"
                        if any(getattr(r, "models_contacts", False) for r in requests) else "")
                     + float32_note(requests)),
        ("PIC", f"histogram with B = {int(metrics_config.get('bins', 0)):,} equal-width bins, nats"),
        ("POIC", "deterministic temperature search over λ ∈ "
                 f"[{', '.join(f'{x:g}' for x in metrics_config.get('temperature_range', []))}]"),
        ("Uncertainty", f"bootstrap of the policies, {metrics_config.get('resamples', '?')} resamples "
                        f"(seed {metrics_config.get('seed', '?')}), percentile 95 % intervals"),
        ("Significance", f"Welch's t-test, two-sided, on {metrics_config.get('batches', '?')} consecutive "
                         f"policy batches (SAC: on seeds); significant when p < {alpha:g}"),
        ("Directions", directions),
    ]
    if data.diagnostics:
        c = data.diagnostics_config
        items.append(("Diagnostics", f"permutation null × {c.get('repeats', '?')} (seed {c.get('seed', '?')}); "
                                     f"bins sweep {joined(c.get('bins_sweep', []))} (up to B); Miller–Madow; "
                                     f"k-NN MI (k = {c.get('knn_neighbors', '?')})"))
    else:
        items.append(("Diagnostics", "not computed"))
    if sac_curves is not None and not sac_curves.empty:
        seeds = sorted(sac_curves["seed"].unique().tolist())
        budgets = sorted(sac_curves.groupby("task")["env_step"].max().unique())
        items.append(("SAC", f"variants {joined(sorted(sac_curves['variant'].unique()))}; seeds "
                             f"{', '.join(map(str, seeds))}; budgets {joined(f'{int(b):,}' for b in budgets)} "
                             "env steps per seed"))
    else:
        items.append(("SAC", "not computed"))
    skipped = (sac_curves.attrs.get("sac_skipped") or {}) if sac_curves is not None else {}
    if skipped:
        items.append(("SAC skipped", "; ".join(f"{data.name(t)}: {why}" for t, why in skipped.items())))
    versions = {}
    for task in data.tasks:
        for artefact in (data.results[task].rwg, data.results[task].metrics):
            versions.update(artefact.manifest.get("versions", {}))
    items.append(("Where the RWG ran", where_it_ran(
        data, {task: data.results[task].rwg.manifest.get("jobs", []) for task in data.tasks}, "RWG")))
    sac_jobs = (sac_curves.attrs.get("sac_jobs") or {}) if sac_curves is not None else {}
    if sac_jobs:
        items.append(("Where SAC ran", where_it_ran(data, sac_jobs, "SAC")))
    items.append(("Software", ", ".join(f"{k} {v}" for k, v in sorted(versions.items()))))
    items.append(("Metrics artefacts", ", ".join(f"{data.name(t)}: {data.results[t].metrics.key}" for t in data.tasks)))
    items.append(("Verdict artefact", data.verdict_key))
    return tuple(items)
