"""SAC training throughput on the 1-link dense task, and the projected time of the paper protocol.

Throughput is measured in environment steps per second summed over seeds ("seed-steps/s"), with one
gradient update per step and the protocol's evaluation schedule (10 episodes every 1000 steps),
after the warm-up, for:

1. one seed (``train_sac``),
2. five seeds trained together (``train_sac_seeds``, stacked parameters, one env per seed),
3. two such five-seed runs at once in two processes (what a study does on a 2-core machine: ``sac.workers``,
   one run per CPU by default), summed;
4. and 5. the same two with the batched kernel stepping the environments (``sac.backend=batched``), side by side.

The projection divides the paper protocol's seed-steps (every task's budget × 5 seeds, plus the
SAC+HER runs of the sparse tasks) by each throughput; a refined line corrects each task for its own
environment-step cost (the 2-link arms step more slowly in PyBullet), measured with random actions on the
backend the run would use (the obstacle task keeps PyBullet under ``sac.backend=batched``).

Timings are wall-clock; the "CPU share" column (process CPU time / wall time) shows how much of a
core each run actually had — below ~0.95 the machine was busy with other work and the figures are
pessimistic. Usage: ``.venv/bin/python bench/bench_sac.py [--steps 2000] [--no-concurrent]``.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import statistics
import sys
import time

import torch

import taskcomplexity  # noqa: F401 - registers the tasks
from taskcomplexity.cli import CONF_DIR
from taskcomplexity.rl import SACSettings, protocol_variants, train_sac, train_sac_seeds, with_budget
from taskcomplexity.rl.factories import make_env
from taskcomplexity.rl.settings import OWN_ENV, env_backend
from taskcomplexity.rwg.backends import sac_backends
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.spec import make_task

PAPER_STUDY = CONF_DIR / "study" / "seven_tasks.yaml"
BENCH_TASK = ("one_link_1m0", "dense")
PAPER_SEEDS = 5
SAC_BACKENDS = (OWN_ENV, *sac_backends())
"""What steps SAC's environments, side by side: each task's own env (PyBullet), then each backend's vector env."""
WARMUP = 1000
ENV_PROBE_STEPS = 300
ENV_PROBE_WARMUP = 20


def paper_runs() -> list[tuple[str, str, bool, int]]:
    """(arm, reward, her, budget per seed) of every run of the paper protocol (budgets: study/seven_tasks.yaml)."""
    paper = SACSettings()  # the defaults are the published protocol
    study = load_study_file(PAPER_STUDY)
    runs = []
    for entry in study.tasks:
        arm, reward = entry.selection["arm"], entry.selection["reward"]
        task = make_task(arm, reward)
        budgeted = with_budget(paper, study.task(task.task_id).sac_steps, task_id=task.task_id)
        runs += [(arm, reward, v.her, v.total_steps) for v in protocol_variants(task, budgeted)]
    return runs


def measure(seeds: tuple[int, ...], steps: int, backend: str = "pybullet") -> dict[str, float]:
    """Steady-state seed-steps/s of one training run on the bench task (after a 1000-step warm-up)."""
    settings = SACSettings(
        total_steps=WARMUP + steps,
        warmup_steps=WARMUP,
        eval_every=math.gcd(WARMUP, steps),  # an evaluation at the end of the warm-up and of the run
        eval_episodes=10,
        checkpoint_every=100_000,
        seeds=seeds,
        num_threads=1,
        backend=backend,
    )
    task = make_task(*BENCH_TASK)
    wall, cpu = time.perf_counter(), time.process_time()
    if len(seeds) == 1:
        curve = train_sac(task, settings, seed=seeds[0])
    else:
        curve = train_sac_seeds(task, settings)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    seconds = curve.groupby("env_step")["time/seconds"].first()
    steady = seconds[WARMUP + steps] - seconds[WARMUP]
    return {"rate": len(seeds) * steps / steady, "cpu_share": cpu / wall, "wall": wall}


def _measure_worker(args: tuple[tuple[int, ...], int, str]) -> dict[str, float]:
    return measure(*args)


def env_step_seconds(arm: str, reward: str, her: bool, instances: int = PAPER_SEEDS,
                     backend: str = "pybullet") -> float:
    """Seconds per environment step and instance of ``make_env`` with random actions, on the backend a SAC run with
    ``sac.backend=backend`` uses for the task."""
    task = make_task(arm, reward)
    used = env_backend(task, SACSettings(backend=backend))
    env = make_env(task, instances, goal_conditioned=her, backend=used)
    try:
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(0)
            td = env.reset(seed=list(range(instances)))
            for step in range(ENV_PROBE_WARMUP + ENV_PROBE_STEPS):
                if step == ENV_PROBE_WARMUP:
                    start = time.perf_counter()
                _, td = env.step_and_maybe_reset(env.rand_action(td))
            return (time.perf_counter() - start) / (ENV_PROBE_STEPS * instances)
    finally:
        env.close()


def macs_per_seed_step(n_obs: int, n_act: int, hidden=(256, 256), batch: int = 64) -> int:
    """Multiply-accumulates of one SAC update of one seed (one environment step's worth), counted from the shapes.

    Per minibatch row: forward passes of the actor on s and s′, of both critics on (s, ã) for the actor loss and
    on (s, a) for the critic loss, and of both target critics on (s′, a′); backward passes as about twice a
    forward (weights and inputs) for the actor and the critics of the critic loss, and once (inputs only: their
    parameters are detached there) for the critics of the actor loss.
    """
    def mlp(inputs: int, outputs: int) -> int:
        sizes = [inputs, *hidden, outputs]
        return sum(a * b for a, b in zip(sizes[:-1], sizes[1:], strict=True))

    actor, critic = mlp(n_obs, 2 * n_act), mlp(n_obs + n_act, 1)
    forward = 2 * actor + 4 * critic + 2 * critic
    backward = 2 * actor + 2 * 2 * critic + 2 * 1 * critic
    return batch * (forward + backward)


def gemm_rates(seeds: int = PAPER_SEEDS, batch: int = 64, width: int = 256, repeats: int = 5) -> tuple[float, float]:
    """MAC/s of float32 batched products at the update's shape, (seeds, batch, width) @ (seeds, width, width), and of
    one large product (1024³), one torch thread, best of ``repeats``."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        rates = []
        for a, b in (((seeds, batch, width), (seeds, width, width)), ((1024, 1024), (1024, 1024))):
            x, y = torch.randn(*a), torch.randn(*b)
            macs = x.numel() * y.shape[-1]
            loops = max(1, int(2e9 // macs))
            best = math.inf
            for _ in range(repeats):
                start = time.perf_counter()
                for _ in range(loops):
                    torch.matmul(x, y)
                best = min(best, time.perf_counter() - start)
            rates.append(macs * loops / best)
        return rates[0], rates[1]
    finally:
        torch.set_num_threads(previous)


def update_seconds(seeds: int = PAPER_SEEDS, updates: int = 100, repeats: int = 5) -> dict[str, float]:
    """Seconds per SAC update (objective, backward, both Adam steps, target update) at the protocol's shapes, one
    torch thread: through TorchRL's ``SACLoss`` (how training ran before) and through the direct objective that
    training uses (:mod:`taskcomplexity.rl.objective`, the same numbers); alternating, median of ``repeats``."""
    from tensordict import TensorDict

    from taskcomplexity.rl.factories import (
        make_actor_critic,
        make_loss,
        make_objective,
        make_optimisers,
        make_target_updater,
    )

    s = SACSettings()
    task = make_task(*BENCH_TASK)
    n_obs, n_act, b = task.observation_size, task.action_size, s.batch_size
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(0)
            actor, critics = make_actor_critic(task, hidden_sizes=s.hidden_sizes, seeds=tuple(range(seeds)),
                                               goal_conditioned=False)
            loss = make_loss(actor, critics, gamma=s.gamma, alpha=s.alpha, loss_function=s.loss_function)
            optimisers = make_optimisers(loss, actor_lr=s.actor_lr, critic_lr=s.critic_lr)
            updater = make_target_updater(loss, tau=s.tau)
            objective = make_objective(loss, actor, task, gamma=s.gamma, loss_function=s.loss_function,
                                       goal_conditioned=False)
            batches = [TensorDict({
                "observation": torch.randn(seeds, b, n_obs), "action": torch.rand(seeds, b, n_act) * 2 - 1,
                "next": {"observation": torch.randn(seeds, b, n_obs), "reward": torch.randn(seeds, b, 1),
                         "done": torch.zeros(seeds, b, 1, dtype=torch.bool),
                         "terminated": torch.zeros(seeds, b, 1, dtype=torch.bool)}}, [seeds, b]) for _ in range(10)]

            def through_sacloss(batch):
                out = loss(batch)
                return (out.get("loss_actor") + out.get("loss_qvalue")) * seeds

            times: dict[str, list[float]] = {"SACLoss": [], "direct": []}
            for _ in range(repeats):
                for name, value in (("SACLoss", through_sacloss), ("direct", objective)):
                    start = time.perf_counter()
                    for i in range(updates):
                        total = value(batches[i % len(batches)])
                        for optimiser in optimisers:
                            optimiser.zero_grad(set_to_none=True)
                        total.backward()
                        for optimiser in optimisers:
                            optimiser.step()
                        updater.step()
                    times[name].append((time.perf_counter() - start) / updates)
        return {name: statistics.median(values) for name, values in times.items()}
    finally:
        torch.set_num_threads(previous)


def hours(seconds: float) -> str:
    return f"{seconds / 3600:5.2f} h"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="measured steps per seed after the warm-up")
    parser.add_argument("--no-concurrent", action="store_true", help="skip the two-process measurement")
    args = parser.parse_args()

    runs = paper_runs()
    seed_steps = sum(budget for *_, budget in runs) * PAPER_SEEDS
    probe = {backend: {(arm, reward, her): env_step_seconds(arm, reward, her, backend=backend)
                       for arm, reward, her, _ in runs} for backend in SAC_BACKENDS}

    load_before = os.getloadavg()[0]
    results: dict[str, dict[str, float]] = {}
    results["1 seed"] = measure((0,), args.steps) | {"processes": 1, "backend": "pybullet"}
    five = tuple(range(PAPER_SEEDS))
    for backend in SAC_BACKENDS:  # side by side: PyBullet, then the batched kernel stepping the environments
        suffix = "" if backend == OWN_ENV else f", {backend}"
        results[f"5 seeds together{suffix}"] = measure(five, args.steps, backend) | {"processes": 1,
                                                                                      "backend": backend}
        if not args.no_concurrent:
            with multiprocessing.get_context("spawn").Pool(2) as pool:
                pair = pool.map(_measure_worker, [(five, args.steps, backend)] * 2)
            results[f"2 processes × 5 seeds{suffix}"] = {
                "rate": sum(r["rate"] for r in pair),
                "cpu_share": sum(r["cpu_share"] for r in pair) / 2,
                "wall": max(r["wall"] for r in pair),
                "processes": 2,
                "backend": backend,
            }
    load_after = os.getloadavg()[0]

    print(f"\nSAC throughput on {'-'.join(BENCH_TASK)}: one update per step, batch 64, 2×256 MLPs, "
          f"evaluation 10 episodes / 1000 steps; torch {torch.__version__}, {os.cpu_count()} CPUs, "
          f"1 torch thread per process, load average {load_before:.1f} → {load_after:.1f}\n")
    header = f"{'configuration':<33} {'seed-steps/s':>12} {'CPU share':>9} {'paper protocol':>15} {'refined':>9}"
    print(header)
    print("-" * len(header))
    for name, result in results.items():
        rate = result["rate"]
        # refined: each run pays its own env-step cost instead of the bench task's (shared by the
        # processes running at once)
        per_step = 1.0 / rate
        costs = probe[result["backend"]]
        reference = costs[(*BENCH_TASK, False)]
        refined = sum(
            budget * PAPER_SEEDS * (per_step + (costs[(arm, reward, her)] - reference) / result["processes"])
            for arm, reward, her, budget in runs
        )
        print(f"{name:<33} {rate:12.0f} {result['cpu_share']:9.2f} {hours(seed_steps / rate):>15} {hours(refined):>9}")
    print(
        f"\npaper protocol: {len(runs)} runs (7 tasks + SAC+HER on 3 sparse tasks) × {PAPER_SEEDS} seeds = "
        f"{seed_steps:,} seed-steps; projection = seed-steps / throughput (warm-up counted at full cost)."
    )
    task = make_task(*BENCH_TASK)
    per_step = macs_per_seed_step(task.observation_size, task.action_size)
    at_shape, large = gemm_rates()
    together = results["5 seeds together"]["rate"]
    print(f"arithmetic: {per_step / 1e6:.0f} MMAC per seed-step (counted from the shapes, batch 64); five seeds "
          f"together run at {together * per_step / 1e9:.1f} GMAC/s effective, against float32 matmul at the update's "
          f"shape (5 × 64 × 256 @ 256 × 256) {at_shape / 1e9:.1f} GMAC/s and at 1024³ {large / 1e9:.1f} GMAC/s on one "
          f"thread: the floor of the five-seed run is {at_shape / per_step:.0f} seed-steps/s at the update's shape "
          "(the rest is the optimiser, the loss's element-wise work, per-operation overhead and the environments)")
    update = update_seconds()
    print(f"one five-seed update (one thread, alternating, median of 5 × 100): through SACLoss "
          f"{1e3 * update['SACLoss']:.1f} ms, direct (what training runs) {1e3 * update['direct']:.1f} ms: "
          f"{update['SACLoss'] / update['direct']:.2f}× (the same numbers: tests/rl/test_objective.py); "
          f"{PAPER_SEEDS * per_step / update['direct'] / 1e9:.1f} GMAC/s in the direct update")
    for backend, costs in probe.items():
        print(f"env step cost per instance, {backend} (random actions, 5 instances; the obstacle task on PyBullet): "
              + ", ".join(f"{a}-{r}{'+her' if h else ''} {1e6 * s:.0f} µs" for (a, r, h), s in costs.items()))
    pybullet, batched = (results.get(f"2 processes × 5 seeds{s}") for s in ("", ", batched"))
    if pybullet and batched:
        print(f"two runs at once: batched environments {batched['rate'] / pybullet['rate']:.2f}× the seed-steps/s of "
              "PyBullet, measured side by side in this run")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
