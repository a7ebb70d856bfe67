"""Meta-World per-step cost: the RWG path against Meta-World's own step and the bare simulator, side by side.

    python bench/bench_metaworld.py                        # one task per difficulty group, medians of 3 (minutes)
    python bench/bench_metaworld.py --tasks reach --steps 500 --policies 4 --episodes 2 --repeats 1   # seconds

Needs the metaworld extra (``pip install -e '.[metaworld]'``); without it the script says so in one line and exits 0.

For each task (default: one of each difficulty group of ``study=metaworld``), the CPU-µs per environment step of

- ``floor``: bare ``mujoco.mj_step(model, data, nstep=frame_skip)`` on the env's own model and data, uniform random
  gripper controls: the simulator alone, what no Python layer can go below;
- ``metaworld step``: Meta-World's own ``SawyerXYZEnv.step`` in a plain loop (its Python: the mocap action, the
  site updates, ``mj_forward``, the observation with its object quaternions from SciPy, the shaped reward), a
  reset every 500 steps;
- ``task env``: the env the RWG steps (``GymTask(taskcomplexity/MetaWorld-v3).make_env()``: gymnasium's time limit
  and order wrappers around :class:`~taskcomplexity.tasks.manipulation.MetaWorldEnv`), same loop;
- ``rwg, 1 process`` / ``rwg, every core``: ``run_rwg(task, mlp32, N(0, I), RWGSettings(N, M, workers=…), "gym")``,
  CPU of this process and of the worker processes it waited for, over the steps it took; ``net of env setup``
  takes out the making of its pools (CPU per ``make_env``, measured apart, times the envs each process makes),
  a fixed cost per task that a larger N spreads thinner.

Ratios: each row against the floor and against Meta-World's own step. The RWG path cannot go below Meta-World's
step without changing its returns (its observation and reward code is what makes a step cost 3-9 floors); the
figure to watch is the RWG path's overhead over that step, and CPU-s / wall-s of the every-core run (cores busy).
Timings are facts printed, never an exit status; medians over the repeats, a first small run untimed.
"""

from __future__ import annotations

import argparse
import functools
import resource
import statistics
import sys
import time
from pathlib import Path

import numpy as np

TASKS = ("reach", "hammer", "pick-place", "stick-push")
"""One task of each difficulty group (easy, medium, hard, very hard) of study=metaworld."""


def cpu() -> float:
    """CPU seconds of this process and of the children it waited for."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def floor(env, steps: int, rng) -> float:
    import mujoco

    raw = env.unwrapped._env
    low, high = raw.model.actuator_ctrlrange.T
    controls = rng.uniform(low, high, (steps, low.size))
    start = cpu()
    for control in controls:
        raw.data.ctrl[:] = control
        mujoco.mj_step(raw.model, raw.data, nstep=raw.frame_skip)
    return (cpu() - start) / steps


def loop(step, reset, steps: int, rng) -> float:
    actions = rng.uniform(-1, 1, (steps, 4))
    reset()
    start = cpu()
    for i, action in enumerate(actions):
        if i and i % 500 == 0:
            reset()
        step(action)
    return (cpu() - start) / steps


def rwg(task, workers: int, policies: int, episodes: int) -> tuple[float, float, int, int]:
    """(CPU-s, wall-s, steps taken, envs made in all) of one RWG run."""
    from omegaconf import OmegaConf

    import taskcomplexity
    from taskcomplexity.policies.families import PriorSpec, network_from_config
    from taskcomplexity.rwg.backends import backend
    from taskcomplexity.rwg.chunking import chunk_size
    from taskcomplexity.rwg.run import run_rwg
    from taskcomplexity.rwg.settings import RWGSettings

    conf = Path(taskcomplexity.__file__).parent / "conf"
    network = network_from_config(OmegaConf.load(conf / "network" / "mlp32.yaml"))
    settings = RWGSettings(policies=policies, episodes=episodes, workers=workers)
    size = chunk_size(task, network, settings, "gym")
    in_flight = backend("gym").environments_in_flight(task)
    per_process = min(size, policies) * min(episodes, max(1, in_flight // min(size, policies)))
    processes = min(workers, -(-policies // size))  # a process per chunk at most
    envs = per_process * processes + 1  # + the replay check's env
    start, wall = cpu(), time.perf_counter()
    chunk = run_rwg(task, network, PriorSpec(), settings, "gym")
    time.sleep(0.2)  # let the pool's processes be reaped, so their CPU is counted here
    return cpu() - start, time.perf_counter() - wall, int(np.asarray(chunk.steps).sum()), envs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", default=",".join(TASKS), help="Meta-World task names, comma-separated")
    parser.add_argument("--steps", type=int, default=2000, help="steps of the floor and plain loops")
    parser.add_argument("--policies", type=int, default=16, help="N of the rwg runs")
    parser.add_argument("--episodes", type=int, default=4, help="M of the rwg runs")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    try:
        import metaworld  # noqa: F401
    except ImportError:
        print("bench_metaworld: the metaworld extra is not installed (pip install -e '.[metaworld]'); nothing "
              "measured")
        return 0
    from taskcomplexity.cores import usable_cores
    from taskcomplexity.tasks.gym_task import GymTask
    from taskcomplexity.tasks.registration import METAWORLD_ID

    cores = usable_cores()
    print(f"Meta-World per-step cost, CPU-µs per environment step (medians of {args.repeats}); rwg: N = "
          f"{args.policies} × M = {args.episodes} episodes of 500 steps, network mlp32, {cores} usable cores\n")
    header = f"{'task':<12} {'path':<34} {'CPU-µs/step':>11} {'× floor':>8} {'× MW step':>9} {'cores busy':>10}"
    print(header)
    print("-" * len(header))
    for name in args.tasks.split(","):
        task = GymTask(METAWORLD_ID, kwargs={"task_name": name, "reward": "dense"})
        env = task.make_env()
        raw = env.unwrapped._env
        rng = np.random.default_rng(0)
        start = cpu()
        made = [task.make_env() for _ in range(4)]
        make_cpu = (cpu() - start) / len(made)
        for extra in made:
            extra.close()
        rwg(task, 1, 2, 2)  # untimed: imports, compilation
        rows: dict[str, list[float]] = {}
        busy = []
        for repeat in range(args.repeats):
            rows.setdefault("floor (mj_step × frame skip)", []).append(floor(env, args.steps, rng))
            rows.setdefault("metaworld step", []).append(loop(raw.step, raw.reset, args.steps, rng))
            rows.setdefault("task env (what the rwg steps)", []).append(
                loop(env.step, functools.partial(env.reset, seed=repeat), args.steps, rng))
            for workers, label in ((1, "rwg, 1 process"), (cores, "rwg, every core")):
                spent, wall, steps, envs = rwg(task, workers, args.policies, args.episodes)
                rows.setdefault(label, []).append(spent / steps)
                rows.setdefault(label + ", net of env setup", []).append(max(0.0, spent - make_cpu * envs) / steps)
                if workers > 1:
                    busy.append(spent / wall / cores)
        env.close()
        base = statistics.median(rows["floor (mj_step × frame skip)"])
        step = statistics.median(rows["metaworld step"])
        for label, values in rows.items():
            median = statistics.median(values)
            cores_busy = f"{statistics.median(busy):.0%}" if label.startswith("rwg, every core") and busy else ""
            print(f"{name:<12} {label:<34} {median * 1e6:>11.0f} {median / base:>8.2f} {median / step:>9.2f} "
                  f"{cores_busy:>10}")
        print(f"{name:<12} {'making one env (CPU-ms)':<34} {make_cpu * 1e3:>11.0f}")
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
