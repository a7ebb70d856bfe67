"""Old against new, side by side: the per-policy log-mean-exp ℓₙ(λ) and the whole metrics and diagnostics stages.

Usage::

    python bench/bench_metrics.py                        # N = 2000, M = 500, 200 resamples, 3 repeats
    python bench/bench_metrics.py --policies 10000 --resamples 1000   # the published scale (old: ~6 min a repeat)
    python bench/bench_metrics.py --returns path/to/returns.parquet  # an RWG artefact instead of synthetic returns

1. ℓₙ(λ) on the 200 temperatures of the coarse POIC grid and a 63-point refinement bracket:
   :class:`~taskcomplexity.metrics.poic.PolicyLogMeans` (numba) against the numpy implementation it
   replaced, re-implemented below, in this process; median seconds of ``--repeats`` runs, the ratio and
   the largest difference.
2. ``compute_metrics`` and ``compute_diagnostics`` (stages/) on the same returns: "new" is this
   working tree, "old" the library at git revision ``--baseline`` (extracted with ``git archive`` into a
   temporary directory); each run is a fresh subprocess that first warms up on a tiny matrix (numba
   compilation or cache loading) and then times one call. Median wall and CPU seconds, ratios, and the
   largest difference between old and new estimates (stored tables, every numeric column).

The machine's load average is printed: on a shared machine compare the side-by-side ratios, not the
absolute seconds. The script never fails on a timing.
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
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BASELINE = "ce1b4b8"
"""The last commit before the numba estimators (issue 17)."""


# Synthetic returns ---------------------------------------------------------------------------------


def dense_returns(rng: np.random.Generator, policies: int, episodes: int) -> np.ndarray:
    """Dense-reward-like returns: a per-policy mean plus noise of per-policy scale, at most 0."""
    means = rng.normal(-100.0, 30.0, size=(policies, 1))
    scales = rng.lognormal(np.log(20.0), 0.5, size=(policies, 1))
    return np.minimum(means + scales * rng.standard_normal((policies, episodes)), 0.0)


def sparse_returns(rng: np.random.Generator, policies: int, episodes: int) -> np.ndarray:
    """Sparse-reward-like returns in {-50, …, 0}: minus the steps spent outside the target."""
    success = rng.beta(0.2, 5.0, size=(policies, 1))
    return -(50.0 - rng.binomial(50, np.broadcast_to(success, (policies, episodes)))).astype(np.float64)


def load_returns(path: Path) -> np.ndarray:
    """The (N, M) matrix of an RWG ``returns.parquet`` (columns policy, episode, return)."""
    import pandas as pd

    table = pd.read_parquet(path, columns=["policy", "episode", "return"])
    matrix = np.empty((table["policy"].max() + 1, table["episode"].max() + 1))
    matrix[table["policy"].to_numpy(), table["episode"].to_numpy()] = table["return"].to_numpy()
    return matrix


# 1. ℓₙ(λ): the numpy implementation the kernel replaced ----------------------------------------------


def numpy_log_means(returns: np.ndarray, temperatures: np.ndarray) -> np.ndarray:
    """ℓₙ(λ) as PolicyLogMeans computed it before the kernel (both of its storage paths)."""
    n_policies, n_episodes = returns.shape
    centred = returns - returns.max(axis=1, keepdims=True)
    ordered = np.sort(centred, axis=1)
    distinct = np.ones(ordered.shape, dtype=bool)
    np.not_equal(ordered[:, 1:], ordered[:, :-1], out=distinct[:, 1:])
    lowest = float(centred.min())
    sums = np.empty((n_policies, temperatures.size))
    if distinct.sum() <= distinct.size // 2:  # repeated returns stored once with their multiplicity
        starts = np.flatnonzero(distinct)
        values = ordered.ravel()[starts]
        multiplicity = np.diff(np.append(starts, ordered.size)).astype(np.float64)
        row_starts = np.concatenate(([0], np.cumsum(distinct.sum(axis=1))[:-1]))
        for column, temperature in enumerate(temperatures):
            exponent = values / temperature
            if lowest / temperature < -700.0:
                np.maximum(exponent, -700.0, out=exponent)
            sums[:, column] = np.add.reduceat(np.exp(exponent) * multiplicity, row_starts)
    else:  # blocks of policies of about 2 MiB
        rows = max(1, (1 << 18) // n_episodes)
        block = np.empty((rows, n_episodes))
        for column, temperature in enumerate(temperatures):
            for start in range(0, n_policies, rows):
                part = centred[start:start + rows]
                scratch = block[: part.shape[0]]
                np.divide(part, temperature, out=scratch)
                if lowest / temperature < -700.0:
                    np.maximum(scratch, -700.0, out=scratch)
                np.exp(scratch, out=scratch)
                scratch.sum(axis=1, out=sums[start:start + rows, column])
    return np.log(sums) - np.log(n_episodes)


def median_seconds(run, repeats: int) -> tuple[float, object]:
    """Median wall seconds of ``repeats`` calls, and the last result."""
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def bench_log_means(cases: dict[str, np.ndarray], repeats: int) -> None:
    from taskcomplexity.metrics.poic import PolicyLogMeans
    from taskcomplexity.metrics.temperature import POICSearch

    lattice = POICSearch().lattice()
    coarse = lattice.temperatures[lattice.coarse_indices]
    print(f"\n1. ℓₙ(λ) of every policy: {coarse.size} coarse temperatures and a 63-point bracket "
          f"(median of {repeats}; the kernel includes sorting the rows)")
    header = f"{'case':<8} {'temperatures':<20} {'numpy s':>9} {'numba s':>9} {'ratio':>7} {'ms/λ numpy':>11} " \
             f"{'ms/λ numba':>11} {'max |Δℓ|':>9}"
    print(header)
    print("-" * len(header))
    PolicyLogMeans(next(iter(cases.values()))[:4]).evaluate(coarse[:2])  # compile or load the cache
    for name, returns in cases.items():
        # The refinement bracket around the coarse point where the sample's MI curve usually peaks.
        centre = int(np.argmin(np.abs(np.log(coarse) - np.log(np.ptp(returns) / 4))))
        bracket = lattice.temperatures[max(centre - 1, 0) * lattice.refine_points + 1:
                                       (centre + 1) * lattice.refine_points]
        for label, temperatures in (("coarse grid", coarse), ("refinement bracket", bracket)):
            old_time, old = median_seconds(lambda t=temperatures, r=returns: numpy_log_means(r, t), repeats)
            new_time, new = median_seconds(lambda t=temperatures, r=returns: PolicyLogMeans(r).evaluate(t), repeats)
            print(f"{name:<8} {label:<20} {old_time:>9.3f} {new_time:>9.3f} {old_time / new_time:>6.1f}x "
                  f"{1e3 * old_time / temperatures.size:>11.2f} {1e3 * new_time / temperatures.size:>11.3f} "
                  f"{np.abs(old - new).max():>9.1e}")


# 2. The stages, old and new, each in a fresh subprocess ------------------------------------------------


def worker(source: Path, data: Path, stage: str, resamples: int, bins: int, out: Path) -> None:
    """Run one stage once on the returns in ``data`` with the library under ``source``; write JSON."""
    sys.path.insert(0, str(source))
    from taskcomplexity.stages.diagnostics_stage import DiagnosticsSettings, compute_diagnostics
    from taskcomplexity.stages.metrics_stage import MetricsSettings, compute_metrics

    returns = np.load(data)
    settings = MetricsSettings(bins=bins, resamples=resamples)

    def run(matrix, metrics_settings):
        if stage == "metrics":
            return compute_metrics(matrix, metrics_settings)
        return compute_diagnostics(matrix, metrics_settings, DiagnosticsSettings())

    run(returns[:20, :20], MetricsSettings(bins=100, resamples=5))  # numba: compile or load the cache
    wall, cpu = time.perf_counter(), time.process_time()
    tables = run(returns, settings)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    values = {}
    for name, table in tables.items():
        numeric = table.select_dtypes("number")
        values[name] = {column: numeric[column].to_list() for column in numeric.columns}
    out.write_text(json.dumps({"wall": wall, "cpu": cpu, "values": values}))


def baseline_source(revision: str, directory: Path) -> Path | None:
    """``src/`` of the library at ``revision``, extracted under ``directory``; None if git cannot."""
    try:
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "src/taskcomplexity"],
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(directory)], input=archive, check=True, capture_output=True)
    except (OSError, subprocess.CalledProcessError) as error:
        print(f"(no old column: git archive {revision} failed: {error})")
        return None
    return directory / "src"


def run_worker(source: Path, data: Path, stage: str, args: argparse.Namespace, scratch: Path) -> dict:
    out = scratch / f"{stage}-{time.monotonic_ns()}.json"
    env = {**os.environ, "OMP_WAIT_POLICY": "PASSIVE", "PYTHONDONTWRITEBYTECODE": "1"}
    subprocess.run([sys.executable, __file__, "--worker", stage, "--source", str(source), "--data", str(data),
                    "--out", str(out), "--resamples", str(args.resamples), "--bins", str(args.bins)],
                   check=True, env=env)
    return json.loads(out.read_text())


def largest_difference(old: dict, new: dict) -> float:
    """Largest absolute difference over every numeric column both runs stored."""
    largest = 0.0
    for name, columns in new["values"].items():
        for column, values in columns.items():
            before = old["values"].get(name, {}).get(column)
            if before is not None and len(before) == len(values):
                difference = np.abs(np.asarray(before, dtype=float) - np.asarray(values, dtype=float))
                largest = max(largest, float(np.nanmax(difference, initial=0.0)))
    return largest


def bench_stages(returns: np.ndarray, args: argparse.Namespace) -> None:
    with tempfile.TemporaryDirectory() as name:
        scratch = Path(name)
        data = scratch / "returns.npy"
        np.save(data, returns)
        sources = {"new": ROOT / "src", "old": baseline_source(args.baseline, scratch)}
        print(f"\n2. The stages on the same returns, N = {returns.shape[0]}, M = {returns.shape[1]}, "
              f"B = {args.bins}, {args.resamples} resamples (median of {args.repeats} fresh processes; "
              f"old = git {args.baseline})")
        header = f"{'stage':<12} {'old wall s':>11} {'new wall s':>11} {'ratio':>7} {'old CPU s':>10} " \
                 f"{'new CPU s':>10} {'max |Δ estimate|':>17}"
        print(header)
        print("-" * len(header))
        for stage in ("metrics", "diagnostics"):
            runs = {label: [] for label, source in sources.items() if source is not None}
            for _ in range(args.repeats):  # old and new alternate, so that both see the same load
                for label in runs:
                    runs[label].append(run_worker(sources[label], data, stage, args, scratch))
            wall = {label: statistics.median(r["wall"] for r in found) for label, found in runs.items()}
            cpu = {label: statistics.median(r["cpu"] for r in found) for label, found in runs.items()}
            if "old" in runs:
                print(f"{stage:<12} {wall['old']:>11.1f} {wall['new']:>11.1f} {wall['old'] / wall['new']:>6.1f}x "
                      f"{cpu['old']:>10.1f} {cpu['new']:>10.1f} "
                      f"{largest_difference(runs['old'][-1], runs['new'][-1]):>17.1e}")
            else:
                print(f"{stage:<12} {'':>11} {wall['new']:>11.1f} {'':>7} {'':>10} {cpu['new']:>10.1f}")


def parse_arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--policies", type=int, default=2000, help="N, policies (default 2000)")
    parser.add_argument("--episodes", type=int, default=500, help="M, episodes per policy (default 500)")
    parser.add_argument("--resamples", type=int, default=200, help="bootstrap resamples (default 200)")
    parser.add_argument("--bins", type=int, default=100_000, help="PIC histogram bins (default 100000)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats of every measurement (default 3)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the synthetic returns")
    parser.add_argument("--returns", type=Path, help="an RWG returns.parquet instead of synthetic dense returns")
    parser.add_argument("--baseline", default=BASELINE, help=f"git revision of the old library (default {BASELINE})")
    parser.add_argument("--skip-stages", action="store_true", help="only the ℓₙ comparison")
    parser.add_argument("--worker", choices=["metrics", "diagnostics"], help=argparse.SUPPRESS)
    parser.add_argument("--source", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--data", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    return parser.parse_args()


def main() -> None:
    args = parse_arguments()
    if args.worker:
        worker(args.source, args.data, args.worker, args.resamples, args.bins, args.out)
        return
    sys.path.insert(0, str(ROOT / "src"))
    rng = np.random.default_rng(args.seed)
    dense = load_returns(args.returns) if args.returns else dense_returns(rng, args.policies, args.episodes)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; "
          f"returns {'from ' + str(args.returns) if args.returns else 'synthetic'}, "
          f"N = {dense.shape[0]}, M = {dense.shape[1]}")
    bench_log_means({"dense": dense, "sparse": sparse_returns(rng, *dense.shape)}, args.repeats)
    if not args.skip_stages:
        bench_stages(dense, args)


if __name__ == "__main__":
    main()
