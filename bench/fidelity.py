"""`make fidelity`: our Table 1 at the published scale beside the published cells, with the probes of
docs/explanation/fidelity.md.

    .venv/bin/python bench/fidelity.py                       # experiment=published (reuses `make run`'s cache)
    .venv/bin/python bench/fidelity.py rwg.policies=10200    # any Hydra override of the study
    .venv/bin/python bench/fidelity.py --scan                # + the torque-scale scan (about 1 min a point)

Computes (or reuses, from the cache under ``paths.outputs``) the RWG and metrics artefacts of every task
of the study and prints, per task, PIC and POIC with their bootstrap mean ± sd, H(R) and H(R|Θ); for
the cells whose published value is known (``PUBLISHED``), the distance of our bootstrap mean from it in
published standard deviations. Then, for those cells, the probes that decide where an offset comes from
(docs/explanation/fidelity.md): the pooled returns' range, tails and ties, and H(R), H(R|Θ) and PIC again with the
most extreme returns clipped, so that the bin width no longer depends on them.
``--scan`` adds, for the 1-link L = 1.0 dense cell, PIC at torque scales within ±1 % of the spec's 30 N·m
(same policies, same reset states, so the differences are the mechanics' alone): how far a change in the
fourth significant digit of the arm's impulse moves the cell (docs/explanation/fidelity.md).
At the published scale a cold run takes as long as `make run`; not part of CI.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import argparse
import dataclasses

import numpy as np
from hydra import compose, initialize_config_dir

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import pic
from taskcomplexity.stages.rwg_stage import load_returns, run_rwg_stage
from taskcomplexity.stages.task_artefacts import study_metrics
from taskcomplexity.study.plan import read_plan

PUBLISHED = {
    # Table 1 of the paper, bootstrap mean ± sd (nats), with the entropies where they were reported;
    # as quoted by issue 19 of this project. Other cells: not restated here.
    "one_link_1m0-dense": {"pic": (4.005, 0.0085), "h_r": 10.1425, "h_r_given_theta": 6.1373},
    "two_link_obstacle-dense": {"pic": (3.671, 0.0143)},
}
SCAN_CELL = "one_link_1m0-dense"
SCAN_CHANGES = (-1e-2, -3e-3, -1e-3, -3e-4, -1e-4, 0.0, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2)
"""Relative changes of the torque scale that ``--scan`` applies to ``SCAN_CELL``'s arm."""
CLIP_QUANTILES = (1e-5, 1 - 1e-5)
"""The probe's clipping: the pooled returns below/above these quantiles are set to them."""


def probe(returns: np.ndarray, bins: int) -> str:
    """Range, tails and ties of the pooled returns, and the histogram terms with the extremes clipped."""
    flat = returns.ravel()
    low, high = np.quantile(flat, CLIP_QUANTILES)
    distinct = np.unique(flat).size
    spread = flat.max() - flat.min()
    clipped = pic(np.clip(returns, low, high), bins=bins)
    plain = pic(returns, bins=bins)
    lines = [
        f"    returns in [{flat.min():.4f}, {flat.max():.4f}] (range {spread:.4f}); "
        f"{CLIP_QUANTILES[0]:g}/{CLIP_QUANTILES[1]:g} quantiles {low:.4f}, {high:.4f} (range {high - low:.4f}, "
        f"{(high - low) / spread:.1%} of the full range)",
        f"    {flat.size:,} returns, {distinct:,} distinct ({flat.size - distinct:,} ties); bin width "
        f"{spread / bins:.3g}",
        f"    H(R) {plain.h_r:.4f}  H(R|Θ) {plain.h_r_given_theta:.4f}  PIC {plain.pic:.4f}   (as estimated)",
        f"    H(R) {clipped.h_r:.4f}  H(R|Θ) {clipped.h_r_given_theta:.4f}  PIC {clipped.pic:.4f}   "
        "(extremes clipped: the bins span the central range)",
    ]
    return "\n".join(lines)


def torque_scan(cache, request, bins: int, published: tuple[float, float]) -> None:
    """PIC of ``request``'s task with its torque scale changed by each of :data:`SCAN_CHANGES` (cached RWG)."""
    arm = request.task.arm
    mean, sd = published
    print(f"\n{request.label}: torque scale × (1 + ε), the same {request.settings.policies:,} policies × "
          f"{request.settings.episodes} reset states (point estimates; off in published sd)")
    print(f"{'ε':>9}{'torque (N·m)':>15}{'H(R)':>9}{'H(R|Θ)':>9}{'PIC':>9}{'off':>7}")
    for change in SCAN_CHANGES:
        scaled = dataclasses.replace(arm, torque_scale=tuple(t * (1 + change) for t in arm.torque_scale))
        changed = dataclasses.replace(request, task=dataclasses.replace(request.task, arm=scaled))
        artefact, _ = run_rwg_stage(cache, changed, progress=True)
        result = pic(load_returns(artefact), bins=bins)
        print(f"{change:>+9.0e}{scaled.torque_scale[0]:>15.4f}{result.h_r:9.4f}{result.h_r_given_theta:9.4f}"
              f"{result.pic:9.4f}{(result.pic - mean) / sd:+7.1f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("overrides", nargs="*", help="Hydra overrides (default: experiment=published)")
    parser.add_argument("--scan", action="store_true",
                        help=f"also scan {SCAN_CELL}'s torque scale within ±1 %% (one RWG run per point)")
    args = parser.parse_args()
    overrides = args.overrides
    if not any(o.startswith("experiment=") for o in overrides):
        overrides = ["experiment=published", *overrides]
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=overrides)
    plan = read_plan(cfg)
    study, settings = plan.study, plan.settings["metrics"]
    results = study_metrics(plan.cache, list(plan.requests), settings, names=[e.id for e in plan.entries],
                            progress=True)
    print(f"\n{study.name}: N = {int(cfg.rwg.policies):,} × M = {int(cfg.rwg.episodes):,}, B = {settings.bins:,}, "
          f"{settings.resamples} bootstrap resamples, seed {int(cfg.rwg.seed)}, contacts {cfg.rwg.contacts}")
    print(f"{'task':<26}{'PIC':>8}{'PIC mean ± sd':>20}{'POIC mean ± sd':>22}{'H(R)':>9}{'H(R|Θ)':>9}"
          f"{'published PIC':>20}{'off (sd)':>10}")
    for result in results:
        row = result.table("metrics.parquet").iloc[0]
        published = PUBLISHED.get(result.task_id, {})
        reference, off = "", ""
        if "pic" in published:
            mean, sd = published["pic"]
            reference = f"{mean:.4f} ± {sd:.4f}"
            off = f"{(row['pic_mean'] - mean) / sd:+.1f}"
        print(f"{result.task_id:<26}{row['pic']:8.4f}{row['pic_mean']:11.4f} ± {row['pic_sd']:.4f}"
              f"{row['poic_mean']:13.4f} ± {row['poic_sd']:.4f}{row['h_r']:9.4f}{row['h_r_given_theta']:9.4f}"
              f"{reference:>20}{off:>10}")
    precision_check(plan, results, settings)
    for result in results:
        published = PUBLISHED.get(result.task_id)
        if not published:
            continue
        print(f"\n{result.task_id}: published " + ", ".join(
            f"{k} {v[0]:.4f} ± {v[1]:.4f}" if isinstance(v, tuple) else f"{k} {v:.4f}" for k, v in published.items()))
        print(probe(load_returns(result.rwg), settings.bins))
    if args.scan:
        cells = {e.id: request for e, request in zip(plan.entries, plan.requests, strict=True)}
        if SCAN_CELL not in cells:
            raise SystemExit(f"--scan: study {study.name} has no task {SCAN_CELL}")
        torque_scan(plan.cache, cells[SCAN_CELL], settings.bins, PUBLISHED[SCAN_CELL]["pic"])


def precision_check(plan, results, settings) -> None:
    """The study's float32 forward passes (``rwg.precision=float32``) beside float64 on the same policies and episodes:
    each cell's change in its float64 bootstrap sd and, where the paper's sd is restated, in that."""
    narrow = {e.id: r for e, r in zip(plan.entries, plan.requests, strict=True) if r.settings.precision != "float64"}
    if not narrow:
        return
    wide = {task: dataclasses.replace(r, settings=dataclasses.replace(r.settings, precision="float64"))
            for task, r in narrow.items()}
    reference = study_metrics(plan.cache, list(wide.values()), settings, names=list(wide), progress=True)
    print(f"\nrwg.precision=float32 against float64 (same policies, same episodes; {len(narrow)} of "
          f"{len(results)} tasks, the others run float64):")
    print(f"{'task':<26}{'PIC f64':>10}{'PIC f32':>10}{'Δ (boot sd)':>13}{'Δ (paper sd)':>14}"
          f"{'POIC f64':>11}{'POIC f32':>11}{'Δ (boot sd)':>13}")
    mine = {r.task_id: r.table("metrics.parquet").iloc[0] for r in results}
    for result in reference:
        a, b = result.table("metrics.parquet").iloc[0], mine[result.task_id]
        paper = PUBLISHED.get(result.task_id, {}).get("pic")
        in_paper = f"{(b['pic'] - a['pic']) / paper[1]:+.4f}" if paper else "—"
        print(f"{result.task_id:<26}{a['pic']:10.5f}{b['pic']:10.5f}{(b['pic'] - a['pic']) / a['pic_sd']:+13.4f}"
              f"{in_paper:>14}{a['poic']:11.6f}{b['poic']:11.6f}{(b['poic'] - a['poic']) / a['poic_sd']:+13.4f}")


if __name__ == "__main__":
    main()
