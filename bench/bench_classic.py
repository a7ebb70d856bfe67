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
repeats; a first small run of each backend (numba compilation, env construction) is not timed.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch
from gymnasium import spaces

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.classic import KERNELS
from taskcomplexity.tasks.gym_task import GymTask

NETWORKS = {
    "mlp32": NetworkSpec(),  # the arms' default: 32 → ReLU → 32 → ReLU → tanh
    "pic_h2_64": NetworkSpec(hidden=(64, 64), activation="tanh", output="linear"),  # the original family's
}


def median_rate(run, repeats: int, warm=None) -> float:
    """Median of ``repeats`` timed calls of ``run() -> steps``: steps per second (after ``warm()`` or a run)."""
    (warm or run)()
    rates = []
    for _ in range(repeats):
        started = time.perf_counter()
        steps = run()
        rates.append(steps / (time.perf_counter() - started))
    return statistics.median(rates)


def rwg_rate(task, network, backend, policies, episodes, repeats) -> float:
    settings = RWGSettings(policies=policies, episodes=episodes, seed=0)
    small = RWGSettings(policies=2, episodes=2, seed=0)
    return median_rate(lambda: int(run_rwg(task, network, PriorSpec(), settings, backend).steps.sum()), repeats,
                       lambda: run_rwg(task, network, PriorSpec(), small, backend))


def vector_rate(task, network, make, num_envs, steps, repeats) -> float:
    """Steps/s of a vector env of ``num_envs`` driven by num_envs/16 policies × 16 envs for ``steps`` steps."""
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


def policy_rate(task, network, policies, episodes, repeats) -> float:
    """Rows/s of the forward pass alone on the kernel backend's batch: the policy's bound."""
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
            kernel = rwg_rate(task, network, "kernel", args.policies, args.episodes, args.repeats)
            bound = policy_rate(task, network, args.policies, args.episodes, args.repeats)
            gym = rwg_rate(task, network, "gym", args.gym_policies, args.gym_policies, args.repeats)
            vec = vector_rate(task, network, lambda n, e=env_id: gymnasium.make_vec(e, num_envs=n),
                              args.num_envs, args.vector_steps, args.repeats)
            pooled = envpool_maker(env_id)  # envpool has gymnasium's ids only (not taskcomplexity/NoisyCartPole)
            pool = vector_rate(task, network, pooled, args.num_envs, args.vector_steps,
                               args.repeats) if pooled is not None else float("nan")
            print(f"{env_id:<26}{name:<11}{kernel:>11,.0f}{bound:>11,.0f}{gym:>10,.0f}{kernel / gym:>7.1f}"
                  f"{vec:>10,.0f}{kernel / vec:>7.1f}{pool:>10,.0f}{kernel / pool:>7.1f}", flush=True)


if __name__ == "__main__":
    main()
