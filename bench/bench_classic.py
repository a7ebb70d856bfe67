"""Classic-control throughput: the kernel backend against gymnasium (and envpool, when installed).

    python bench/bench_classic.py                       # every id, both networks, medians of 3
    python bench/bench_classic.py --ids CartPole-v1 --networks pic_h2_64 --repeats 5

Per task and policy network, environment steps per second of

- ``kernel``: RWG's kernel backend (numba step + batched policy forward), N × M policies × episodes;
- ``gym``: RWG's generic backend on the same policies and reset seeds (one ``gymnasium.make`` env per slot);
- ``make_vec``: ``gymnasium.make_vec(id, num_envs)`` (CartPole's NumPy vector env, a ``SyncVectorEnv``
  for the others) stepped for a fixed number of steps by the same policies, batched the same way;
- ``envpool``: ``envpool.make(id, env_type="gymnasium", num_envs)`` likewise (optional: ``pip install
  envpool``), and the policy bound: the forward pass alone on the kernel's batch (rows/s).

``make_vec`` and envpool auto-reset from their own generators (seeded by the run seed), so they run the
same policies on the same kind of work, not the same episodes. Every figure is the median of the
repeats; a first small run of each backend (numba compilation, env construction) is not timed. Per task and network a
``floor:`` line (``bench/floors.py``) gives the kernel backend's CPU per step over the forward pass's per row: its
×floor on the CPU path this runs on (``bench/run.py`` runs this script again on the AVX2 path with
``--paths-repeats 0``).

Then both CPU paths side by side (``--paths-repeats 0`` skips it): the classic-control study, ``pipelines/study.py
study=classic_control`` at N = M = ``--paths-policies`` (RWG, metrics, diagnostics, verdict and report, in fresh
outputs each run), run natively and on the AVX2 path of numba, NumPy, torch and the BLAS (``tests/cpu_paths.py``),
native and AVX2 in turn; per path its CPU seconds (median, min, max), the ratio AVX2 / native of each pair, and
whether the report's printed tables are the same on both. Each path's numba kernels are compiled by a first run that
is not timed. Before it, the forward pass's tanh on each path: NumPy's and the kernel's
(:mod:`taskcomplexity.policies.tanh`), ns per value.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import floors
import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.classic import KERNELS
from taskcomplexity.tasks.gym_task import GymTask

ROOT = Path(__file__).resolve().parent.parent
GOAL = 1.25
"""The AVX2 path's CPU seconds at most this many times the native path's, on the same machine."""
VECTOR_FLAGS = ("avx512f", "avx512bw", "avx512vl", "avx2", "fma", "avx", "sse4_2", "asimd", "sve")
"""The /proc/cpuinfo flags that decide the code paths numba, NumPy, torch and the BLAS take."""

NETWORKS = {
    "mlp32": NetworkSpec(),  # the arms' default: 32 → ReLU → 32 → ReLU → tanh
    "pic_h2_64": NetworkSpec(hidden=(64, 64), activation="tanh", output="linear"),  # the original family's
}


def median_rate(run, repeats: int, warm=None) -> tuple[float, float]:
    """Medians of ``repeats`` timed calls of ``run() -> steps`` (after ``warm()`` or a run): steps per second (wall),
    and CPU-µs per step (this process's threads)."""
    (warm or run)()
    rates, cpu = [], []
    for _ in range(repeats):
        started, started_cpu = time.perf_counter(), time.process_time()
        steps = run()
        rates.append(steps / (time.perf_counter() - started))
        cpu.append((time.process_time() - started_cpu) / steps * 1e6)
    return statistics.median(rates), statistics.median(cpu)


def rwg_rate(task, network, backend, policies, episodes, repeats) -> tuple[float, float]:
    settings = RWGSettings(policies=policies, episodes=episodes, seed=0)
    small = RWGSettings(policies=2, episodes=2, seed=0)
    return median_rate(lambda: int(run_rwg(task, network, PriorSpec(), settings, backend).steps.sum()), repeats,
                       lambda: run_rwg(task, network, PriorSpec(), small, backend))


def vector_rate(task, network, make, num_envs, steps, repeats) -> tuple[float, float]:
    """Steps/s (and CPU-µs/step) of a vector env of ``num_envs`` driven by num_envs/16 policies × 16 envs for
    ``steps`` steps."""
    env = make(num_envs)
    width = 16
    policies = sample_policies(network, PriorSpec(), task.observation_size, task.action_size, 0,
                               np.arange(num_envs // width))
    box = isinstance(task.action_space, spaces.Box)

    def run() -> int:
        obs, _ = env.reset(seed=0)
        for _ in range(steps):
            x = torch.from_numpy(np.asarray(obs, dtype=np.float64).reshape(len(policies), width, -1))
            outputs = policies.unit_outputs(policies.act(x).numpy(), box).reshape(num_envs, -1)
            obs, *_ = env.step(decode_actions(task.action_space, outputs))
        return num_envs * steps

    try:
        return median_rate(run, repeats)
    finally:
        env.close()


def policy_rate(task, network, policies, episodes, repeats) -> tuple[float, float]:
    """Rows/s (and CPU-µs per row) of the forward pass alone on the kernel backend's batch: the policy's bound, and
    the kernel backend's floor in :data:`floors.FLOORS`."""
    batch = sample_policies(network, PriorSpec(), task.observation_size, task.action_size, 0, np.arange(policies))
    x = torch.from_numpy(np.random.default_rng(0).normal(0.0, 0.1, (policies, episodes, task.observation_size)))

    def run() -> int:
        for _ in range(10):
            batch.act(x)
        return 10 * policies * episodes

    return median_rate(run, repeats)


def envpool_maker(env_id):
    """envpool's vector env of ``env_id`` (None: envpool is not installed or has no such env)."""
    try:
        import envpool
    except ImportError:
        return None
    if env_id not in envpool.list_all_envs():
        return None
    return lambda n: envpool.make(env_id, env_type="gymnasium", num_envs=n, seed=0)


def cpu_line() -> str:
    """The CPU model and its vector extensions."""
    info = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    model = re.search(r"^(?:model name|Model)\s*:\s*(.+)$", info, flags=re.MULTILINE)
    flags = re.search(r"^(?:flags|Features)\s*:\s*(.+)$", info, flags=re.MULTILINE)
    present = set(flags.group(1).split()) if flags else set()
    return f"CPU {model.group(1).strip() if model else 'unknown'} ({' '.join(f for f in VECTOR_FLAGS if f in present)})"


def path_environments(numba_cache: str) -> dict[str, dict[str, str]]:
    """The environment of each CPU path: this process's, and tests/cpu_paths.py's AVX2 path (numba's kernels for it
    cached in ``numba_cache``)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from cpu_paths import avx2_environment

    return {"native": dict(os.environ), "AVX2": {**os.environ, **avx2_environment(numba_cache)}}


def child_cpu(command: list[str], env: dict[str, str]) -> tuple[float, subprocess.CompletedProcess]:
    """Run ``command``; its CPU seconds (its process and those it waited for) and its completed process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done


def report_tables(outputs: Path) -> dict[str, str]:
    """The report's Markdown tables (name → text): the digits it prints (its CSV files hold every float's last bits,
    which NumPy's exp and log round differently on the two paths)."""
    return {p.name: p.read_text() for p in sorted(outputs.glob("reports/*/*/tables/*.md"))}


def study_run(policies: int, env: dict[str, str]) -> tuple[float, dict[str, str]]:
    """The classic-control study at N = M = ``policies`` in fresh outputs: its CPU seconds and its report's tables."""
    with tempfile.TemporaryDirectory(prefix="bench-classic-paths-") as outputs:
        command = [sys.executable, str(ROOT / "pipelines" / "study.py"), "study=classic_control",
                   f"study.policies={policies}", f"study.episodes={policies}"]
        cpu, _ = child_cpu(command, {**env, "TASKCOMPLEXITY_OUTPUTS": outputs})
        return cpu, report_tables(Path(outputs))


TANH_TIMING = """
import time, numpy as np
from taskcomplexity.policies.tanh import implementation
from taskcomplexity.policies.tanh_kernel import tanh_kernel
x = np.random.default_rng(0).normal(0.0, 5.0, (2, 1000, 64)); out = np.empty_like(x)
def ns(f):
    f(); best = float("inf")
    for _ in range(7):
        start = time.process_time()
        for _ in range(20): f()
        best = min(best, (time.process_time() - start) / 20 / x.size * 1e9)
    return best
print(f"{ns(lambda: np.tanh(x, out=out)):.2f} {ns(lambda: tanh_kernel(x, out)):.2f} {implementation()}")
"""
"""Prints NumPy's and the kernel's ns per float64 tanh value (the best of 7 × 20 calls on classic control's hidden
layer shape, one thread) and the one the forward pass takes."""


def compare_paths(policies: int, repeats: int) -> None:
    """The classic-control study on both CPU paths, side by side (module docstring)."""
    with tempfile.TemporaryDirectory(prefix="bench-classic-numba-avx2-") as numba_cache:
        envs = path_environments(numba_cache)
        print(f"\nboth CPU paths, {cpu_line()}, {os.cpu_count()} cores")
        for name, env in envs.items():
            described = subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, 'tests'); "
                                        "from cpu_paths import describe; print(describe())"],
                                       cwd=ROOT, env=env, capture_output=True, text=True).stdout.strip()
            numpy_ns, kernel_ns, chosen = child_cpu([sys.executable, "-c", TANH_TIMING], env)[1].stdout.split()
            print(f"  {name:<7} {described}")
            print(f"  {'':<7} float64 tanh, ns per value: NumPy {numpy_ns}, kernel {kernel_ns}; "
                  f"the forward pass takes {chosen}'s")
        print(f"the classic-control study at N = M = {policies} ({policies**2:,} episodes per task; "
              f"fresh outputs each run), CPU seconds over {repeats} runs per path after one untimed run each")
        for env in envs.values():  # compiles (or loads) each path's numba kernels
            study_run(policies, env)
        cpu: dict[str, list[float]] = {name: [] for name in envs}
        tables: dict[str, dict[str, str]] = {}
        for _ in range(repeats):
            for name, env in envs.items():
                seconds, tables[name] = study_run(policies, env)
                cpu[name].append(seconds)
        print(f"{'path':<9}{'CPU-s':>9}{'min':>9}{'max':>9}")
        for name, seconds in cpu.items():
            print(f"{name:<9}{statistics.median(seconds):>9.1f}{min(seconds):>9.1f}{max(seconds):>9.1f}")
        ratios = [a / n for a, n in zip(cpu["AVX2"], cpu["native"], strict=True)]
        print(f"AVX2 / native: {statistics.median(ratios):.2f} (each pair: {', '.join(f'{r:.2f}' for r in ratios)}; "
              f"goal <= {GOAL})")
        differ = sorted(n for n in tables["native"] if tables["native"][n] != tables["AVX2"].get(n))
        same = "the same on both paths" if not differ else "differ: " + ", ".join(differ)
        print(f"the report's printed tables: {same} ({len(tables['native'])} files)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ids", nargs="+", default=sorted(KERNELS))
    parser.add_argument("--networks", nargs="+", default=list(NETWORKS), choices=list(NETWORKS))
    parser.add_argument("--policies", type=int, default=128, help="N of the kernel run")
    parser.add_argument("--episodes", type=int, default=64, help="M of the kernel run")
    parser.add_argument("--gym-policies", type=int, default=4, help="N = M of the gym backend's run")
    parser.add_argument("--num-envs", type=int, default=256, help="make_vec / envpool width")
    parser.add_argument("--vector-steps", type=int, default=100, help="make_vec / envpool steps per run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--paths-policies", type=int, default=300, help="N = M of the study on both CPU paths")
    parser.add_argument("--paths-repeats", type=int, default=3, help="timed study runs per CPU path (0: skip)")
    args = parser.parse_args()

    import gymnasium

    has_envpool = envpool_maker("CartPole-v1") is not None
    if not has_envpool:
        print("envpool not installed (pip install envpool): its column is skipped")
    head = (f"{'task':<26}{'network':<11}{'kernel':>11}{'policy':>11}{'gym':>10}{'×gym':>7}{'make_vec':>10}"
            f"{'×vec':>7}{'envpool':>10}{'×pool':>7}")
    print("env steps/s (policy: forward-pass rows/s, the bound); × = kernel / other")
    print(head)
    print("-" * len(head))
    for env_id in args.ids:
        task = GymTask(env_id)
        for name in args.networks:
            network = NETWORKS[name]
            kernel, kernel_cpu = rwg_rate(task, network, "kernel", args.policies, args.episodes, args.repeats)
            bound, bound_cpu = policy_rate(task, network, args.policies, args.episodes, args.repeats)
            gym, _ = rwg_rate(task, network, "gym", args.gym_policies, args.gym_policies, args.repeats)
            vec, _ = vector_rate(task, network, lambda n, e=env_id: gymnasium.make_vec(e, num_envs=n),
                                 args.num_envs, args.vector_steps, args.repeats)
            pooled = envpool_maker(env_id)  # envpool has gymnasium's ids only (not taskcomplexity/NoisyCartPole)
            pool = vector_rate(task, network, pooled, args.num_envs, args.vector_steps,
                               args.repeats)[0] if pooled is not None else float("nan")
            print(f"{env_id:<26}{name:<11}{kernel:>11,.0f}{bound:>11,.0f}{gym:>10,.0f}{kernel / gym:>7.1f}"
                  f"{vec:>10,.0f}{kernel / vec:>7.1f}{pool:>10,.0f}{kernel / pool:>7.1f}", flush=True)
            floors.report("kernel", "classic-control", f"{env_id}/{name}", kernel_cpu / bound_cpu)
    if args.paths_repeats:
        compare_paths(args.paths_policies, args.paths_repeats)


if __name__ == "__main__":
    main()
