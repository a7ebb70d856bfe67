"""RWG's episodes as one fused numba kernel: each policy's forward pass, then the step kernel's step.

Per block of one policy's episodes, each environment step packs the environments still running,
runs the policy's MLP on their observations (:func:`forward`) and advances them with
:func:`taskcomplexity.tasks.step_kernel.step_block`, the same definition of the mechanics that
:func:`~taskcomplexity.tasks.step_kernel.step` runs; environments whose episode ended cost nothing
more. An episode stops at termination, after ``max_steps`` steps, or at a hand-over to the PyBullet
reference (its state is then the one before the step, exactly as ``step`` leaves it).

The policy's arithmetic is each environment's own (a fixed summation order per output), so an
episode's return depends only on its policy and its initial state, not on the chunking, the block or
the number of threads. The forward pass runs on the n active environments rounded up to a whole number
of vectors (:data:`~taskcomplexity.tasks.dynamics.VECTOR`): the compiler's vector loop then covers every
column, where the scalar loop it leaves for a remainder cost up to 40 % more time per pass
(``bench/bench_kernel_split.py``); the extra columns hold earlier steps' finite numbers and are computed and
ignored. The physics of a task without a block does the same (:func:`~taskcomplexity.tasks.step_kernel.step_block`).

It is the same function as :meth:`taskcomplexity.policies.mlp.PolicyBatch.act`
up to the summation order of the matrix products (float64 rounding; ``tests/tasks/test_rollout_kernel.py``).

Parameters of P policies are one float64 row each (:meth:`~taskcomplexity.policies.mlp.PolicyBatch.packed`):
per layer the weight as (fan_out, fan_in) row-major, then its bias (fan_out) when the network has
biases; ``layer_sizes`` holds the first layer's fan_in (observation size, plus 1 with an input bias),
then every layer's fan_out.
"""

from __future__ import annotations

import numba
import numpy as np

from taskcomplexity.tasks.dynamics import BLOCK, inverse_mass_matrix, row_length, whole_vectors
from taskcomplexity.tasks.step_kernel import KernelTask, block_goals, env_state, gather, step_block

PRECISIONS = {"float64": np.float64, "float32": np.float32}
"""The forward pass's arithmetic, by name (:func:`rollout`)."""


@numba.njit(cache=True)
def _rows4(w, b0, fan_in, src, r0, r1, r2, r3, n):
    """Four output rows (weights at b0, b0 + fan_in, …): four inputs per pass over the n environments."""
    b1, b2, b3 = b0 + fan_in, b0 + 2 * fan_in, b0 + 3 * fan_in
    for e in range(n):
        r0[e] = 0.0
        r1[e] = 0.0
        r2[e] = 0.0
        r3[e] = 0.0
    i = 0
    while i + 4 <= fan_in:
        s0, s1, s2, s3 = src[i], src[i + 1], src[i + 2], src[i + 3]
        w00, w01, w02, w03 = w[b0 + i], w[b0 + i + 1], w[b0 + i + 2], w[b0 + i + 3]
        w10, w11, w12, w13 = w[b1 + i], w[b1 + i + 1], w[b1 + i + 2], w[b1 + i + 3]
        w20, w21, w22, w23 = w[b2 + i], w[b2 + i + 1], w[b2 + i + 2], w[b2 + i + 3]
        w30, w31, w32, w33 = w[b3 + i], w[b3 + i + 1], w[b3 + i + 2], w[b3 + i + 3]
        for e in range(n):
            x0, x1, x2, x3 = s0[e], s1[e], s2[e], s3[e]
            r0[e] = (((r0[e] + w00 * x0) + w01 * x1) + w02 * x2) + w03 * x3
            r1[e] = (((r1[e] + w10 * x0) + w11 * x1) + w12 * x2) + w13 * x3
            r2[e] = (((r2[e] + w20 * x0) + w21 * x1) + w22 * x2) + w23 * x3
            r3[e] = (((r3[e] + w30 * x0) + w31 * x1) + w32 * x2) + w33 * x3
        i += 4
    while i < fan_in:
        si = src[i]
        w0, w1, w2, w3 = w[b0 + i], w[b1 + i], w[b2 + i], w[b3 + i]
        for e in range(n):
            x = si[e]
            r0[e] += w0 * x
            r1[e] += w1 * x
            r2[e] += w2 * x
            r3[e] += w3 * x
        i += 1


@numba.njit(cache=True)
def _row(w, b0, fan_in, src, r0, n):
    """One output row, four inputs per pass."""
    for e in range(n):
        r0[e] = 0.0
    i = 0
    while i + 4 <= fan_in:
        s0, s1, s2, s3 = src[i], src[i + 1], src[i + 2], src[i + 3]
        w0, w1, w2, w3 = w[b0 + i], w[b0 + i + 1], w[b0 + i + 2], w[b0 + i + 3]
        for e in range(n):
            r0[e] = (((r0[e] + w0 * s0[e]) + w1 * s1[e]) + w2 * s2[e]) + w3 * s3[e]
        i += 4
    while i < fan_in:
        si, w0 = src[i], w[b0 + i]
        for e in range(n):
            r0[e] += w0 * si[e]
        i += 1


@numba.njit(cache=True)
def _dense(w, off, fan_in, fan_out, src, dst, n):
    """dst[j, :n] = Σᵢ w[off + j·fan_in + i] · src[i, :n], summed from 0 in order i = 0, 1, … in every column.

    Blocks of four outputs × four inputs per pass over the n environments (fewer loads and stores
    per multiply–add); the parentheses keep each column's sum in input order, so every variant
    computes the plain loop's result, and a column's result does not depend on the others.
    """
    j = 0
    while j + 4 <= fan_out:
        _rows4(w, off + j * fan_in, fan_in, src, dst[j], dst[j + 1], dst[j + 2], dst[j + 3], n)
        j += 4
    while j < fan_out:
        _row(w, off + j * fan_in, fan_in, src, dst[j], n)
        j += 1


@numba.njit(cache=True)
def forward(w, layer_sizes, bias, relu, tanh_output, h, g, n):
    """One policy's MLP on n environments at once.

    Parameters
    ----------
    w : ndarray (S,)
        The policy's packed parameters (module docstring).
    layer_sizes : ndarray (L + 1,) int64
    bias, relu, tanh_output : bool
        Layers have biases; hidden activation ReLU (else tanh); output tanh (else linear).
    h, g : ndarray (width, ≥ n)
        Work buffers, width = max(layer_sizes); on entry ``h[:layer_sizes[0], :n]`` holds the inputs,
        one column per environment.
    n : int

    Returns
    -------
    ndarray: ``h`` or ``g``, whose rows ``[:layer_sizes[-1]]`` hold the outputs (columns ``:n``).
    """
    layers = layer_sizes.shape[0] - 1
    off = 0
    cur, nxt = h, g
    for k in range(layers):
        fan_in, fan_out = layer_sizes[k], layer_sizes[k + 1]
        _dense(w, off, fan_in, fan_out, cur, nxt, n)
        off += fan_in * fan_out
        if bias:  # added after the sum, as x @ W + b
            for j in range(fan_out):
                b, row = w[off + j], nxt[j]
                for e in range(n):
                    row[e] += b
            off += fan_out
        if k < layers - 1 and relu:
            for j in range(fan_out):
                row = nxt[j]
                for e in range(n):
                    row[e] = max(row[e], 0.0)
        elif k < layers - 1 or tanh_output:
            for j in range(fan_out):
                row = nxt[j]
                for e in range(n):
                    row[e] = np.tanh(row[e])
        cur, nxt = nxt, cur
    return cur


@numba.njit(parallel=True, cache=True)
def _rollout(arm, p, zone, weights, layer_sizes, bias, relu, tanh_output, input_bias, episodes, max_steps, state,
             dt, substeps):
    active, steps, obs, action = state.active, state.steps, state.obs, state.action
    n_pol = active.shape[0] // episodes
    n_obs = obs.shape[1]
    n_out = layer_sizes[-1]
    width = 0
    for size in layer_sizes:
        width = max(width, size)
    inv = inverse_mass_matrix(arm)
    blocks = (episodes + BLOCK - 1) // BLOCK
    for job in numba.prange(n_pol * blocks):
        policy = job // blocks
        lo = policy * episodes + (job % blocks) * BLOCK
        hi = min(lo + BLOCK, (policy + 1) * episodes)
        w = weights[policy]
        index = np.empty(hi - lo, dtype=np.int64)
        # room for whole vectors: the forward pass runs on n rounded up to VECTOR columns (module docstring);
        # zeros, so that the columns past n only ever hold finite numbers
        h = np.zeros((width, row_length(hi - lo)), weights.dtype)  # the forward pass in the weights' precision
        g = np.zeros((width, row_length(hi - lo)), weights.dtype)
        goals = block_goals(p, state.target, lo, hi)  # the target's terms, once per episode
        if input_bias:
            h[n_obs] = 1.0
        for _ in range(max_steps):
            n = gather(active, steps, max_steps, lo, hi, index)
            if n == 0:
                break
            for i in range(n_obs):
                row = h[i]
                for j in range(n):
                    row[j] = obs[index[j], i]
            out = forward(w, layer_sizes, bias, relu, tanh_output, h, g, whole_vectors(n))
            for k in range(n_out):
                row = out[k]
                for j in range(n):
                    action[index[j], k] = row[j]
            if input_bias:  # the forward pass may have used h's constant row as a work row
                h[n_obs] = 1.0
            step_block(arm, inv, p, zone, index, n, state, dt, substeps, goals, lo)


def rollout(
    kernel: KernelTask,
    state: dict[str, np.ndarray],
    weights: np.ndarray,
    layer_sizes: np.ndarray,
    *,
    episodes: int,
    max_steps: int,
    activation: str = "relu",
    output: str = "tanh",
    bias: bool = False,
    input_bias: bool = False,
    precision: str = "float64",
) -> None:
    """Run every active environment until its episode ends, in place.

    Parameters
    ----------
    kernel, state
        As in :func:`taskcomplexity.tasks.step_kernel.step`; ``reward`` and ``done`` end up holding
        each environment's last step.
    weights : ndarray (P, S) float64
        Packed parameters of P policies (module docstring); environment i follows policy
        i // ``episodes``, so B = P · episodes.
    layer_sizes : ndarray (L + 1,) int64
    episodes : int
        Environments per policy.
    max_steps : int
        Episode length limit (truncation); an environment that has taken ``max_steps`` steps stops.
    activation : {'relu', 'tanh'}
    output : {'tanh', 'linear'}
        The outputs are the actions (clipped to [−1, 1] by the step).
    bias, input_bias : bool
        As in :class:`taskcomplexity.policies.mlp.NetworkSpec`.
    precision : {'float64', 'float32'}
        The forward pass's arithmetic: the weights, the observations as the network reads them and every
        layer's values in this precision (the actions return to float64; the physics is always float64).
        float32 runs the forward pass about 1.5× faster; the returns then differ from float64's by the
        rounding of the actions (``tests/tasks/test_rollout_kernel.py`` states the tolerance).
    """
    q = state["joint_angles"]
    n_env, dof = q.shape
    if weights.shape[0] * episodes != n_env:
        raise ValueError(f"{weights.shape[0]} policies × {episodes} episodes != {n_env} environments")
    if int(layer_sizes[0]) != state["observation"].shape[1] + int(input_bias) or int(layer_sizes[-1]) != dof:
        raise ValueError(f"layer sizes {list(layer_sizes)} do not fit observation size "
                         f"{state['observation'].shape[1]} (input bias {input_bias}) and {dof} actions")
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {list(PRECISIONS)}, got {precision!r}")
    action = np.zeros((n_env, dof))
    _rollout(
        kernel.arm, kernel.task, kernel.zone, np.ascontiguousarray(weights, dtype=PRECISIONS[precision]),
        np.ascontiguousarray(layer_sizes, dtype=np.int64), bool(bias), activation == "relu", output == "tanh",
        bool(input_bias), int(episodes), int(max_steps), env_state(state, action), float(kernel.time_step),
        int(kernel.substeps),
    )
