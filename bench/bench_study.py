"""The main job's time, stage by stage: where `make run` spends its wall time and how much of the cores it uses.

Runs the seven-task study of ``experiment=published`` (SAC off, as in `make run`) into a fresh
temporary cache, timing every stage of every task: wall seconds, CPU seconds (all threads of this
process) and the core share, CPU / (wall × cores) — 1.00 means every core was busy the whole time — and,
per stage, how busy each core was (from /proc/stat: every process's work, so other load shows).
The published scale (N = 10⁴ × M = 500, B = 10⁵, 1000 resamples) takes tens of minutes here, so the
default is a reduced scale given by ``--policies``/``--episodes``/``--resamples`` (B stays 10⁵); the
last column projects each stage to the published N × M by linear scaling (RWG and the metrics are
linear in N·M; the projection of the diagnostics and the bootstrap is rougher).

    .venv/bin/python bench/bench_study.py                    # N = 1000 × M = 100: about 4 minutes
    .venv/bin/python bench/bench_study.py --published        # the published scale itself
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from hydra import compose, initialize_config_dir
from omegaconf import open_dict

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.rwg import simulate_chunk
from taskcomplexity.stages.diagnostics_stage import run_diagnostics_stage
from taskcomplexity.stages.metrics_stage import run_metrics_stage
from taskcomplexity.stages.rwg_stage import run_rwg_stage
from taskcomplexity.stages.verdict_stage import run_verdict_stage
from taskcomplexity.study.plan import read_plan

CORES = os.cpu_count() or 1


def core_ticks() -> list[tuple[int, int]]:
    """(busy, total) clock ticks of every core since boot, from /proc/stat (every process's work; [] elsewhere)."""
    try:
        lines = Path("/proc/stat").read_text().splitlines()
    except OSError:
        return []
    ticks = []
    for line in lines:
        name, *values = line.split()
        if name.startswith("cpu") and name != "cpu":
            numbers = [int(v) for v in values[:8]]
            idle = numbers[3] + numbers[4]  # idle + iowait
            ticks.append((sum(numbers) - idle, sum(numbers)))
    return ticks


class Timer:
    """Wall and CPU seconds of a block (CPU: this process, every thread), and how busy each core was."""

    def __enter__(self):
        self.wall, self.cpu, self.ticks = time.perf_counter(), time.process_time(), core_ticks()
        return self

    def __exit__(self, *exc):
        self.wall = time.perf_counter() - self.wall
        self.cpu = time.process_time() - self.cpu
        after = core_ticks()
        self.busy = [(b1 - b0, t1 - t0) for (b0, t0), (b1, t1) in zip(self.ticks, after, strict=True)]

    @property
    def share(self) -> float:
        return self.cpu / max(self.wall, 1e-9) / CORES


def busy_shares(timers: list[Timer]) -> str:
    """Each core's busy share over the timers' blocks (all processes on the machine), e.g. ``0.97 0.95``."""
    if not timers or not timers[0].busy:
        return "n/a"
    cores = len(timers[0].busy)
    busy = [sum(t.busy[c][0] for t in timers) for c in range(cores)]
    total = [sum(t.busy[c][1] for t in timers) for c in range(cores)]
    return " ".join(f"{b / max(n, 1):.2f}" for b, n in zip(busy, total, strict=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policies", type=int, default=1000)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--resamples", type=int, default=200)
    parser.add_argument("--published", action="store_true", help="N, M and resamples of experiment=published")
    args = parser.parse_args()
    overrides = ["experiment=published"]
    if not args.published:
        overrides += [f"rwg.policies={args.policies}", f"rwg.episodes={args.episodes}",
                      f"metrics.resamples={args.resamples}"]
    with tempfile.TemporaryDirectory() as outputs, initialize_config_dir(config_dir=str(CONF_DIR),
                                                                         version_base="1.3"):
        cfg = compose("config", overrides=overrides)
        with open_dict(cfg):
            cfg.paths.outputs = str(Path(outputs) / "outputs")
        plan = read_plan(cfg)
        study, entries, requests, cache = plan.study, plan.entries, plan.requests, plan.cache
        settings, diagnostics_settings = plan.settings["metrics"], plan.settings["diagnostics"]
        n, m = int(cfg.rwg.policies), int(cfg.rwg.episodes)
        scale = 10_000 * 500 / (n * m)
        print(f"seven tasks at N = {n:,} × M = {m:,}, B = {settings.bins:,}, {settings.resamples} resamples, "
              f"{CORES} cores; projection × {scale:g} to N = 10,000 × M = 500")
        with Timer() as t:  # numba compiles (or loads from its cache) each kernel at its first call
            for request in requests:
                simulate_chunk(request.task, request.network, request.prior,
                               replace(request.settings, policies=2, episodes=2), 0, 2, request.backend)
        print(f"warm-up: the kernels' first calls (numba compilation, cached on disk after a first run) "
              f"{t.wall:.1f} s, not counted below")
        rows, metrics, diagnostics = [], {}, {}
        print(f"{'task':<26} {'stage':<12} {'wall s':>8} {'CPU s':>8} {'core share':>10} {'projected s':>12}")

        def report(task: str, stage: str, timer: Timer, linear: bool = True) -> None:
            rows.append((stage, timer))
            projected = f"{timer.wall * scale:12.0f}" if linear else f"{'':>12}"
            print(f"{task:<26} {stage:<12} {timer.wall:8.1f} {timer.cpu:8.1f} {timer.share:10.2f} {projected}",
                  flush=True)

        for entry, request in zip(entries, requests, strict=True):
            with Timer() as t:
                rwg, _ = run_rwg_stage(cache, request)
            report(entry.id, "rwg", t)
            with Timer() as t:
                metrics[entry.id], _ = run_metrics_stage(cache, rwg, settings)
            report(entry.id, "metrics", t)
            with Timer() as t:
                diagnostics[entry.id], _ = run_diagnostics_stage(cache, rwg, settings, diagnostics_settings)
            report(entry.id, "diagnostics", t)
        with Timer() as t:
            run_verdict_stage(cache, study, metrics, diagnostics=diagnostics, alpha=settings.alpha)
        report("all", "verdict", t, linear=False)
        print(f"\n{'stage':<12} {'wall s':>8} {'share of wall':>14} {'core share':>10} {'projected s':>12}  "
              "each core busy (every process)")
        total = sum(t.wall for _, t in rows)
        for stage in ("rwg", "metrics", "diagnostics", "verdict"):
            timers = [t for s, t in rows if s == stage]
            wall, cpu = sum(t.wall for t in timers), sum(t.cpu for t in timers)
            projected = f"{wall * scale:12.0f}" if stage != "verdict" else f"{wall:12.0f}"
            print(f"{stage:<12} {wall:8.1f} {wall / total:14.0%} {cpu / wall / CORES:10.2f} {projected}  "
                  f"{busy_shares(timers)}")
        print(f"{'total':<12} {total:8.1f} {'':>14} {sum(t.cpu for _, t in rows) / total / CORES:10.2f} "
              f"{sum(t.wall * (scale if s != 'verdict' else 1) for s, t in rows):12.0f}  "
              f"{busy_shares([t for _, t in rows])}")
        print("core share: this process's CPU seconds / (wall seconds × cores); each core busy: the share of "
              "the time each core was not idle, whoever ran on it (a busy machine shows here)")


if __name__ == "__main__":
    main()
