"""The obstacle task's contacts: exact hand-overs to PyBullet against the batched contact model.

    python bench/bench_contacts.py                       # N = 400 × M = 50, seed 21
    python bench/bench_contacts.py --policies 1000 --seed 3

Runs the same RWG work (same policies, same initial states) both ways, side by side, and prints the
wall time of each, their ratio, and how far the model's distribution of outcomes is from PyBullet's:
episode lengths, returns and collisions (two-sample KS tests), and the metrics the study reports
(PIC and POIC, Welch's test on policy batches), next to the plain 2-link arm's for scale.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import stats

from taskcomplexity.metrics.batches import welch_test
from taskcomplexity.metrics.evaluate import batch_estimates
from taskcomplexity.metrics.pic import pic
from taskcomplexity.metrics.poic import poic
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.spec import make_task


def run(arm: str, contacts: str, args) -> tuple[object, float]:
    settings = RWGSettings(policies=args.policies, episodes=args.episodes, seed=args.seed, contacts=contacts)
    started = time.perf_counter()
    chunk = run_rwg(make_task(arm, "dense"), NetworkSpec(), PriorSpec(), settings, "batched")
    return chunk, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--policies", type=int, default=400)
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=21)
    args = parser.parse_args()
    run("two_link_obstacle", "model", argparse.Namespace(policies=2, episodes=2, seed=0))  # compile

    exact, exact_s = run("two_link_obstacle", "pybullet", args)
    model, model_s = run("two_link_obstacle", "model", args)
    plain, _ = run("two_link", "pybullet", args)
    n = exact.returns.size
    print(f"two_link_obstacle-dense, N = {args.policies} × M = {args.episodes} (seed {args.seed}): {n:,} episodes")
    print(f"  exact (rwg.contacts=pybullet): {exact_s:7.1f} s, {exact.handoffs:,} episodes finished on PyBullet")
    print(f"  model (rwg.contacts=model):    {model_s:7.1f} s, {model.contacts:,} episodes touched the block"
          f"  → {exact_s / model_s:,.0f}× faster")

    def collided(c):
        return (c.steps < 50) & ~c.success

    rows = [
        ("mean episode length", exact.steps.mean(), model.steps.mean(), stats.ks_2samp(exact.steps.ravel(),
                                                                                   model.steps.ravel()).pvalue),
        ("mean return", exact.returns.mean(), model.returns.mean(), stats.ks_2samp(exact.returns.ravel(),
                                                                               model.returns.ravel()).pvalue),
        ("collision fraction", collided(exact).mean(), collided(model).mean(), None),
    ]
    chosen = [DEFAULT_REGISTRY["pic"], DEFAULT_REGISTRY["poic"]]
    batches = {name: batch_estimates(c.returns, chosen)
               for name, c in (("exact", exact), ("model", model), ("plain", plain))}
    for metric, estimate in (("PIC", lambda r: pic(r).pic), ("POIC", lambda r: poic(r).poic)):
        column = metric.lower()
        p = welch_test(batches["exact"][column], batches["model"][column]).pvalue
        rows.append((metric, estimate(exact.returns), estimate(model.returns), p))
    print(f"\n{'':<22}{'exact':>12}{'model':>12}{'p (exact vs model)':>22}")
    for name, a, b, p in rows:
        print(f"{name:<22}{a:>12.4f}{b:>12.4f}{'' if p is None else f'{p:>22.3g}'}")
    print("p: two-sample KS test (length, return); Welch's test on policy batches (PIC, POIC)")
    for metric in ("pic", "poic"):
        p = welch_test(batches["model"][metric], batches["plain"][metric]).pvalue
        print(f"for scale, {metric.upper()} model vs plain two_link-dense: p = {p:.2g}")
    lengths = exact.steps.mean() - model.steps.mean()
    spread = np.sqrt(exact.steps.var() / n + model.steps.var() / n)
    print(f"length difference exact − model: {lengths:+.3f} ± {spread:.3f} steps")


if __name__ == "__main__":
    main()
