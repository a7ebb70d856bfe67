"""Where the diagnostics stage and the bootstrap's POIC spend their time, and old against new.

Usage::

    python bench/bench_diagnostics.py                     # synthetic dense and sparse, N = 1000, M = 500 (~1.5 min)
    python bench/bench_diagnostics.py --returns outputs/cache/rwg/<key>/returns.parquet [...] --metrics-stage
                                                          # RWG artefacts (published scale: ~6 min a task)
    python bench/bench_diagnostics.py --repeats 1 --skip-old   # the split only

Per task:

1. The split of ``compute_diagnostics`` (stages/), step by step as it runs them, in process CPU seconds
   (all threads) beside wall seconds: the permutation null (shuffles, PIC, and the POIC search in its
   parts: sorted rows, ℓ on the coarse grid, ℓ on the refinement, the optimality curves), the whole
   sample's PIC and POIC, the sweeps over B and over subsamples, the other estimators (Miller–Madow,
   k-NN) and the per-batch estimates (with their nulls). The shuffles here are drawn in line, so
   their time shows; the stage draws them ahead in a background thread.
2. ``compute_diagnostics`` (and with ``--metrics-stage`` ``compute_metrics``, whose bootstrap holds the
   other POIC searches) as wholes, "new" (this tree) and "old" (git ``--baseline``, extracted with
   ``git archive``), each in a fresh subprocess that warms up first (numba compilation or cache
   loading), old and new alternating; medians of ``--repeats``, ratios, and whether every table is
   identical (``array_equal``).
3. The bootstrap (``--resamples``) split into its PIC part and its POIC part, the POIC part into the
   curves on the coarse grid, ℓ on the refinement brackets and the curves there, with the counts that
   set their cost: distinct S* among the resamples, fine temperatures in the union of the brackets and
   per resample.

The load average is printed: on a shared machine read the CPU seconds and the side-by-side ratios.
The script never fails on a timing.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from contextlib import contextmanager
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BASELINE = "7d05b37"
"""The last commit before the diagnostics work of issue 30."""


class Clock:
    """CPU (process, all threads) and wall seconds accumulated per label, in insertion order."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = defaultdict(float)
        self.wall: dict[str, float] = defaultdict(float)

    @contextmanager
    def __call__(self, label: str):
        cpu, wall = time.process_time(), time.perf_counter()
        try:
            yield
        finally:
            self.cpu[label] += time.process_time() - cpu
            self.wall[label] += time.perf_counter() - wall


def diagnostics_split(returns: np.ndarray, bins: int) -> Clock:
    """The steps of ``compute_diagnostics`` with the default settings, timed one by one."""
    from taskcomplexity.metrics import diagnostics as diag
    from taskcomplexity.metrics.evaluate import batch_estimates
    from taskcomplexity.metrics.pic import pic
    from taskcomplexity.metrics.poic import PolicyLogMeans, optimality_curves, reference_return
    from taskcomplexity.metrics.registry import DEFAULT_REGISTRY
    from taskcomplexity.metrics.sample import Sample, component_seeds
    from taskcomplexity.metrics.shuffle import permutation
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings, estimation
    from taskcomplexity.stages.metrics_stage import MetricsSettings

    settings, metrics_settings = DiagnosticsSettings(), MetricsSettings(bins=bins)
    sample = Sample(returns, estimation(metrics_settings, settings))
    lattice = sample.estimation.search.lattice()
    clock = Clock()
    rng = np.random.default_rng(sample.seed("null"))
    ones, s_star = np.ones((1, returns.shape[0])), np.array([reference_return(returns, None)])
    for _ in range(settings.repeats):
        with clock("null: shuffle"):
            shuffled = permutation(rng, returns.ravel()).reshape(returns.shape)
        with clock("null: PIC"):
            pic(shuffled, bins=bins)
        with clock("null: POIC sorted rows"):
            source = PolicyLogMeans(shuffled)
        with clock("null: POIC ℓ coarse"):
            coarse = source.on_lattice(lattice, lattice.coarse_indices)
        with clock("null: POIC curves"):
            curves = optimality_curves(coarse, source.row_max, lattice.temperatures[lattice.coarse_indices],
                                       ones, s_star)
            fine = np.flatnonzero(lattice.refinement_mask(curves.mi).any(axis=0))
        with clock("null: POIC ℓ fine"):
            refined = source.on_lattice(lattice, fine)
        with clock("null: POIC curves"):
            optimality_curves(refined, source.row_max, lattice.temperatures[fine], ones, s_star)
    with clock("sample: PIC and POIC"):
        sample.pic, sample.poic  # noqa: B018 (cached properties: computed here)
    with clock("sweep over B"):
        diag.pic_bins_sweep(returns, bins=sorted({b for b in settings.bins_sweep if b <= bins} | {bins}))
    with clock("sweep over subsamples"):
        sizes = [sorted({int(total * f) for f in settings.subsample_fractions} | {total}) for total in returns.shape]
        diag.pic_subsample_sweep(returns, seed=component_seeds(settings.seed)["subsample"],
                                 policies=sizes[0], episodes=sizes[1], bins=bins)
    with clock("estimators: Miller–Madow"):
        sample.pic_miller_madow  # noqa: B018
    with clock("estimators: k-NN"):
        sample.knn  # noqa: B018
    with clock("batches (their nulls, MM, k-NN)"):
        batch_estimates(returns, DEFAULT_REGISTRY.of_stage("diagnostics"), batches=metrics_settings.batches,
                        estimation=sample.estimation)
    return clock


def bootstrap_split(returns: np.ndarray, bins: int, resamples: int) -> tuple[Clock, dict]:
    """The bootstrap's PIC and POIC parts, the POIC part step by step as ``search_poic`` runs it."""
    from taskcomplexity.metrics.bootstrap import _bootstrap_pic, bootstrap_multiplicities
    from taskcomplexity.metrics.poic import PolicyLogMeans, optimality_curves, poic
    from taskcomplexity.metrics.temperature import DEFAULT_SEARCH

    clock = Clock()
    lattice = DEFAULT_SEARCH.lattice()
    source = PolicyLogMeans(returns)
    with clock("point POIC (shared ℓ)"):
        poic(returns, log_means=source)
    weights = bootstrap_multiplicities(returns.shape[0], resamples=resamples, seed=0)
    with clock("bootstrap PIC"):
        _bootstrap_pic(returns, weights, bins, lambda n: None)
    s_star = np.where(weights > 0, source.row_max, -np.inf).max(axis=1)
    temperatures, coarse = lattice.temperatures, lattice.coarse_indices
    with clock("bootstrap POIC: curves coarse"):
        curves = optimality_curves(source.on_lattice(lattice, coarse), source.row_max, temperatures[coarse],
                                   weights, s_star)
        refine = lattice.refinement_mask(curves.mi)
        fine = np.flatnonzero(refine.any(axis=0))
    with clock("bootstrap POIC: ℓ fine"):
        refined = source.on_lattice(lattice, fine)
    with clock("bootstrap POIC: curves fine"):
        optimality_curves(refined, source.row_max, temperatures[fine], weights, s_star, refine[:, fine])
    counts = {"distinct S*": int(np.unique(s_star).size), "fine union": int(fine.size),
              "fine per resample": float(refine.sum(axis=1).mean())}
    return clock, counts


def print_clock(title: str, clock: Clock) -> None:
    total_cpu, total_wall = sum(clock.cpu.values()), sum(clock.wall.values())
    print(f"\n{title}")
    header = f"  {'step':<34} {'CPU s':>7} {'share':>6} {'wall s':>7}"
    print(header)
    print("  " + "-" * (len(header) - 2))
    for label in clock.cpu:
        print(f"  {label:<34} {clock.cpu[label]:>7.2f} {clock.cpu[label] / total_cpu:>6.0%} {clock.wall[label]:>7.2f}")
    print(f"  {'total':<34} {total_cpu:>7.2f} {1:>6.0%} {total_wall:>7.2f}")


# Old against new, whole stage, fresh processes ------------------------------------------------------


def worker(source: Path, data: Path, stage: str, bins: int, out: Path) -> None:
    sys.path.insert(0, str(source))
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings, compute_diagnostics
    from taskcomplexity.stages.metrics_stage import MetricsSettings, compute_metrics

    def run(matrix, settings):
        if stage == "metrics":
            return compute_metrics(matrix, settings)
        return compute_diagnostics(matrix, settings, DiagnosticsSettings())

    returns = np.load(data)
    run(returns[:20, :20], MetricsSettings(bins=100, resamples=5))  # warm up
    cpu, wall = time.process_time(), time.perf_counter()
    tables = run(returns, MetricsSettings(bins=bins))
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    values = {name: {c: table[c].to_numpy(dtype=np.float64).tolist() for c in table.select_dtypes("number")}
              for name, table in tables.items()}
    out.write_text(json.dumps({"cpu": cpu, "wall": wall, "values": values}))


def whole_stage(stage: str, returns: np.ndarray, bins: int, args: argparse.Namespace, scratch: Path) -> None:
    from bench_metrics import baseline_source

    data = scratch / "returns.npy"
    np.save(data, returns)
    sources = {"new": ROOT / "src"}
    if not args.skip_old:
        old = baseline_source(args.baseline, scratch)
        if old is not None:
            sources["old"] = old
    runs: dict[str, list[dict]] = {label: [] for label in sources}
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    for repeat in range(args.repeats):
        for label, source in sources.items():
            out = scratch / f"{stage}-{label}-{repeat}.json"
            subprocess.run([sys.executable, __file__, "--worker", stage, "--source", str(source), "--data", str(data),
                            "--bins", str(bins), "--out", str(out)], check=True, env=env)
            runs[label].append(json.loads(out.read_text()))
    cpu = {label: statistics.median(r["cpu"] for r in found) for label, found in runs.items()}
    wall = {label: statistics.median(r["wall"] for r in found) for label, found in runs.items()}
    print(f"\n  compute_{stage}, median of {args.repeats} fresh processes "
          f"(load average now {os.getloadavg()[0]:.1f}):")
    for label in runs:
        print(f"    {label:<4} CPU {cpu[label]:6.2f} s   wall {wall[label]:6.2f} s")
    if "old" in runs:
        old, new = runs["old"][-1]["values"], runs["new"][-1]["values"]
        identical = all(np.array_equal(np.asarray(old[name][column]), np.asarray(values), equal_nan=True)
                        for name, columns in new.items() for column, values in columns.items())
        print(f"    old/new  CPU {cpu['old'] / cpu['new']:.2f}x   wall {wall['old'] / wall['new']:.2f}x   "
              f"every table identical: {identical}")


def parse_arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--returns", type=Path, nargs="*", default=[], help="RWG returns.parquet files")
    parser.add_argument("--policies", type=int, default=1000, help="N of the synthetic returns (default 1000)")
    parser.add_argument("--episodes", type=int, default=500, help="M of the synthetic returns (default 500)")
    parser.add_argument("--bins", type=int, default=None, help="B (default N·M / 50, the paper's ratio)")
    parser.add_argument("--resamples", type=int, default=1000, help="bootstrap resamples (default 1000)")
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes per version (default 3)")
    parser.add_argument("--baseline", default=BASELINE, help=f"git revision of the old library (default {BASELINE})")
    parser.add_argument("--skip-old", action="store_true", help="no old/new comparison")
    parser.add_argument("--metrics-stage", action="store_true", help="also compare compute_metrics old/new")
    parser.add_argument("--worker", choices=["metrics", "diagnostics"], help=argparse.SUPPRESS)
    parser.add_argument("--source", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--data", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    return parser.parse_args()


def main() -> None:
    args = parse_arguments()
    if args.worker:
        worker(args.source, args.data, args.worker, args.bins, args.out)
        return
    sys.path.insert(0, str(ROOT / "src"))
    from bench_metrics import dense_returns, load_returns, sparse_returns

    if args.returns:
        cases = {path.parent.name: load_returns(path) for path in args.returns}
    else:
        rng = np.random.default_rng(0)
        cases = {"dense": dense_returns(rng, args.policies, args.episodes),
                 "sparse": sparse_returns(rng, args.policies, args.episodes)}
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    tiny = next(iter(cases.values()))[:40, :40]
    diagnostics_split(tiny, 100)  # numba and BLAS: compile or load the cache, start the threads
    bootstrap_split(tiny, 100, 20)
    with tempfile.TemporaryDirectory() as name:
        for task, returns in cases.items():
            bins = args.bins or max(2, returns.size // 50)
            print(f"\n=== {task}: N = {returns.shape[0]}, M = {returns.shape[1]}, B = {bins}")
            print_clock("1. diagnostics, step by step", diagnostics_split(returns, bins))
            for stage in ("diagnostics", "metrics") if args.metrics_stage else ("diagnostics",):
                whole_stage(stage, returns, bins, args, Path(name))
            clock, counts = bootstrap_split(returns, bins, args.resamples)
            print_clock(f"3. bootstrap, {args.resamples} resamples", clock)
            poic_cpu = sum(v for k, v in clock.cpu.items() if k.startswith("bootstrap POIC"))
            print(f"  POIC share of the bootstrap: {poic_cpu / (poic_cpu + clock.cpu['bootstrap PIC']):.0%}; "
                  + ", ".join(f"{k} {v:g}" for k, v in counts.items()))


if __name__ == "__main__":
    main()
