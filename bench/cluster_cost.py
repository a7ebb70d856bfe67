"""`make cluster-cost`: what `make atlas-cost` predicts for a study's RWG sent as jobs, against what the jobs used.

    python bench/cluster_cost.py                                       # the atlas at N = 64 × M = 10, 2 shards per task
    python bench/cluster_cost.py experiment=atlas study.policies=200 study.episodes=25 rwg.shards=4
    python bench/cluster_cost.py --partition gpu_short experiment=atlas ...   # another cluster's partition

The prediction is `pipelines/cost.py`'s, from the same functions: two pilots per task extrapolated to N × M
(:func:`taskcomplexity.commands.cost.price`) plus, once per job, the start-up of a fresh process on the task's
backend (:func:`taskcomplexity.commands.cost.job_start_cpu`). Then the study's RWG goes out as one job array
(`pipelines/rwg.py -m rwg.entry=<ids> rwg.shards=K 'rwg.shard=range(K)' hydra/launcher=cluster`), into a cache of its
own, and each task's measured CPU is the sum of SLURM's accounting (`sacct`'s TotalCPU: user + system time of every
process of the job) over the jobs its artefact's manifest names. The table gives both per task and their ratio;
nothing here gates on a timing.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["experiment=atlas", "study.policies=64", "study.episodes=10", "rwg.shards=2"]


def total_cpu(text: str) -> float:
    """Seconds of a sacct TotalCPU field: ``[D-][HH:]MM:SS[.mmm]``."""
    days, _, clock = text.rpartition("-")
    parts = [float(p) for p in clock.split(":")]
    seconds = sum(p * 60 ** i for i, p in enumerate(reversed(parts)))
    return seconds + 86400 * (int(days) if days else 0)


def sacct_cpu(jobs: list[str]) -> float:
    """The CPU-s SLURM accounted to ``jobs`` (each job's own row: its steps added up)."""
    out = subprocess.run(["sacct", "-n", "-P", "-o", "JobID,TotalCPU", "-j", ",".join(jobs)], capture_output=True,
                         text=True, check=True).stdout
    rows = dict(line.split("|") for line in out.splitlines() if line)
    missing = [job for job in jobs if job not in rows]
    if missing:
        raise SystemExit(f"error: sacct has no record of jobs {', '.join(missing)}")
    return sum(total_cpu(rows[job]) for job in jobs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--partition", default="local", help="the SLURM partition (default: the local cluster's)")
    parser.add_argument("overrides", nargs="*", help=f"the study's overrides (default: {' '.join(DEFAULT)})")
    args = parser.parse_args()
    overrides = args.overrides or DEFAULT

    from hydra import compose, initialize_config_dir

    from taskcomplexity.cli import CONF_DIR
    from taskcomplexity.commands.cost import job_start_cpu, price
    from taskcomplexity.stages.cache import Cache
    from taskcomplexity.study.plan import study_requests

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    entries = study_requests(cfg)
    shards = int(cfg.rwg.shards)
    print(f"prediction for {len(entries)} tasks × {shards} shards ({' '.join(overrides)}):", flush=True)
    predicted, starts = {}, {}
    for entry, request in entries:
        cost = price(request, entry.id)
        if cost.backend not in starts:
            starts[cost.backend] = job_start_cpu(entry.id, overrides)
        predicted[entry.id] = (cost.backend, cost.cpu_seconds, cost.job_cpu_seconds(shards, starts[cost.backend]))
        print(f"  {entry.id}: {predicted[entry.id][2]:.1f} CPU-s", flush=True)

    with tempfile.TemporaryDirectory(prefix="cluster-cost-") as outputs:
        ids = ",".join(entry.id for entry, _ in entries)
        command = [sys.executable, str(ROOT / "pipelines" / "rwg.py"), "-m", *overrides, f"rwg.entry={ids}",
                   f"rwg.shard=range({shards})", "hydra/launcher=cluster", f"hydra.launcher.partition={args.partition}",
                   f"paths.outputs={outputs}"]
        print("sending: " + " ".join(command[1:]), flush=True)
        started = time.monotonic()
        subprocess.run(command, check=True, capture_output=True, text=True)
        wall = time.monotonic() - started
        cache = Cache(Path(outputs) / "cache")
        measured = {}
        for entry, request in entries:
            artefact = cache.lookup("rwg", request.key)
            jobs = sorted({r["job"] for r in artefact.manifest["jobs"] if r["scheduler"] == "slurm"})
            measured[entry.id] = (jobs, sacct_cpu(jobs))

    print(f"\nthe job array ran in {wall:.0f} s of wall time; per task, CPU-s (the prediction's episodes + "
          f"{shards} job start-ups, against sacct's TotalCPU of its {shards} jobs):")
    head = f"{'task':<26}{'backend':>9}{'episodes':>10}{'predicted':>11}{'measured':>10}{'ratio':>8}"
    print(head)
    print("-" * len(head))
    worst = 0.0
    for entry, _ in entries:
        backend, episodes, whole = predicted[entry.id]
        _, cpu = measured[entry.id]
        ratio = whole / cpu if cpu else float("nan")
        worst = max(worst, abs(ratio - 1.0))
        print(f"{entry.id:<26}{backend:>9}{episodes:>10.1f}{whole:>11.1f}{cpu:>10.1f}{ratio:>8.2f}")
    total_p = sum(p[2] for p in predicted.values())
    total_m = sum(m[1] for m in measured.values())
    print(f"{'total':<26}{'':>9}{'':>10}{total_p:>11.1f}{total_m:>10.1f}{total_p / total_m:>8.2f}")
    print(f"largest deviation of a task: {100 * worst:.0f} % (start-ups measured: "
          + ", ".join(f"{b} {s:.1f} CPU-s" for b, s in starts.items()) + ")")


if __name__ == "__main__":
    main()
