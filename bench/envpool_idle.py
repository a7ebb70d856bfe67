"""Where the envpool backend leaves cores idle: its run split by what the main thread does, and by how many of a
pool's environments still run.

    .venv/bin/python bench/envpool_idle.py --task Hopper-v5 --pools 2

One RWG run on the envpool backend (N policies, one environment each, M episodes, pic_h2_64 policies, episodes of
at most ``--max-steps``), with the main thread's time split at the pool's calls into three phases: ``wait`` (blocked
in ``recv`` on one pool while the pools' threads step), ``book`` (the answer's rewards and ends booked) and
``forward`` (the next actions computed and sent, while the other pool steps). Per phase: its wall time, the main
thread's CPU and the process's (every thread's); cores busy = process CPU / wall. The same split by the number of
environments still running in the pool just answered: a chunk ends with its slowest policies (those whose M
episodes are longest) stepping alone. Idle core-seconds = cores × wall - process CPU. Needs the atlas extra
(EnvPool); the backend's ``_Group`` is wrapped, not changed.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import taskcomplexity.rwg.envpool_backend as backend
from taskcomplexity.cores import usable_cores
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.gym_task import GymTask

RUNNING = ((0, 16), (16, 64), (64, 112), (112, backend.POLICIES_PER_POOL + 1))
"""Bins of the environments still running in the pool just answered (half a chunk's 256 per pool at most)."""


def timed_run(task, policies: int, episodes: int, pools: int) -> tuple[list[tuple], float, float, int]:
    """The run with every phase timed: ([(phase, wall, main CPU, process CPU, running)], wall, CPU, steps)."""
    log: list[tuple] = []
    mark: dict = {}

    def enter(phase: str, group) -> None:
        now = time.perf_counter(), time.thread_time(), time.process_time()
        if mark:
            log.append((mark["phase"], now[0] - mark["at"][0], now[1] - mark["at"][1], now[2] - mark["at"][2],
                        mark["running"]))
        mark.update(phase=phase, at=now, running=len(group.rows))

    receive, send = backend._Group.receive, backend._Group.send

    def timed_receive(group) -> None:
        enter("wait", group)
        recv = group.pool.recv

        def answered():
            answer = recv()
            enter("book", group)
            return answer

        group.pool.recv = answered
        try:
            receive(group)
        finally:
            group.pool.recv = recv

    def timed_send(group) -> None:
        enter("forward", group)
        send(group)

    network = NetworkSpec(hidden=(64, 64), activation="tanh", output="linear")
    saved = backend.POOLS
    backend._Group.receive, backend._Group.send, backend.POOLS = timed_receive, timed_send, pools
    try:
        started, cpu = time.perf_counter(), time.process_time()
        chunk = run_rwg(task, network, PriorSpec(), RWGSettings(policies=policies, episodes=episodes, seed=0),
                        "envpool")
        return log, time.perf_counter() - started, time.process_time() - cpu, int(chunk.steps.sum())
    finally:
        backend._Group.receive, backend._Group.send, backend.POOLS = receive, send, saved


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="Hopper-v5", help="a gymnasium MuJoCo or DM Control id EnvPool simulates")
    parser.add_argument("--pools", type=int, default=backend.POOLS, help="envpool_backend.POOLS (1: lock-step)")
    parser.add_argument("--policies", type=int, default=backend.POLICIES_PER_POOL, help="N (one chunk: 256)")
    parser.add_argument("--episodes", type=int, default=400, help="M")
    parser.add_argument("--max-steps", type=int, default=100, help="episode limit")
    args = parser.parse_args()

    task = GymTask(args.task, max_steps=args.max_steps)
    task.validate()
    run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=2, episodes=2, seed=0), "envpool")  # warm
    log, wall, cpu, steps = timed_run(task, args.policies, args.episodes, args.pools)
    cores = usable_cores()
    phases = np.array([k for k, *_ in log])
    times = np.array([row[1:] for row in log], dtype=float)  # wall, main CPU, process CPU, running
    print(f"{args.task}, pools={args.pools}, N = {args.policies} × M = {args.episodes}: {steps:,} steps, "
          f"{wall:.1f} s wall, {cpu:.1f} CPU-s, {cpu / wall:.2f} of {cores} cores busy, "
          f"{cores * wall - cpu:.1f} idle core-s")
    for phase in ("wait", "book", "forward"):
        rows = times[phases == phase]
        print(f"  {phase:<8} {rows[:, 0].sum():7.1f} s wall  main thread {rows[:, 1].sum():6.1f} CPU-s  "
              f"process {rows[:, 2].sum():6.1f} CPU-s  busy {rows[:, 2].sum() / rows[:, 0].sum():.2f}")
    for low, high in RUNNING:
        rows = times[(times[:, 3] >= low) & (times[:, 3] < high)]
        if len(rows):
            spent = rows[:, 0].sum()
            print(f"  {low:>3}-{high - 1:<3} running: {spent:7.1f} s wall ({spent / times[:, 0].sum():.0%})  "
                  f"busy {rows[:, 2].sum() / spent:.2f}  idle {cores * spent - rows[:, 2].sum():.1f} core-s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
