"""The gym backend on a researcher's own env: RWG's CPU per step against a bare loop of the env's ``step()``.

    python bench/bench_gym.py                            # both envs, medians of 3 (a minute or two)
    python bench/bench_gym.py --envs point_mass --policies 8 --episodes 8 --repeats 1   # seconds

Two envs of the kind a researcher brings (``task.env_id="module:Env-v0"``, run by ``backend=gym``):

- ``point_mass``: a MuJoCo point mass on a plane pushed towards the origin by two motors, a gymnasium
  ``MujocoEnv`` defined here (:class:`PointMass`, DM Control's point mass in gymnasium's API); needs the mujoco
  extra (``pip install -e '.[mujoco]'``), skipped in one line without it;
- ``reach1d``: the tutorial's NumPy point mass on a line (``examples/lab/reach1d.py``).

Per env, the CPU-µs (this process's threads and its worker processes) and wall-µs per environment step of

- ``floor``: ``env.step(action)`` in a plain loop on one ``task.make_env()`` (the env as RWG makes it: gymnasium's
  wrappers, no checker), uniform random actions, ``reset()`` when an episode ends;
- ``floor, K envs in turn``: the same loop over the K environments one RWG process keeps in flight, stepped one
  after another: what their working set costs in the caches, before any policy runs;
- ``forward pass``: the policies' ``act`` over the K environments, per row (one call per step of the pool);
- ``rwg gym backend``: ``run_rwg(GymTask(id), network, N(0, I), RWGSettings(N, M, workers=…), "gym")`` with
  ``workers=1`` (in this process) and ``workers=`` the usable cores (their CPU counted too), and both net of env
  setup (the CPU of ``task.make_env()`` times the environments each process makes).

Then the ``vector`` backend on a researcher's NumPy-vectorised env (``vector_pendulum``: ``tests/vector_pendulum.py``,
gymnasium's Pendulum K at a time) against its floor: the vector env's own ``step()`` on random actions over as many
environments as one process keeps in flight.

×floor is CPU-µs/step over the floor's. The goal the issue sets: the all-cores run net of env setup within 1.3× of
the floor, with every core busy (CPU-s / wall-s ≥ 90 % of the usable cores); a printed fact, never an exit status.
The rows between floor and rwg split the distance into its parts. Figures are medians over the repeats, the paths
interleaved in each repeat; the machine may be shared (CPU-µs are disturbed less than wall-µs by other processes).
Per env, a ``floor:`` line (``bench/floors.py``) gives the backend's ×floor and cores busy on the CPU path this runs on
(``bench/run.py`` runs this script again on the AVX2 path).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import floors
import gymnasium
import numpy as np
from bench_mujoco import SETTLE, Row, Timing, cpu_line, setup_seconds, timed

from taskcomplexity.cores import usable_cores

ROOT = Path(__file__).resolve().parent.parent
GOAL_RATIO = 1.3
"""The issue's goal: the gym backend's CPU per step at most this many times a bare loop of the env's ``step()``."""
BUSY = 0.9
"""… with every core busy: CPU-s / wall-s at least this share of the usable cores."""
POINT_MASS_XML = """<mujoco model="point_mass">
  <option timestep="0.02"/>
  <default>
    <joint type="slide" damping="1" limited="true" range="-.29 .29"/>
    <motor gear=".1" ctrlrange="-1 1" ctrllimited="true"/>
  </default>
  <worldbody>
    <geom name="ground" type="plane" size=".3 .3 .1"/>
    <geom name="wall_x" type="plane" pos="-.3 0 .02" zaxis="1 0 0" size=".02 .3 .02"/>
    <geom name="wall_y" type="plane" pos="0 -.3 .02" zaxis="0 1 0" size=".3 .02 .02"/>
    <geom name="wall_neg_x" type="plane" pos=".3 0 .02" zaxis="-1 0 0" size=".02 .3 .02"/>
    <geom name="wall_neg_y" type="plane" pos="0 .3 .02" zaxis="0 -1 0" size=".3 .02 .02"/>
    <body name="pointmass" pos="0 0 .01">
      <joint name="root_x" axis="1 0 0"/>
      <joint name="root_y" axis="0 1 0"/>
      <geom name="pointmass" type="sphere" size=".01" mass=".3"/>
    </body>
  </worldbody>
  <actuator>
    <motor joint="root_x"/>
    <motor joint="root_y"/>
  </actuator>
</mujoco>
"""


def point_mass_class():
    """:class:`PointMass`, defined when MuJoCo is installed (gymnasium's ``MujocoEnv`` imports it)."""
    from gymnasium.envs.mujoco import MujocoEnv

    class PointMass(MujocoEnv):
        """A point mass on a 0.6 m square pushed by two motors (force in [-0.1, 0.1] N): observation (x, y, ẋ, ẏ),
        reward −distance to the origin, the episode ends within 1.5 cm of it; two physics steps of 20 ms per step."""

        metadata = {"render_modes": ["human", "rgb_array", "depth_array", "rgbd_tuple"], "render_fps": 25}

        def __init__(self, xml_file: str, **kwargs):
            observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (4,), np.float64)
            MujocoEnv.__init__(self, xml_file, 2, observation_space=observation_space, **kwargs)

        def step(self, action):
            self.do_simulation(action, self.frame_skip)
            distance = float(np.linalg.norm(self.data.qpos))
            return self._get_obs(), -distance, distance < 0.015, False, {}

        def reset_model(self):
            self.set_state(self.init_qpos + self.np_random.uniform(-0.25, 0.25, self.model.nq), self.init_qvel)
            return self._get_obs()

        def _get_obs(self):
            return np.concatenate([self.data.qpos, self.data.qvel])

    return PointMass


def register_envs() -> dict[str, tuple[str, dict]]:
    """Register the envs this bench measures: name -> (gymnasium id, kwargs)."""
    envs = {}
    try:
        import mujoco  # noqa: F401
    except ImportError:
        print("point_mass: skipped, MuJoCo is not installed (pip install -e '.[mujoco]')")
    else:
        xml = Path(tempfile.mkdtemp(prefix="bench_gym-")) / "point_mass.xml"
        xml.write_text(POINT_MASS_XML)
        gymnasium.register("BenchPointMass-v0", entry_point=point_mass_class(), max_episode_steps=200)
        envs["point_mass"] = ("BenchPointMass-v0", {"xml_file": str(xml)})
    sys.path.insert(0, str(ROOT / "examples" / "lab"))
    import reach1d  # noqa: F401  (registers Reach1D-v0)

    envs["reach1d"] = ("Reach1D-v0", {})
    return envs


def step_loop(envs: list, actions: np.ndarray) -> int:
    """``env.step`` on each action, the environments in turn; ``reset()`` where an episode ends."""
    count = len(envs)
    for i, action in enumerate(actions):
        env = envs[i % count]
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return len(actions)


def forward_loop(policies, observations, calls: int) -> int:
    """``calls`` forward passes over ``observations`` (P, W, obs): rows computed."""
    import torch

    with torch.no_grad():
        for _ in range(calls):
            policies.act(observations)
    return calls * observations.shape[0] * observations.shape[1]


def bench_env(name: str, env_id: str, kwargs: dict, args: argparse.Namespace, network, cores: int) -> dict:
    """Every path on one env; prints its table and returns the summary's figures."""
    import torch

    from taskcomplexity.policies.families import sample_family
    from taskcomplexity.policies.mlp import PriorSpec
    from taskcomplexity.rwg import RWGSettings, chunks, run_rwg
    from taskcomplexity.rwg.backends import backend
    from taskcomplexity.rwg.gym_backend import slots_per_policy
    from taskcomplexity.tasks.gym_task import GymTask

    task = GymTask(env_id, kwargs=kwargs).validate()
    prior = PriorSpec()

    def settings(workers: int) -> RWGSettings:
        return RWGSettings(policies=args.policies, episodes=args.episodes, seed=args.seed, workers=workers)

    ranges = chunks(task, network, settings(cores), "gym")
    first = ranges[0][1] - ranges[0][0]
    width = slots_per_policy(first, args.episodes, backend("gym").environments_in_flight(task))
    in_flight = first * width
    processes = max(1, min(cores, len(ranges)))  # rwg.workers=0: one process per core, at most one per chunk
    rng = np.random.default_rng(args.seed)
    space = task.action_space
    actions = rng.uniform(space.low, space.high, (args.steps, *space.shape)).astype(space.dtype)
    one = [task.make_env()]
    many = [task.make_env() for _ in range(in_flight)]
    for i, env in enumerate(one + many):
        env.reset(seed=args.seed + i)
    policies = sample_family(task, network, prior, args.seed, np.arange(first))
    observations = torch.from_numpy(rng.standard_normal((first, width, task.observation_size)))
    calls = max(1, args.steps // in_flight)
    per_env = setup_seconds(task, min(in_flight, args.setup_envs))
    step_loop(one, actions[:200])
    step_loop(many, actions[:in_flight])
    forward_loop(policies, observations, 2)
    run_rwg(task, network, prior, RWGSettings(policies=2, episodes=2, seed=args.seed, workers=1), "gym")  # warm

    def rwg(workers: int) -> int:
        return int(run_rwg(task, network, prior, settings(workers), "gym").steps.sum())

    runs: dict[str, list[Timing]] = {key: [] for key in ("floor", "many", "forward", "1", "W")}
    for _ in range(args.repeats):
        runs["floor"].append(timed(lambda: step_loop(one, actions)))
        runs["many"].append(timed(lambda: step_loop(many, actions)))
        runs["forward"].append(timed(lambda: forward_loop(policies, observations, calls)))
        runs["1"].append(timed(lambda: rwg(1), SETTLE))
        runs["W"].append(timed(lambda: rwg(cores), SETTLE))
    for env in one + many:
        env.close()
    setup = in_flight * per_env
    floor = Row.of(runs["floor"])
    rows = [
        ("floor: env.step() loop, 1 env", floor, 1),
        (f"floor, {in_flight} envs in turn", Row.of(runs["many"]), 1),
        (f"forward pass, per row ({first}×{width})", Row.of(runs["forward"]), 1),
        ("rwg gym backend, workers=1", Row.of(runs["1"]), 1),
        (f"rwg gym backend, workers={cores}", Row.of(runs["W"]), processes),
        ("  net of env setup, workers=1", Row.of(runs["1"], setup), 1),
        (f"  net of env setup, workers={cores}", Row.of(runs["W"], processes * setup), processes),
    ]
    print(f"\n{name} ({env_id}): observation {task.observation_size}, action {task.action_size}, episodes ≤ "
          f"{task.max_steps} steps; rwg: N = {args.policies} × M = {args.episodes}, {len(ranges)} chunks of ≤ {first} "
          f"policies × {width} episodes in flight = {in_flight} envs per process; medians of {args.repeats}")
    print_rows(rows, floor)
    print(f"env setup: {per_env * 1e3:.2f} ms CPU per task.make_env() × {in_flight} envs × processes")
    net, busy = rows[6][1], rows[4][1].busy
    ratio = net.cpu_us / floor.cpu_us
    fast, full = ratio <= GOAL_RATIO, busy >= BUSY * cores
    print(f"goal (rwg within {GOAL_RATIO}× of the floor per step, all {cores} cores busy), on the workers={cores} run "
          f"net of env setup: CPU ×floor {ratio:.2f} ({'≤' if fast else '>'} {GOAL_RATIO}), {busy:.2f} of {cores} "
          f"cores busy ({'≥' if full else '<'} {BUSY:.0%}): {'met' if fast and full else 'not met'}", flush=True)
    floors.report("gym", "user-env", name, ratio, busy / cores, part=rows[1][1].cpu_us / floor.cpu_us)
    return {"env": name, "floor": floor, "rows": [row for _, row, _ in rows], "met": fast and full}


def bench_vector(args: argparse.Namespace, network, cores: int) -> None:
    """The ``vector`` backend on a researcher's NumPy-vectorised env (``tests/vector_pendulum.py``: gymnasium's
    Pendulum, K at a time) against the vector env's own ``step()`` on random actions, K environments as one process
    keeps in flight; prints its table and its floor line."""
    from taskcomplexity.policies.mlp import PriorSpec
    from taskcomplexity.rwg import RWGSettings, chunks, run_rwg
    from taskcomplexity.rwg.backends import backend
    from taskcomplexity.rwg.gym_backend import slots_per_policy
    from taskcomplexity.tasks.gym_task import GymTask
    from taskcomplexity.tasks.vectorised import make_vector

    sys.path.insert(0, str(ROOT / "tests"))
    task = GymTask("vector_pendulum:VectorPendulum-v0").validate()
    prior = PriorSpec()

    def settings(workers: int) -> RWGSettings:
        return RWGSettings(policies=args.policies, episodes=args.episodes, seed=args.seed, workers=workers)

    ranges = chunks(task, network, settings(cores), "vector")
    first = ranges[0][1] - ranges[0][0]
    in_flight = first * slots_per_policy(first, args.episodes, backend("vector").environments_in_flight(task))
    processes = max(1, min(cores, len(ranges)))
    env = make_vector(task, in_flight)
    space = task.action_space
    calls = max(1, args.steps // in_flight)
    actions = np.random.default_rng(args.seed).uniform(space.low, space.high, (calls, in_flight, *space.shape))
    actions = actions.astype(space.dtype)

    def floor_loop() -> int:
        env.reset(seed=[args.seed + i for i in range(in_flight)])
        for action in actions:
            env.step(action)
        return calls * in_flight

    def rwg(workers: int) -> int:
        return int(run_rwg(task, network, prior, settings(workers), "vector").steps.sum())

    floor_loop()
    run_rwg(task, network, prior, RWGSettings(policies=2, episodes=2, seed=args.seed, workers=1), "vector")  # warm
    runs: dict[str, list[Timing]] = {key: [] for key in ("floor", "1", "W")}
    for _ in range(args.repeats):
        runs["floor"].append(timed(floor_loop))
        runs["1"].append(timed(lambda: rwg(1), SETTLE))
        runs["W"].append(timed(lambda: rwg(cores), SETTLE))
    env.close()
    floor = Row.of(runs["floor"])
    rows = [(f"floor: vector env step(), {in_flight} envs", floor, 1),
            ("rwg vector backend, workers=1", Row.of(runs["1"]), 1),
            (f"rwg vector backend, workers={cores}", Row.of(runs["W"]), processes)]
    print(f"\nvector_pendulum ({task.env_id}, the vector backend): observation {task.observation_size}, action "
          f"{task.action_size}, episodes ≤ {task.max_steps} steps; rwg: N = {args.policies} × M = {args.episodes}, "
          f"{len(ranges)} chunks of ≤ {first} policies, {in_flight} envs per vector env; medians of {args.repeats}")
    print_rows(rows, floor)
    floors.report("vector", "user-env", "vector_pendulum", rows[2][1].cpu_us / floor.cpu_us, rows[2][1].busy / cores)


def print_rows(rows: list, floor) -> None:
    """The table of ``rows`` ((label, Row, processes)): steps, CPU-µs per step and its ratio to ``floor``'s, wall-µs per
    step, cores busy (CPU-s per wall-s), processes."""
    head = (f"{'path':<38}{'steps':>9}{'CPU-µs/step':>13}{'×floor':>8}{'wall-µs/step':>14}{'CPU-s/wall-s':>14}"
            f"{'processes':>11}")
    print(head)
    print("-" * len(head))
    for label, row, procs in rows:
        print(f"{label:<38}{row.steps:>9,}{row.cpu_us:>13.2f}{row.cpu_us / floor.cpu_us:>8.2f}{row.wall_us:>14.2f}"
              f"{row.busy:>14.2f}{procs:>11}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", nargs="+", default=["point_mass", "reach1d", "vector_pendulum"],
                        choices=["point_mass", "reach1d", "vector_pendulum"],
                        help="vector_pendulum: tests/vector_pendulum.py on the vector backend")
    parser.add_argument("--steps", type=int, default=20000, help="environment steps of the floor loops")
    parser.add_argument("--policies", type=int, default=64, help="N of the rwg runs")
    parser.add_argument("--episodes", type=int, default=32, help="M of the rwg runs")
    parser.add_argument("--network", default="pic_h2_64", choices=("pic_h2_64", "mlp32"),
                        help="the policy family (pic_h2_64: the original PIC family's; mlp32: the default arms')")
    parser.add_argument("--setup-envs", type=int, default=16, help="make_env() calls timed for the env setup")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    from taskcomplexity.policies.mlp import NetworkSpec

    network = (NetworkSpec(hidden=(64, 64), activation="tanh", output="linear") if args.network == "pic_h2_64"
               else NetworkSpec())
    cores = usable_cores()
    print(f"{cpu_line()}; Python {sys.version.split()[0]}, gymnasium {gymnasium.__version__}; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}; network {args.network}, prior N(0, I)")
    print(f"per environment step: CPU-µs (this process's threads + its worker processes) and wall-µs; ×floor = "
          f"CPU-µs / the floor's. Goal: rwg ≤ {GOAL_RATIO}× the floor, CPU-s/wall-s ≥ {BUSY:.0%} of {cores} cores")
    envs = register_envs()
    started = time.perf_counter()
    results = [bench_env(name, *envs[name], args, network, cores) for name in args.envs if name in envs]
    if "vector_pendulum" in args.envs:
        bench_vector(args, network, cores)
    print(f"\nsummary ({time.perf_counter() - started:.0f} s): CPU-µs/step of the floor; ×floor of the other paths; "
          f"busy = CPU-s/wall-s of the workers={cores} run")
    head = (f"{'env':<12}{'floor':>8}{'K envs':>8}{'fwd':>7}{'rwg×1':>7}{'rwg×' + str(cores):>7}{'net×1':>7}"
            f"{'net×' + str(cores):>7}{'busy':>7}{'goal':>9}")
    print(head)
    print("-" * len(head))
    for r in results:
        floor, (many, forward, one, every, net_one, net_every) = r["floor"], r["rows"][1:]
        ratios = "".join(f"{row.cpu_us / floor.cpu_us:>7.2f}" for row in (one, every, net_one, net_every))
        parts = f"{many.cpu_us / floor.cpu_us:>8.2f}{forward.cpu_us / floor.cpu_us:>7.2f}"
        verdict = "met" if r["met"] else "not met"
        print(f"{r['env']:<12}{floor.cpu_us:>8.2f}{parts}{ratios}{every.busy:>7.2f}{verdict:>9}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
