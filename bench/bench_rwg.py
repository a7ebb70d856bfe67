"""RWG throughput: the batched backend against the PyBullet reference, side by side in one run.

    python bench/bench_rwg.py                 # side-by-side ratios + all seven tasks at paper scale
    python bench/bench_rwg.py --one-task      # only two_link-dense at paper scale
    python bench/bench_rwg.py --fused-only    # only the fused rollout against the step-by-step path

Prints

- the batched backend's fused rollout (one numba kernel per chunk: each policy's forward pass and
  environment step per environment, finished episodes skipped) against its step-by-step path (one
  batched forward pass, ``PolicyBatch.act``, and one ``BatchedReaching.step`` per environment step):
  episodes per second on the same chunk (same policies, same initial states), for the 1-link arm and
  the 2-link arm with the obstacle (contact model);
- environment steps per second of the batched backend and the PyBullet reference on the same work,
  and their ratio;
- the wall time and peak resident memory of every study task at the paper's full scale (N = 10⁴
  policies × M = 500 episodes) on the batched backend, each in a fresh process. The obstacle task runs
  with its contact model (``rwg.contacts=model``); the cost of the exact alternative (hand-overs to
  PyBullet) is measured on a small run and projected.

Then the pybullet backend against its floor (``--floors-only``: that alone): bare ``stepSimulation`` × substeps on
the same PyBullet world with random torques, CPU-µs per environment step, and a ``floor:`` line per task
(``bench/floors.py``) on the CPU path this runs on (``bench/run.py`` runs ``--floors-only`` again on the AVX2 path).
The batched backend's floor line comes from ``bench/bench_kernel_split.py``.

Medians of repeats, the two sides of a ratio interleaved; the machine may be shared, so compare
ratios (and the CPU-time ratio, which other processes disturb less) rather than absolute rates.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time

import floors
import numpy as np

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies, select_policies
from taskcomplexity.rwg import RWGSettings, _simulate_batched, initial_states, run_rwg
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.spec import make_task

PAPER_STUDY = CONF_DIR / "study" / "seven_tasks.yaml"


def throughput(task, settings, backend, repeats):
    rates = []
    for _ in range(repeats):
        started = time.perf_counter()
        chunk = run_rwg(task, NetworkSpec(), PriorSpec(), settings, backend)
        rates.append(chunk.steps.sum() / (time.perf_counter() - started))
    return statistics.median(rates), int(chunk.steps.sum())


def fused_against_stepwise(arm, reward, contacts, policies, episodes, repeats):
    """Median episodes/s (wall) of both paths on one chunk, the median CPU-time ratio, max |Δ return|."""
    task = make_task(arm, reward)
    indices = np.arange(policies)
    batch = sample_policies(NetworkSpec(), PriorSpec(), task.observation_size, task.action_size, 1, indices)
    joint_angles, target = initial_states(task, 1, indices, episodes)
    for fused in (False, True):  # compile
        _simulate_batched(task, select_policies(batch, indices[:2]), joint_angles[:2, :4], target[:2, :4], contacts,
                          fused=fused)
    wall, cpu, returns = {False: [], True: []}, {False: [], True: []}, {}
    for _ in range(repeats):
        for fused in (False, True):
            started, started_cpu = time.perf_counter(), time.process_time()
            returns[fused] = _simulate_batched(task, batch, joint_angles, target, contacts, fused=fused).returns
            wall[fused].append(time.perf_counter() - started)
            cpu[fused].append(time.process_time() - started_cpu)
    rate = {fused: policies * episodes / statistics.median(wall[fused]) for fused in wall}
    cpu_ratio = statistics.median(cpu[False]) / statistics.median(cpu[True])
    return rate[False], rate[True], cpu_ratio, float(np.abs(returns[True] - returns[False]).max())


FULL_SCALE = """
import json, resource, time
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.spec import make_task
task = make_task({arm!r}, {reward!r})
settings = dict(seed=0, contacts={contacts!r})
run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=4, episodes=4, **settings), "batched")  # compile
started = time.perf_counter()
chunk = run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies={n}, episodes={m}, **settings), "batched")
seconds = time.perf_counter() - started
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
print(json.dumps({{"seconds": seconds, "peak_gb": peak, "steps": int(chunk.steps.sum()), "handoffs": chunk.handoffs,
                  "contacts": chunk.contacts}}))
"""


def full_scale(arm, reward, n, m, contacts="model"):
    out = subprocess.run(
        [sys.executable, "-c", FULL_SCALE.format(arm=arm, reward=reward, n=n, m=m, contacts=contacts)],
        capture_output=True, text=True, check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def hand_over_cost(policies, episodes):
    """Seconds per obstacle episode with exact hand-overs to PyBullet (a small run, projected)."""
    task = make_task("two_link_obstacle", "dense")
    settings = RWGSettings(policies=40, episodes=10, seed=0)
    started = time.perf_counter()
    chunk = run_rwg(task, NetworkSpec(), PriorSpec(), settings, "batched")
    per_episode = (time.perf_counter() - started) / chunk.returns.size
    return per_episode * policies * episodes, chunk.handoffs / chunk.returns.size


def pybullet_floor(env, torques: np.ndarray, max_steps: int) -> int:
    """Bare ``stepSimulation`` × substeps per row of ``torques`` (N·m) on the PyBullet reference's world ``env``, the
    torque set as the env sets it; ``reset()`` every ``max_steps`` rows (an episode's length at most)."""
    client, arm, joints, control = env.client, env.arm_id, env._joints, env._torque_control
    simulate, substeps = client.stepSimulation, env.task.arm.substeps
    for i, torque in enumerate(torques):
        if i % max_steps == 0:
            env.reset(seed=i)
        client.setJointMotorControlArray(arm, joints, control, forces=list(torque))
        for _ in range(substeps):
            simulate()
    return len(torques)


def pybullet_against_floor(arm, reward, policies, episodes, repeats):
    """The pybullet backend's CPU per step (``run_rwg``, one process) and its floor's (:func:`pybullet_floor` on as
    many steps), medians of ``repeats`` interleaved runs: (backend CPU-µs/step, floor CPU-µs/step, steps)."""
    from taskcomplexity.tasks.pybullet_env import ReachingEnv

    task = make_task(arm, reward)
    settings = RWGSettings(policies=policies, episodes=episodes, seed=1)
    run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=2, episodes=2, seed=1), "pybullet")  # warm
    env = ReachingEnv(task=task)
    scale = np.asarray(task.arm.torque_scale, dtype=np.float64)
    cpu: dict[str, list[float]] = {"backend": [], "floor": []}
    try:
        for _ in range(repeats):
            started = time.process_time()
            steps = int(run_rwg(task, NetworkSpec(), PriorSpec(), settings, "pybullet").steps.sum())
            cpu["backend"].append((time.process_time() - started) / steps * 1e6)
            torques = np.random.default_rng(0).uniform(-scale, scale, (steps, task.arm.dof))
            started = time.process_time()
            pybullet_floor(env, torques, task.max_steps)
            cpu["floor"].append((time.process_time() - started) / steps * 1e6)
    finally:
        env.close()
    return statistics.median(cpu["backend"]), statistics.median(cpu["floor"]), steps


def print_pybullet_floors(policies, episodes, repeats):
    """The pybullet backend against bare ``stepSimulation`` on the two throughput tasks, with their floor lines."""
    print(f"pybullet backend against its floor, bare stepSimulation × substeps (random torques, same world), "
          f"N = {policies} × M = {episodes}, one process; CPU-µs per environment step, median of {repeats}")
    print(f"{'task':<26}{'steps':>9}{'pybullet':>11}{'floor':>9}{'×floor':>8}")
    for arm, reward in (("one_link_1m0", "dense"), ("two_link", "sparse")):
        backend_us, floor_us, steps = pybullet_against_floor(arm, reward, policies, episodes, repeats)
        print(f"{arm + '-' + reward:<26}{steps:>9,}{backend_us:>11.1f}{floor_us:>9.1f}{backend_us / floor_us:>8.2f}",
              flush=True)
        floors.report("pybullet", "reaching-arms", f"{arm}-{reward}", backend_us / floor_us)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--policies", type=int, default=10_000)
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--one-task", action="store_true", help="only two_link-dense at full scale")
    parser.add_argument("--fused-only", action="store_true", help="only the fused rollout vs step by step")
    parser.add_argument("--chunk-policies", type=int, default=200, help="policies of the fused/step-by-step chunk")
    parser.add_argument("--floors-only", action="store_true",
                        help="only the pybullet backend against its floor (what bench/run.py runs on the AVX2 path)")
    parser.add_argument("--pybullet-policies", type=int, default=8, help="N = M of the pybullet backend's floor run")
    args = parser.parse_args()
    if args.floors_only:
        print_pybullet_floors(args.pybullet_policies, args.pybullet_policies, args.repeats)
        return

    size = f"{args.chunk_policies} policies × {args.episodes} episodes"
    print(f"Batched backend: fused rollout against step by step, one chunk of {size} (mlp32, N(0, I); "
          "episodes per second, wall)")
    print(f"{'task':<26}{'step by step':>14}{'fused':>12}{'ratio':>9}{'CPU ratio':>11}{'max |Δ return|':>16}")
    for arm, reward, contacts in (("one_link_1m0", "dense", "model"), ("two_link_obstacle", "dense", "model")):
        old, new, cpu_ratio, delta = fused_against_stepwise(arm, reward, contacts, args.chunk_policies, args.episodes,
                                                            args.repeats)
        print(f"{arm + '-' + reward:<26}{old:>14,.0f}{new:>12,.0f}{new / old:>8.2f}×{cpu_ratio:>10.2f}×{delta:>16.1e}",
              flush=True)
    print("(obstacle: rwg.contacts=model; returns differ only by the forward pass's float64 summation order)")
    if args.fused_only:
        return
    print()

    print("RWG throughput, same work on both backends (mlp32, N(0, I); environment steps per second)")
    print(f"{'task':<26}{'pybullet':>12}{'batched':>14}{'ratio':>10}")
    ratios = []
    for arm, reward in (("one_link_1m0", "dense"), ("two_link", "sparse")):
        task = make_task(arm, reward)
        small = RWGSettings(policies=8, episodes=8, seed=1)
        run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=2, episodes=2), "batched")  # compile
        slow, _ = throughput(task, small, "pybullet", args.repeats)
        fast, _ = throughput(task, RWGSettings(policies=400, episodes=100, seed=1), "batched", args.repeats)
        ratios.append(fast / slow)
        print(f"{task.task_id:<26}{slow:>12,.0f}{fast:>14,.0f}{fast / slow:>9.0f}×")
    print(f"median ratio batched / pybullet: {statistics.median(ratios):.0f}×  (target ≥ 300×)\n")
    print_pybullet_floors(args.pybullet_policies, args.pybullet_policies, args.repeats)

    tasks = (("two_link", "dense"),) if args.one_task else [
        (entry.selection["arm"], entry.selection["reward"]) for entry in load_study_file(PAPER_STUDY).tasks]
    print(f"\nfull scale on the batched backend: N = {args.policies:,} × M = {args.episodes} per task "
          "(obstacle: rwg.contacts=model)")
    print(f"{'task':<26}{'seconds':>10}{'peak GB':>10}{'env steps':>16}{'steps/s':>14}{'contact eps':>13}")
    total, slowest, peak = 0.0, 0.0, 0.0
    for arm, reward in tasks:
        r = full_scale(arm, reward, args.policies, args.episodes)
        total += r["seconds"]
        slowest, peak = max(slowest, r["seconds"]), max(peak, r["peak_gb"])
        print(f"{arm + '-' + reward:<26}{r['seconds']:>10.1f}{r['peak_gb']:>10.2f}{r['steps']:>16,}"
              f"{r['steps'] / r['seconds']:>14,.0f}{r['contacts']:>13,}", flush=True)
    print(f"slowest task {slowest:.1f} s (target ≤ 60 s), peak resident memory {peak:.2f} GB (target ≤ 4 GB)")
    if not args.one_task:
        print(f"all {len(tasks)} tasks: {total / 60:.1f} min  (target ≤ 10 min)")
        projected, share = hand_over_cost(args.policies, args.episodes)
        print(f"obstacle task with exact hand-overs instead (rwg.contacts=pybullet): {share:.0%} of episodes "
              f"finish on PyBullet; projected {projected / 3600:.1f} h at full scale on one core")


if __name__ == "__main__":
    main()
