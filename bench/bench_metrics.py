"""Wall time of the PIC/POIC estimators and of their bootstrap, against the naive bootstrap.

Usage::

    python benchmarks/bench_metrics.py                      # paper scale: N=10⁴, M=500, 1000 resamples
    python benchmarks/bench_metrics.py --policies 2000 --episodes 100 --resamples 200

For each synthetic return matrix the script times the point estimates (median of ``--repeats``
runs), one full bootstrap of PIC + POIC, and a few naive resamples (resample the policies, call
``pic`` and ``poic``), whose mean is extrapolated to the requested number of resamples. It prints a
table; it never fails on a timing.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from taskcomplexity.metrics import bootstrap, bootstrap_indices, pic, poic


def dense_returns(rng: np.random.Generator, policies: int, episodes: int) -> np.ndarray:
    """Dense-reward-like returns: a per-policy mean plus noise of per-policy scale."""
    means = rng.normal(-100.0, 30.0, size=(policies, 1))
    scales = rng.lognormal(np.log(5.0), 0.5, size=(policies, 1))
    return means + scales * rng.standard_normal((policies, episodes))


def outlier_returns(rng: np.random.Generator, policies: int, episodes: int) -> np.ndarray:
    """Dense returns with five far outliers, which stretch the PIC bins."""
    returns = dense_returns(rng, policies, episodes)
    flat = rng.choice(returns.size, size=5, replace=False)
    returns.flat[flat] = rng.choice([-1.0, 1.0], size=5) * rng.uniform(2_000.0, 10_000.0, size=5)
    return returns


def sparse_returns(rng: np.random.Generator, policies: int, episodes: int) -> np.ndarray:
    """Sparse-reward-like returns in {-50, …, 0}: minus the steps spent outside the target."""
    success = rng.beta(0.2, 5.0, size=(policies, 1))
    inside = rng.binomial(50, np.broadcast_to(success, (policies, episodes)))
    return -(50.0 - inside)


CASES = {"dense": dense_returns, "outliers": outlier_returns, "sparse": sparse_returns}


def median_time(run: Callable[[], object], repeats: int) -> float:
    """Median wall time in seconds of ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def naive_resample_time(returns: np.ndarray, *, resamples: int, bins: int, seed: int) -> float:
    """Mean wall time of one naive resample (index the policies, run pic and poic)."""
    start = time.perf_counter()
    for indices in bootstrap_indices(returns.shape[0], resamples=resamples, seed=seed):
        resampled = returns[indices]
        pic(resampled, bins=bins)
        poic(resampled)
    return (time.perf_counter() - start) / resamples


def parse_arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--policies", type=int, default=10_000, help="N, policies (default 10000)")
    parser.add_argument("--episodes", type=int, default=500, help="M, episodes per policy (default 500)")
    parser.add_argument("--resamples", type=int, default=1000, help="bootstrap resamples (default 1000)")
    parser.add_argument("--bins", type=int, default=100_000, help="PIC histogram bins (default 100000)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats of the point estimates (default 3)")
    parser.add_argument("--naive", type=int, default=3, help="naive resamples timed (default 3)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the data and the resampling")
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES), help="synthetic data sets")
    return parser.parse_args()


def main() -> None:
    args = parse_arguments()
    header = (
        f"{'case':<9} {'PIC':>8} {'POIC':>8} {'point PIC s':>12} {'point POIC s':>13} "
        f"{'bootstrap s':>12} {'naive/res s':>12} {'naive proj s':>13} {'speed-up':>9}"
    )
    print(
        f"N = {args.policies}, M = {args.episodes}, B = {args.bins} bins, {args.resamples} resamples "
        f"(point estimates: median of {args.repeats}; naive: mean of {args.naive} resamples, extrapolated)"
    )
    print(header)
    print("-" * len(header))
    for name in args.cases:
        returns = CASES[name](np.random.default_rng(args.seed), args.policies, args.episodes)
        estimate_pic, estimate_poic = pic(returns, bins=args.bins), poic(returns)
        pic_time = median_time(lambda r=returns: pic(r, bins=args.bins), args.repeats)
        poic_time = median_time(lambda r=returns: poic(r), args.repeats)
        start = time.perf_counter()
        bootstrap(returns, seed=args.seed, resamples=args.resamples, bins=args.bins)
        bootstrap_time = time.perf_counter() - start
        per_resample = naive_resample_time(returns, resamples=args.naive, bins=args.bins, seed=args.seed)
        projected = per_resample * args.resamples
        print(
            f"{name:<9} {estimate_pic.pic:>8.4f} {estimate_poic.poic:>8.5f} {pic_time:>12.3f} "
            f"{poic_time:>13.3f} {bootstrap_time:>12.2f} {per_resample:>12.3f} {projected:>13.1f} "
            f"{projected / bootstrap_time:>8.1f}x"
        )


if __name__ == "__main__":
    main()
