"""MuJoCo per-step cost: RWG's gym and envpool backends against gymnasium and the bare simulator, side by side.

    python bench/bench_mujoco.py                           # the five MuJoCo presets, medians of 3 (minutes)
    python bench/bench_mujoco.py --tasks Hopper-v5 --steps 1000 --policies 4 --episodes 8 --chunk-policies 2 \\
        --max-steps 100 --repeats 1                        # one task, small budgets (seconds)
    python bench/bench_mujoco.py --max-steps 0             # episodes as long as the presets' (1000 steps)

Needs the mujoco extra (``pip install -e '.[mujoco]'``); without it the script says so in one line and exits 0.

For each of gymnasium's MuJoCo tasks that the project has presets for (``conf/task/{ant,half_cheetah,hopper,
walker2d,humanoid}.yaml``), the CPU-µs (process CPU time: every thread, and the child processes waited for) and
wall-µs per environment step of

- ``floor``: bare ``mujoco.mj_step(model, data)``, ``frame_skip`` times per environment step, on the env's own
  ``env.unwrapped.model``/``data``, with uniform random controls in the actuators' range written to
  ``data.ctrl``; ``mj_resetData`` where the gymnasium run below ended an episode (same controls, same lengths:
  otherwise a fallen body lies in contact with the floor for ever and costs what no episode costs);
- ``floor, policies' actions``: the same bare steps on the actions the rwg runs' policies take (their first
  episodes, recorded by a wrapper, replayed open loop from ``mj_resetData``, at most ``--steps``): tanh-squashed
  N(0, I) MLPs act mostly at the bounds and move the bodies otherwise than uniform controls, so the gap between
  the two floor rows is physics, not overhead;
- ``gymnasium``: ``gymnasium.make(id).step(action)`` in a plain loop on the same controls, ``reset()`` when an
  episode ends;
- ``rwg``: the project's own path, ``taskcomplexity.rwg.run_rwg(GymTask(id), network, N(0, I), RWGSettings(N, M,
  workers=…), "gym")`` (what ``pipelines/rwg.py`` and the RWG stage run for a gymnasium task), with ``workers=1``
  (in this process) and with ``workers=`` the usable cores (a pool of processes: their CPU time is counted
  too, so CPU-µs/step covers every core); the steps are those it took (its ``steps`` array). Each process
  builds its pool of environments (``task.make_env()`` per slot in flight) once per run, a fixed cost a long
  run (thousands of chunks per pool) spreads thin: it is measured apart (CPU per ``make_env``) and taken out
  in the ``net of env setup`` rows. The other fixed costs stay in: the workers' start and stop, and the OpenBLAS
  thread the parent starts again after forking them, which spins ~0.1 CPU-s (an rwg run's CPU is read
  ``SETTLE`` seconds after it returns, so that it is charged to that run, not to the next measurement).
- ``rwg envpool backend`` (with the envpool extra): ``run_rwg(…, "envpool")``, EnvPool's C++ thread pool on every
  core, one environment per policy, so it runs ``--pool-policies`` policies with as many episodes in all as the
  gym runs (``M = N·M / pool-policies``); its pools' making (CPU of ``envpool.make`` for one chunk, times the
  chunks) is taken out in its ``net of pool setup`` row. Beside it, the same run with the chunk's environments in one
  pool stepped in lock-step with the forward pass (``envpool_backend.POOLS = 1``; the backend steps two pools in
  turn), and EnvPool alone: a pool of the chunk's environments stepped on uniform random actions with no policy
  (``pool.step`` per step of all of them): the floor of EnvPool's own build of MuJoCo and its thread pool.

The goal the issue sets: the RWG path within 1.3× of the bare simulator per step (CPU), with every core busy (CPU-s
/ wall-s ≥ 90 % of the usable cores). Each task says whether it meets it, judged on the path ``backend=auto`` takes
(envpool when installed, else the gym backend's all-cores run), net of its setup; that is a printed fact, never an
exit status. Figures are medians over the repeats (the paths interleaved in each repeat); a first small run of each
path is not timed. The machine may be shared: CPU-µs are disturbed less by other processes than wall-µs, and CPU-s
/ wall-s below 1 per process means this run waited for a core. Per task, ``floor:`` lines (``bench/floors.py``) give
the envpool backend's and the gym backend's ×floor (net of their setup) and cores busy on the CPU path this runs on
(``bench/run.py`` runs this script again on the AVX2 path).
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import floors
import numpy as np

from taskcomplexity.cores import usable_cores
from taskcomplexity.rwg.envpool_backend import POLICIES_PER_POOL
from taskcomplexity.tasks.gym_task import MUJOCO_EXTRA

TASKS = ("Ant-v5", "HalfCheetah-v5", "Hopper-v5", "Walker2d-v5", "Humanoid-v5")
"""gymnasium's MuJoCo ids of the project's presets (conf/task/ant.yaml, half_cheetah, hopper, walker2d, humanoid)."""
GOAL_RATIO = 1.3
"""The issue's goal: the RWG path's CPU per step at most this many times the bare simulator's."""
BUSY = 0.9
"""… with every core busy: CPU-s / wall-s at least this share of the usable cores."""
VECTOR_FLAGS = ("avx512f", "avx512bw", "avx512vl", "avx2", "fma", "avx", "sse4_2", "asimd", "sve")
"""The /proc/cpuinfo flags that decide the code paths NumPy, torch, the BLAS and MuJoCo take."""
SETTLE = 0.5
"""Seconds after an rwg run before its CPU time is read (:func:`timed`)."""


def cpu_line() -> str:
    """The CPU model, its vector extensions (the code paths NumPy, torch, the BLAS and MuJoCo take) and the cores."""
    info = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    model = re.search(r"^(?:model name|Model)\s*:\s*(.+)$", info, flags=re.MULTILINE)
    flags = re.search(r"^(?:flags|Features)\s*:\s*(.+)$", info, flags=re.MULTILINE)
    present = set(flags.group(1).split()) if flags else set()
    return (f"CPU {model.group(1).strip() if model else 'unknown'} ({' '.join(f for f in VECTOR_FLAGS if f in present)}"
            f"), {usable_cores()} usable cores (of {os.cpu_count()})")


def clocks() -> tuple[float, float]:
    """(CPU seconds of this process's threads and of its waited-for children, wall seconds)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime, time.perf_counter()


@dataclass
class Timing:
    """One timed run: the environment steps it took and what they cost (``during``: the CPU seconds until it
    returned, for CPU-s / wall-s)."""

    steps: int
    cpu: float
    wall: float
    during: float


def timed(run, settle: float = 0.0) -> Timing:
    """``run() -> steps``, timed by :func:`clocks`; its CPU is read ``settle`` seconds after it returns, so that
    what it leaves running is charged to it, not to the next measurement (after a run on worker processes, the
    parent's OpenBLAS starts a thread again, which spins ~0.1 CPU-s before it sleeps)."""
    cpu, wall = clocks()
    steps = run()
    cpu_after, wall_after = clocks()
    time.sleep(settle)
    return Timing(steps, clocks()[0] - cpu, wall_after - wall, cpu_after - cpu)


@dataclass
class Row:
    """Medians over the repeats of one path: per-step CPU and wall µs, and CPU-s / wall-s."""

    steps: int
    cpu_us: float
    wall_us: float
    busy: float

    @staticmethod
    def of(timings: list[Timing], setup_cpu: float = 0.0) -> Row:
        """The medians; ``setup_cpu`` seconds are taken out of each run's CPU (``net of env setup``)."""
        return Row(int(statistics.median(t.steps for t in timings)),
                   statistics.median((t.cpu - setup_cpu) / t.steps * 1e6 for t in timings),
                   statistics.median(t.wall / t.steps * 1e6 for t in timings),
                   statistics.median(t.during / t.wall for t in timings))


def gym_loop(env, actions: np.ndarray, ends: np.ndarray, seed: int) -> int:
    """``env.step`` on each action, ``reset`` when an episode ends (recorded in ``ends``)."""
    env.reset(seed=seed)
    for i, action in enumerate(actions):
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
            ends[i] = True
    return len(actions)


def floor_loop(env, controls: np.ndarray, ends: np.ndarray) -> int:
    """Bare ``mj_step`` × frame_skip per control row on the env's own model and data; reset where ``ends``."""
    import mujoco

    unwrapped = env.unwrapped
    model, data, skip = unwrapped.model, unwrapped.data, unwrapped.frame_skip
    step, reset, ctrl = mujoco.mj_step, mujoco.mj_resetData, data.ctrl
    reset(model, data)
    for control, end in zip(controls, ends, strict=True):
        ctrl[:] = control
        for _ in range(skip):
            step(model, data)
        if end:
            reset(model, data)
    return len(controls)


def recorded_actions(env_id: str, max_steps: int, network, prior, seed: int, policies: int, episodes: int,
                     steps: int) -> list[np.ndarray]:
    """The actions the gym backend's policies 0 … ``policies``−1 take in their first ``episodes`` episodes (as in
    any run of the same seed), one array per episode, the first ``steps`` of them in the order they ran."""
    import gymnasium

    from taskcomplexity.rwg import RWGSettings, simulate_chunk
    from taskcomplexity.tasks.gym_task import GymTask

    log: list[list[np.ndarray]] = []

    class Recorder(gymnasium.Wrapper):
        episode: list[np.ndarray] = []

        def reset(self, **kwargs):
            self.episode = []
            log.append(self.episode)
            return self.env.reset(**kwargs)

        def step(self, action):
            self.episode.append(np.array(action, dtype=np.float64))
            return self.env.step(action)

    class RecordingTask(GymTask):
        def make_env(self, **kwargs):
            return Recorder(super().make_env(**kwargs))

    settings = RWGSettings(policies=max(2, policies), episodes=max(2, episodes), seed=seed)
    simulate_chunk(RecordingTask(env_id, max_steps=max_steps), network, prior, settings, 0, policies, backend="gym")
    taken, total = [], 0
    for actions in (np.array(actions) for actions in log if actions):
        taken.append(actions[:steps - total])
        total += len(taken[-1])
        if total >= steps:
            break
    return taken


def replay_loop(env, episodes: list[np.ndarray]) -> int:
    """Bare ``mj_step`` × frame_skip per recorded action, each episode from ``mj_resetData``."""
    import mujoco

    unwrapped = env.unwrapped
    model, data, skip = unwrapped.model, unwrapped.data, unwrapped.frame_skip
    step, reset, ctrl = mujoco.mj_step, mujoco.mj_resetData, data.ctrl
    for actions in episodes:
        reset(model, data)
        for control in actions:
            ctrl[:] = control
            for _ in range(skip):
                step(model, data)
    return sum(len(actions) for actions in episodes)


def setup_seconds(task, envs: int) -> float:
    """Median CPU seconds of one ``task.make_env()`` (and its close), over ``envs`` of them."""
    seconds = []
    for _ in range(envs):
        started = time.process_time()
        env = task.make_env()
        env.close()
        seconds.append(time.process_time() - started)
    return statistics.median(seconds)


def bench_task(env_id: str, args: argparse.Namespace, network, cores: int) -> dict:
    """Every path on one task; prints its table and returns the summary's figures."""
    import gymnasium

    from taskcomplexity.policies.mlp import PriorSpec
    from taskcomplexity.rwg import RWGSettings, chunks, run_rwg
    from taskcomplexity.rwg.backends import backend
    from taskcomplexity.rwg.gym_backend import slots_per_policy
    from taskcomplexity.rwg.workers import worker_count
    from taskcomplexity.tasks.gym_task import GymTask

    task = GymTask(env_id, max_steps=args.max_steps or None)
    limit = task.max_steps
    task.validate()  # its first make_env() routes MuJoCo's warnings to the task's log (not stderr) from here on
    env = gymnasium.make(env_id, max_episode_steps=limit)
    unwrapped = env.unwrapped
    skip, actuators = unwrapped.frame_skip, unwrapped.model.nu
    rng = np.random.default_rng(args.seed)
    low, high = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    controls = rng.uniform(low, high, (args.steps, actuators))
    actions = controls.astype(env.action_space.dtype)
    ends = np.zeros(args.steps, dtype=bool)
    warm = min(args.steps, 100)
    gym_loop(env, actions[:warm], ends[:warm].copy(), args.seed)
    floor_loop(env, controls[:warm], ends[:warm])

    def settings(workers: int) -> RWGSettings:
        return RWGSettings(policies=args.policies, episodes=args.episodes, seed=args.seed,
                           chunk_policies=args.chunk_policies, workers=workers)

    prior = PriorSpec()
    run_rwg(task, network, prior, RWGSettings(policies=2, episodes=2, seed=args.seed, workers=1), "gym")  # warm
    ranges = chunks(task, network, settings(cores), "gym")
    first = ranges[0][1] - ranges[0][0]
    in_flight = first * slots_per_policy(first, args.episodes, backend("gym").environments_in_flight(task))
    processes = worker_count(settings(cores), len(ranges))
    per_env = setup_seconds(task, min(in_flight, args.setup_envs))
    taken = recorded_actions(env_id, limit, network, prior, args.seed, args.policies, min(args.episodes, 4),
                             args.steps)
    replay_loop(env, taken[:2])

    def rwg(workers: int) -> int:
        return int(run_rwg(task, network, prior, settings(workers), "gym").steps.sum())

    runs: dict[str, list[Timing]] = {name: [] for name in ("floor", "replay", "gym", "1", "W")}
    for _ in range(args.repeats):
        ends[:] = False
        runs["gym"].append(timed(lambda: gym_loop(env, actions, ends, args.seed)))
        runs["floor"].append(timed(lambda: floor_loop(env, controls, ends)))
        runs["replay"].append(timed(lambda: replay_loop(env, taken)))
        runs["1"].append(timed(lambda: rwg(1), SETTLE))
        runs["W"].append(timed(lambda: rwg(cores), SETTLE))
    pool = envpool_row(task, network, prior, args, cores)
    env.close()
    episodes_gym = int(ends.sum())

    setup = in_flight * per_env
    floor = Row.of(runs["floor"])
    rows = [
        (f"floor: mj_step ×{skip}", floor, 1),
        ("floor, policies' actions", Row.of(runs["replay"]), 1),
        ("gymnasium.make().step", Row.of(runs["gym"]), 1),
        ("rwg gym backend, workers=1", Row.of(runs["1"]), 1),
        (f"rwg gym backend, workers={cores}", Row.of(runs["W"]), processes),
        ("  net of env setup, workers=1", Row.of(runs["1"], setup), 1),
        (f"  net of env setup, workers={cores}", Row.of(runs["W"], processes * setup), processes),
        *pool,
    ]
    print(f"\n{env_id}: frame_skip {skip}, {actuators} actuators, observation {task.observation_size}, episodes ≤ "
          f"{limit} steps (gymnasium's run: {episodes_gym} episodes ended in {args.steps} steps); rwg: N = "
          f"{args.policies} × M = {args.episodes}, {len(ranges)} chunks of ≤ {first} policies, {in_flight} envs in "
          f"flight per process; the policies' actions: {len(taken)} episodes; medians of {args.repeats}")
    head = (f"{'path':<42}{'steps':>9}{'CPU-µs/step':>13}{'×floor':>8}{'wall-µs/step':>14}{'CPU-s/wall-s':>14}"
            f"{'processes':>11}")
    print(head)
    print("-" * len(head))
    for name, row, procs in rows:
        print(f"{name:<42}{row.steps:>9,}{row.cpu_us:>13.1f}{row.cpu_us / floor.cpu_us:>8.2f}{row.wall_us:>14.1f}"
              f"{row.busy:>14.2f}{procs:>11}")
    share = processes * setup / statistics.median(t.cpu for t in runs["W"])
    print(f"env setup: {per_env * 1e3:.2f} ms CPU per task.make_env() (median of {min(in_flight, args.setup_envs)}), "
          f"× {in_flight} envs × processes: {setup:.2f} CPU-s with workers=1, {processes * setup:.2f} with workers="
          f"{cores} ({share:.0%} of that run's CPU)")
    if processes < cores:
        print(f"note: {len(ranges)} chunks keep only {processes} of {cores} cores stepping (one chunk per process at "
              f"a time): raise --policies")
    net, busy = (rows[8][1], rows[7][1].busy) if pool else (rows[6][1], rows[4][1].busy)
    ratio = net.cpu_us / floor.cpu_us
    fast, full = ratio <= GOAL_RATIO, busy >= BUSY * cores
    judged = "the envpool run net of pool setup" if pool else f"the workers={cores} run net of env setup"
    print(f"goal (rwg within {GOAL_RATIO}× of the floor per step, all {cores} cores busy), on {judged}: "
          f"CPU ×floor {ratio:.2f} ({'≤' if fast else '>'} {GOAL_RATIO}), {busy:.2f} of {cores} "
          f"cores busy ({'≥' if full else '<'} {BUSY:.0%}): {'met' if fast and full else 'not met'}", flush=True)
    floors.report("gym", "mujoco", env_id, rows[6][1].cpu_us / floor.cpu_us, rows[4][1].busy / cores,
                  part=rows[2][1].cpu_us / floor.cpu_us)
    if pool:
        floors.report("envpool", "mujoco", env_id, rows[8][1].cpu_us / floor.cpu_us, rows[7][1].busy / cores,
                      part=rows[10][1].cpu_us / floor.cpu_us)
    return {"task": env_id, "floor": floor, "rows": [row for _, row, _ in rows], "met": fast and full}


def envpool_row(task, network, prior, args: argparse.Namespace, cores: int) -> list:
    """The envpool backend's rows (the run; net of making its pools; net of them with its pools in lock-step; EnvPool
    stepping the same environments alone on random actions), or none without EnvPool."""
    import taskcomplexity.rwg.envpool_backend as backend
    from taskcomplexity.rwg import RWGSettings, chunks, run_rwg
    from taskcomplexity.rwg.envpool_backend import environment_seeds, make_pool
    from taskcomplexity.tasks.envpool_ids import envpool_id

    if envpool_id(task) is None:
        return []
    episodes = max(2, args.policies * args.episodes // args.pool_policies)
    settings = RWGSettings(policies=args.pool_policies, episodes=episodes, seed=args.seed)
    run_rwg(task, network, prior, RWGSettings(policies=2, episodes=2, seed=args.seed), "envpool")  # warm
    ranges = chunks(task, network, settings, "envpool")
    seeds = environment_seeds(args.seed, np.arange(ranges[0][1] - ranges[0][0]))
    making = []
    for _ in range(3):
        started = time.process_time()
        for group in np.array_split(seeds, min(backend.POOLS, len(seeds))):  # the pools run_envpool makes
            make_pool(task, group).close()
        making.append(time.process_time() - started)
    pools = backend.POOLS

    def rwg(groups: int) -> int:
        backend.POOLS = groups
        try:
            return int(run_rwg(task, network, prior, settings, "envpool").steps.sum())
        finally:
            backend.POOLS = pools

    runs: dict[str, list[Timing]] = {"pools": [], "lock-step": [], "alone": []}
    for _ in range(args.repeats):
        runs["pools"].append(timed(lambda: rwg(pools)))
        runs["lock-step"].append(timed(lambda: rwg(1)))
        runs["alone"].append(envpool_alone(task, seeds, runs["pools"][-1].steps, args.seed))
    setup = len(ranges) * statistics.median(making)
    return [(f"rwg envpool backend, N={args.pool_policies} M={episodes}", Row.of(runs["pools"]), 1),
            ("  net of pool setup", Row.of(runs["pools"], setup), 1),
            ("  net of pool setup, 1 pool lock-step", Row.of(runs["lock-step"], setup), 1),
            (f"EnvPool alone, {len(seeds)} envs, random actions", Row.of(runs["alone"]), 1)]


def envpool_alone(task, seeds: np.ndarray, steps: int, seed: int) -> Timing:
    """EnvPool stepping a pool of ``len(seeds)`` environments of ``task`` in lock-step on uniform random actions (no
    policy, no Python per step but the call), about ``steps`` environment steps in all, timed without making the pool:
    the backend's floor on EnvPool's build of the simulator."""
    from taskcomplexity.rwg.envpool_backend import make_pool

    pool = make_pool(task, seeds)
    try:
        pool.reset()
        space = task.action_space
        calls = max(1, steps // len(seeds))
        actions = np.random.default_rng(seed).uniform(space.low, space.high, (calls, len(seeds), *space.shape))
        every = np.arange(len(seeds))

        def run() -> int:
            for action in actions:
                pool.step(action, env_id=every)
            return calls * len(seeds)

        return timed(run)
    finally:
        pool.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    parser.add_argument("--steps", type=int, default=5000, help="environment steps of the floor and gymnasium runs")
    parser.add_argument("--policies", type=int, default=4, help="N of the rwg runs")
    parser.add_argument("--episodes", type=int, default=256, help="M of the rwg runs")
    parser.add_argument("--chunk-policies", type=int, default=0,
                        help="rwg.chunk_policies (0: the project's choice, ~256 envs in flight per process)")
    parser.add_argument("--max-steps", type=int, default=100,
                        help="episode limit of every path (0: the env's own, 1000 for these tasks; HalfCheetah never "
                             "ends an episode sooner, so 1000 makes its runs minutes long)")
    parser.add_argument("--network", default="pic_h2_64", choices=("pic_h2_64", "mlp32"),
                        help="the policy family (pic_h2_64: study=furuta_benchmark's; mlp32: the default arms')")
    parser.add_argument("--setup-envs", type=int, default=16, help="make_env() calls timed for the env setup")
    parser.add_argument("--pool-policies", type=int, default=POLICIES_PER_POOL,
                        help="N of the envpool runs (one environment per policy; M: as many episodes as the gym runs)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    try:
        import mujoco
    except ImportError:
        print(f"bench_mujoco: skipped, MuJoCo is not installed: this bench needs the mujoco extra ({MUJOCO_EXTRA})")
        return 0

    from taskcomplexity.policies.mlp import NetworkSpec

    network = (NetworkSpec(hidden=(64, 64), activation="tanh", output="linear") if args.network == "pic_h2_64"
               else NetworkSpec())
    cores = usable_cores()
    print(f"{cpu_line()}; MuJoCo {mujoco.__version__}, gymnasium {__import__('gymnasium').__version__}, Python "
          f"{sys.version.split()[0]}; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}; network {args.network}, prior N(0, I)")
    print(f"per environment step: CPU-µs (this process's threads + its worker processes) and wall-µs; ×floor = "
          f"CPU-µs / the floor's. Goal: rwg ≤ {GOAL_RATIO}× the floor, CPU-s/wall-s ≥ {BUSY:.0%} of {cores} cores")
    results = [bench_task(env_id, args, network, cores) for env_id in args.tasks]

    print("\nsummary: CPU-µs/step of the floor; ×floor (CPU-µs/step ÷ the floor's) of the other paths; wall-µs/step "
          "and CPU-s/wall-s of rwg. pol. = the floor on the policies' actions, net = rwg net of env setup; pool net = "
          "the envpool backend net of pool setup, lock = the same with one pool in lock-step, alone = EnvPool stepping "
          "its environments on random actions (EnvPool's floor)")
    head = (f"{'task':<16}{'floor':>8}{'pol.':>7}{'gym':>7}{'rwg×1':>7}{'rwg×' + str(cores):>7}{'net×1':>7}"
            f"{'net×' + str(cores):>7}{'wall×1':>9}{'wall×' + str(cores):>9}{'busy×' + str(cores):>8}{'pool':>7}"
            f"{'pool net':>9}{'lock':>7}{'alone':>7}{'pool wall':>10}{'pool busy':>10}{'goal':>10}")
    print(head)
    print("-" * len(head))
    for r in results:
        floor, (_, replay, gym, one, every, net_one, net_every, *pool) = r["floor"], r["rows"]
        ratios = "".join(f"{row.cpu_us / floor.cpu_us:>7.2f}" for row in (replay, gym, one, every, net_one, net_every))
        pooled = (f"{pool[0].cpu_us / floor.cpu_us:>7.2f}{pool[1].cpu_us / floor.cpu_us:>9.2f}"
                  f"{pool[2].cpu_us / floor.cpu_us:>7.2f}{pool[3].cpu_us / floor.cpu_us:>7.2f}{pool[0].wall_us:>10.1f}"
                  f"{pool[0].busy:>10.2f}" if pool else f"{'-':>7}{'-':>9}{'-':>7}{'-':>7}{'-':>10}{'-':>10}")
        print(f"{r['task']:<16}{floor.cpu_us:>8.1f}{ratios}{one.wall_us:>9.1f}{every.wall_us:>9.1f}{every.busy:>8.2f}"
              f"{pooled}{'met' if r['met'] else 'not met':>10}")
    met = sum(r["met"] for r in results)
    print(f"{met} of {len(results)} tasks meet the goal (the path backend=auto takes, net of its setup, within "
          f"{GOAL_RATIO}× of the floor's CPU per step, with ≥ {BUSY:.0%} of {cores} cores busy)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
