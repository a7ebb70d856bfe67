"""Where the fused RWG rollout of the seven arm tasks spends an environment step, beside the floors measured here.

    python bench/bench_kernel_split.py                     # N = 100 policies × M = 500 episodes per task
    python bench/bench_kernel_split.py --policies 40 --repeats 1

Per task, ns per environment step (one numba thread, process CPU time) of

- forward: the policy's MLP (:func:`taskcomplexity.tasks.rollout_kernel.forward`);
- physics: the contact-free integration (:func:`taskcomplexity.tasks.dynamics.integrate_block`, 51 physics steps);
- contacts: the obstacle's contact model on top of it (the same integration with the task's contact zone,
  minus the contact-free one on a copy of the same states);
- obs/reward: the rest of :func:`taskcomplexity.tasks.step_kernel.step_block` (torques, clearances,
  observation, reward, episode bookkeeping);
- book: packing the active environments, their observations and actions.

The split comes from a copy of the rollout's loop (:func:`_timed_rollout`) that calls the same
functions with the CPU's cycle counter around each; the cycles are scaled to the copy's process CPU time
(a shared machine's waits spread over the components alike). ``real`` is the production kernel's CPU time
per step on the same chunk, ``sum`` the split's total (the copy's overhead included).

The forward pass runs in ``--precision`` (default float32, as ``make run`` runs it: ``rwg.precision`` of
``experiment=published``; the obstacle task's in float64). Floors, measured on this machine in the same run:
forward, MACs per step over the rate of NumPy's matmul (in the forward pass's precision)
at the forward pass's shapes (one BLAS thread, 256 environments per product); physics and obs/reward,
the same functions on 256 contiguous environments in a tight loop (no packing, no episode ends). The
contact model has no floor here (its work depends on how many physics steps come near the block).
Where a part is above 1.5× its floor the bench says why; for the forward pass it times each layer alone (on a
policy's first observations, so that the output's tanh sees realistic values) beside matmul at that layer's shape.
Per contact-free task a ``floor:`` line (``bench/floors.py``) gives the batched backend's ×floor: ``real`` over the sum
of the three floors, on the CPU path this runs on (``bench/run.py`` runs this script again on the AVX2 path).
"""

from __future__ import annotations

import argparse
import statistics
import time

import floors as bench_floors
import numba
import numpy as np
import torch
from llvmlite import ir
from numba.core import types
from numba.core.extending import intrinsic
from threadpoolctl import threadpool_limits

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies
from taskcomplexity.rwg import initial_states
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks import contact, rollout_kernel
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.dynamics import BLOCK, integrate_block, inverse_mass_matrix, row_length, whole_vectors
from taskcomplexity.tasks.rollout_kernel import PRECISIONS
from taskcomplexity.tasks.spec import make_task
from taskcomplexity.tasks.step_kernel import (
    begin_step,
    block_goals,
    env_state,
    finish_step,
    gather,
)

SEVEN_TASKS = [(t.selection["arm"], t.selection["reward"])
               for t in load_study_file(CONF_DIR / "study" / "seven_tasks.yaml").tasks]
PARTS = ("book", "forward", "physics", "contacts", "obs/reward")
BOOK, FORWARD, FREE, INTEGRATE, OBSERVE, ACTIVE, BLOCK_STEPS, TOUCHED = range(8)  # slots of _timed_rollout's t


@intrinsic
def _cycles(typingctx):
    """The CPU's time-stamp counter (llvm.readcyclecounter), int64 cycles."""

    def codegen(context, builder, signature, args):
        fn = builder.module.declare_intrinsic("llvm.readcyclecounter", fnty=ir.FunctionType(ir.IntType(64), []))
        return builder.call(fn, [])

    return types.int64(), codegen


@numba.njit(parallel=True, cache=True)
def _timed_rollout(arm, p, zone, free_zone, weights, layer_sizes, relu, tanh_output, episodes, max_steps, state, dt,
                   substeps, t):
    """:func:`taskcomplexity.tasks.rollout_kernel._rollout` (no biases) with cycles per part summed into t.

    Run it on one thread: t is shared. With a contact zone the contact-free integration also runs on a
    copy of each step's states (t[FREE]); t[INTEGRATE] is the real one.
    """
    active, steps, obs, action = state.active, state.steps, state.obs, state.action
    n_pol = active.shape[0] // episodes
    n_obs, n_out = obs.shape[1], layer_sizes[-1]
    width = 0
    for size in layer_sizes:
        width = max(width, size)
    inv = inverse_mass_matrix(arm)
    contacts = zone.mode != contact.NO_CONTACT
    blocks = (episodes + BLOCK - 1) // BLOCK
    for job in numba.prange(n_pol * blocks):
        policy = job // blocks
        lo = policy * episodes + (job % blocks) * BLOCK
        hi = min(lo + BLOCK, (policy + 1) * episodes)
        w = weights[policy]
        index = np.empty(hi - lo, dtype=np.int64)
        columns = row_length(hi - lo)
        h, g = np.zeros((width, columns), weights.dtype), np.zeros((width, columns), weights.dtype)
        goals = block_goals(p, state.target, lo, hi)
        for _ in range(max_steps):
            c0 = _cycles()
            n = gather(active, steps, max_steps, lo, hi, index)
            if n == 0:
                break
            for i in range(n_obs):
                row = h[i]
                for j in range(n):
                    row[j] = obs[index[j], i]
            c1 = _cycles()
            out = rollout_kernel.forward(w, layer_sizes, False, relu, tanh_output, h, g,
                                         whole_vectors(n))
            c2 = _cycles()
            for k in range(n_out):
                row = out[k]
                for j in range(n):
                    action[index[j], k] = row[j]
            c3 = _cycles()
            columns = whole_vectors(n) if zone.mode == contact.NO_CONTACT else n  # as step_block does
            a1, a2, u, v, t1, t2, upper, touched = begin_step(p, index, n, state, columns)
            c4 = _cycles()
            if contacts:
                f1, f2, fu, fv, ft = a1.copy(), a2.copy(), u.copy(), v.copy(), touched.copy()
                c5 = _cycles()
                integrate_block(arm, inv, f1, f2, fu, fv, t1, t2, dt, substeps, free_zone, ft)
                t[FREE] += _cycles() - c5
            c5 = _cycles()
            integrate_block(arm, inv, a1, a2, u, v, t1, t2, dt, substeps, zone, touched)
            c6 = _cycles()
            finish_step(p, zone, index, n, state, goals, lo, a1, a2, u, v, upper, touched)
            c7 = _cycles()
            t[BOOK] += (c1 - c0) + (c3 - c2)
            t[FORWARD] += c2 - c1
            t[INTEGRATE] += c6 - c5
            t[OBSERVE] += (c4 - c3) + (c7 - c6)
            t[ACTIVE] += n
            t[BLOCK_STEPS] += 1
            for j in range(n):
                t[TOUCHED] += touched[j]


@numba.njit(parallel=True, cache=True)
def _isolated(arm, p, zone, state, dt, substeps, n, repeats, which):
    """Cycles of ``repeats`` calls of one part on environments 0 … n−1 (which: 0 physics, 1 obs/reward)."""
    index = np.arange(n)
    inv = inverse_mass_matrix(arm)
    goals = block_goals(p, state.target, 0, n)
    total = 0
    for _ in numba.prange(1):  # a parallel kernel, as the rollout: its loops compile alike
        for _repeat in range(repeats):
            c0 = _cycles()
            a1, a2, u, v, t1, t2, upper, touched = begin_step(p, index, n, state)
            c1 = _cycles()
            if which == 0:
                integrate_block(arm, inv, a1, a2, u, v, t1, t2, dt, substeps, zone, touched)
                total += _cycles() - c1
            else:
                finish_step(p, zone, index, n, state, goals, 0, a1, a2, u, v, upper, touched)
                total += _cycles() - c0
    return total


@numba.njit(cache=True)
def _time_layer(w, off, fan_in, fan_out, src, dst, n, reps, activation):
    """Cycles of ``reps`` passes of one layer of the kernel's forward pass (activation 0 none, 1 ReLU, 2 tanh)."""
    start = _cycles()
    for _ in range(reps):
        rollout_kernel._dense(w, off, fan_in, fan_out, src, dst, n)
        if activation == 1:
            for j in range(fan_out):
                row = dst[j]
                for e in range(n):
                    row[e] = max(row[e], 0.0)
        elif activation == 2:
            for j in range(fan_out):
                row = dst[j]
                for e in range(n):
                    row[e] = np.tanh(row[e])
    return _cycles() - start


def forward_by_layer(weights, layer_sizes, observations, rate: float, repeats: int = 5) -> list[dict]:
    """Each layer of one policy's forward pass alone, on the observations given (one column each, ≤ 256).

    Per layer: ns per environment of the kernel's products, of its activation (the output's tanh: the C
    library's, per value), MACs, and NumPy's matmul rate at the same shape. The inputs are the policy's own
    activations, so the output's tanh sees the values it sees in a rollout (its cost depends on them).
    """
    n = observations.shape[0]
    columns = row_length(n)
    buffers = [np.zeros((int(size), columns), weights.dtype) for size in layer_sizes]
    buffers[0][:, :n] = observations.T
    layers, off, out = len(layer_sizes) - 1, 0, []
    for k in range(layers):
        fan_in, fan_out = int(layer_sizes[k]), int(layer_sizes[k + 1])
        activation = 1 if k < layers - 1 else 2
        src, dst = buffers[k], buffers[k + 1]
        _time_layer(weights, off, fan_in, fan_out, src, dst, n, 1, activation)  # compile; dst = this layer's output
        reps = max(1, int(2e6 // (fan_in * fan_out * n)))
        products = min(_time_layer(weights, off, fan_in, fan_out, src, dst.copy(), n, reps, 0) for _ in range(repeats))
        whole = min(_time_layer(weights, off, fan_in, fan_out, src, dst.copy(), n, reps, activation)
                    for _ in range(repeats))
        ns = products / rate / (reps * n) * 1e9
        out.append(dict(shape=f"{fan_in}→{fan_out}", macs=fan_in * fan_out, products=ns,
                        activation=max(whole / rate / (reps * n) * 1e9 - ns, 0.0),
                        gemm=gemm_rate([fan_in, fan_out], dtype=weights.dtype),
                        tanh=activation == 2))
        off += fan_in * fan_out
    return out


def cycles_per_second() -> float:
    """The cycle counter's rate, against the wall clock over 0.2 s."""
    c0, t0 = _cycles_now(), time.perf_counter()
    time.sleep(0.2)
    return (_cycles_now() - c0) / (time.perf_counter() - t0)


@numba.njit(cache=True)
def _cycles_now():
    return _cycles()


def gemm_rate(layer_sizes, columns: int = 256, repeats: int = 5, dtype=np.float64) -> float:
    """MAC/s of NumPy's matmul over the forward pass's layers in ``dtype`` (one BLAS thread), best of ``repeats``."""
    rng = np.random.default_rng(0)
    weights = [rng.normal(size=(b, a)).astype(dtype) for a, b in zip(layer_sizes[:-1], layer_sizes[1:], strict=True)]
    x = rng.normal(size=(layer_sizes[0], columns)).astype(dtype)
    macs = sum(w.size for w in weights) * columns
    loops = max(1, int(2e8 // macs))
    best = np.inf
    with threadpool_limits(1):
        for _ in range(repeats):
            started = time.process_time()
            for _ in range(loops):
                y = x
                for w in weights:
                    y = w @ y
            best = min(best, time.process_time() - started)
    return macs * loops / best


def forward_rate(weights, layer_sizes, columns: int = 256, repeats: int = 5) -> float:
    """MAC/s of the kernel's forward pass alone on ``columns`` environments, best of ``repeats``."""
    width = int(layer_sizes.max())
    h = np.random.default_rng(1).normal(size=(width, columns)).astype(weights.dtype)
    g = np.empty_like(h)
    macs = int((layer_sizes[:-1] * layer_sizes[1:]).sum()) * columns
    loops = max(1, int(1e8 // macs))
    best = np.inf
    for _ in range(repeats):
        started = time.process_time()
        for _ in range(loops):
            rollout_kernel.forward(weights, layer_sizes, False, True, True, h, g, columns)
        best = min(best, time.process_time() - started)
    return macs * loops / best


def chunk(task, policies: int, episodes: int):
    """A fresh environment batch at its initial states and the paper's policies for it."""
    batch = sample_policies(NetworkSpec(), PriorSpec(), task.observation_size, task.action_size, 0,
                            np.arange(policies))
    joint_angles, target = initial_states(task, 0, batch.indices, episodes)
    env = BatchedReaching(task, policies * episodes, "model")
    env.reset(torch.from_numpy(joint_angles.reshape(policies * episodes, -1)),
              torch.from_numpy(target.reshape(-1, 2)))
    return env, batch


def measure(task, policies: int, episodes: int, precision: str):
    """(real ns/step, split ns/step per part, mean active environments per block step, touched share)."""
    env, batch = chunk(task, policies, episodes)
    weights, layer_sizes = batch.packed()
    started = time.process_time()
    env.rollout(weights, layer_sizes, precision=precision)
    real = (time.process_time() - started) / int(env.steps.sum()) * 1e9

    env, _ = chunk(task, policies, episodes)
    k = env._kernel
    t = np.zeros(8, dtype=np.int64)
    state = env_state(env._state, np.zeros((policies * episodes, task.action_size)))
    started = time.process_time()
    _timed_rollout(k.arm, k.task, k.zone, contact.no_contact(), weights.astype(PRECISIONS[precision]), layer_sizes,
                   True, True, episodes,
                   task.max_steps, state, k.time_step, k.substeps, t)
    cpu = time.process_time() - started
    steps = int(env.steps.sum())
    timed = t[[BOOK, FORWARD, FREE, INTEGRATE, OBSERVE]].astype(float)
    scale = cpu / timed.sum() / steps * 1e9  # ns of CPU time per cycle and step
    contacts = k.zone.mode != contact.NO_CONTACT
    physics = timed[2] if contacts else timed[3]
    parts = np.array([timed[0], timed[1], physics, timed[3] - physics, timed[4]]) * scale
    split_total = (timed.sum() - (timed[2] if contacts else 0.0)) * scale
    return real, parts, split_total, t[ACTIVE] / t[BLOCK_STEPS], t[TOUCHED] / steps


def isolated(task, rate: float, n: int = 256, repeats: int = 200):
    """ns per environment step of the physics (no contacts) and of obs/reward on n contiguous environments."""
    env, _ = chunk(task, 1, n)
    k = env._kernel
    state = env_state(env._state, np.random.default_rng(2).uniform(-1.0, 1.0, (n, task.action_size)))
    out = []
    for which in (0, 1):
        _isolated(k.arm, k.task, contact.no_contact(), state, k.time_step, k.substeps, n, 1, which)  # compile
        best = min(_isolated(k.arm, k.task, contact.no_contact(), state, k.time_step, k.substeps, n, repeats, which)
                   for _ in range(3))
        out.append(best / rate / (n * repeats) * 1e9)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--policies", type=int, default=100)
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--precision", choices=sorted(PRECISIONS), default="float32",
                        help="the forward pass's (default: as make run runs it; the obstacle task stays float64)")
    args = parser.parse_args()
    numba.set_num_threads(1)
    rate = cycles_per_second()

    print(f"Fused RWG rollout, ns per environment step by part: N = {args.policies} × M = {args.episodes} per task, "
          f"mlp32, forward pass in {args.precision} (the obstacle task's in float64, as in make run), one numba "
          f"thread, median of {args.repeats} (CPU time; split by the cycle counter)")
    print(f"{'task':<26}{'real':>7}{'sum':>7}" + "".join(f"{p:>12}" for p in PARTS) + f"{'envs/block':>12}")
    floors = {}
    for arm, reward in SEVEN_TASKS:
        task = make_task(arm, reward)
        precision = "float64" if task.arm.obstacle is not None else args.precision  # as RWGRequest decides
        env, batch = chunk(task, 1, 4)
        weights, layer_sizes = batch.packed()
        weights = weights.astype(PRECISIONS[precision])
        if arm not in floors:
            gemm = gemm_rate(layer_sizes, dtype=weights.dtype)
            own = forward_rate(weights[0], layer_sizes)
            macs = int((layer_sizes[:-1] * layer_sizes[1:]).sum())
            floors[arm] = dict(gemm=gemm, own=own, macs=macs, forward=macs / gemm * 1e9, dtype=precision)
            floors[arm]["physics"], floors[arm]["obs/reward"] = isolated(task, rate)
            first, _ = chunk(task, 1, 256)
            floors[arm]["layers"] = forward_by_layer(weights[0], layer_sizes, first._state["observation"], rate)
        measure(task, 2, 8, precision)  # compile
        runs = [measure(task, args.policies, args.episodes, precision) for _ in range(args.repeats)]
        real = statistics.median(r[0] for r in runs)
        parts = np.median([r[1] for r in runs], axis=0)
        total = statistics.median(r[2] for r in runs)
        active, touched = runs[0][3], runs[0][4]
        floor = floors[arm]
        print(f"{arm + '-' + reward:<26}{real:>7.0f}{total:>7.0f}"
              + "".join(f"{v:>12.0f}" for v in parts) + f"{active:>12.0f}")
        ratios = []
        for name, value in zip(PARTS, parts, strict=True):
            if name in floor:
                ratios.append(f"{name} {value:.0f}/{floor[name]:.0f} = {value / floor[name]:.2f}×")
        print(f"{'':<26}measured/floor: " + ", ".join(ratios))
        if task.arm.obstacle is None:  # the contact model has no floor
            bench_floors.report("batched", "reaching-arms", f"{arm}-{reward}",
                                real / (floor["forward"] + floor["physics"] + floor["obs/reward"]))
        if parts[1] > 1.5 * floor["forward"]:
            share = [layer["macs"] / layer["products"] * 1e9 / layer["gemm"] for layer in floor["layers"]]
            layers = ", ".join(
                f"{layer['shape']} {layer['products']:.0f} ns ({fraction:.2f})"
                + (f" + tanh {layer['activation']:.0f} ns" if layer["tanh"] else "")
                for layer, fraction in zip(floor["layers"], share, strict=True))
            print(f"{'':<26}forward: each column's sums stay in input order (float64 returns bit for bit as before). "
                  "By layer, alone on 256 environments of a policy's first observations, ns per environment (and the "
                  f"share of matmul's rate at the layer's shape): {layers}; the tanh is the C library's, scalar, one "
                  "call per action (a vectorised tanh would not give its bits). Passes of 8 inputs instead of 4 and "
                  "fused multiply-adds were tried side by side (no faster). In the rollout a block holds "
                  f"{active:.0f} active environments on average, and each step adds its copies of the observations "
                  "in and the actions out")
        if parts[2] > 1.5 * floor["physics"]:
            print(f"{'':<26}physics: in the rollout a block holds {active:.0f} active environments on average "
                  "(the floor: 256)")
        if parts[4] > 1.5 * floor["obs/reward"]:
            print(f"{'':<26}obs/reward: the same code; the floor loop repeats 256 environments in order (rows and "
                  f"branch outcomes warm), the rollout reads and writes the packed rows of {active:.0f} active "
                  "environments per block")
        if parts[3] > 0:
            print(f"{'':<26}contacts: no floor; exact gate, detection and solve per physics step, "
                  f"{touched:.1%} of the environment steps touched the block")
    print("\nfloors: " + "; ".join(
        f"{arm}: {f['dtype']} matmul {f['gemm'] / 1e9:.1f} GMAC/s × {f['macs']} MACs/step → forward "
        f"{f['forward']:.0f} ns, physics {f['physics']:.0f} ns, obs/reward {f['obs/reward']:.0f} ns"
        for arm, f in floors.items()))


if __name__ == "__main__":
    main()
