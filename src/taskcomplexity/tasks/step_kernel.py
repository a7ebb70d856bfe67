"""The batched backend's environment step as one fused numba kernel.

Per environment, one call does what ``ReachingEnv.step`` does: clip the action, integrate the
physics (:func:`taskcomplexity.tasks.dynamics.integrate_block`), then observe by the scalar
definitions of :mod:`taskcomplexity.tasks.mechanics` (observation, distance d, the obstacle's
clearances d₁ and d₂), reward by :func:`taskcomplexity.tasks.rewards.reward` (success, collision and the
reward, the function the PyBullet reference evaluates too), and keep the episode bookkeeping
(return, length, done).

The task's parameters reach the kernels as named records of floats
(:class:`~taskcomplexity.tasks.mechanics.TaskParams`, :class:`~taskcomplexity.tasks.dynamics.ArmParams`,
:class:`~taskcomplexity.tasks.contact.ContactZone`): numba passes them by value, so their fields stay
in registers.

:mod:`~taskcomplexity.tasks.mechanics` is the definition of what the agent observes: the PyBullet
reference runs it too, and ``tests/tasks/test_step_kernel.py`` holds this kernel to its array form on
random states. The kernel exists for speed: at the paper's scale the same arithmetic as ~40
separate tensor operations per step spent most of its time moving memory.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

from taskcomplexity.tasks import rewards
from taskcomplexity.tasks.contact import HANDOVER, NO_CONTACT, ContactZone
from taskcomplexity.tasks.dynamics import BLOCK, ArmParams, integrate_block, inverse_mass_matrix, whole_vectors
from taskcomplexity.tasks.mechanics import (
    TaskParams,
    forearm_clearance_at,
    goal_at,
    observe_goal_at,
    upper_arm_clearance_at,
)

KERNEL_MODULES = ("step_kernel", "rollout_kernel", "dynamics", "contact", "mechanics", "rewards")


def drop_stale_kernels(directory: Path | None = None) -> bool:
    """Delete numba's on-disk kernels of this package when any of their sources changed.

    numba keys a cached kernel on its own file only: after an edit to :mod:`~taskcomplexity.tasks.dynamics`
    or :mod:`~taskcomplexity.tasks.contact` it would go on loading a :func:`_step` compiled from the old
    code. A digest of all the kernel sources, stamped next to the cache, catches that. Returns whether
    anything was dropped.
    """
    here = Path(__file__).resolve().parent
    directory = directory or (Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else here / "__pycache__")
    digest = hashlib.sha256(b"".join((here / f"{name}.py").read_bytes() for name in KERNEL_MODULES)).hexdigest()
    stamp = directory / "taskcomplexity-kernels.sha256"
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        directory.mkdir(parents=True, exist_ok=True)
        for path in directory.iterdir():
            if path.suffix in (".nbi", ".nbc") and path.name.split(".")[0] in KERNEL_MODULES:
                path.unlink(missing_ok=True)
        tmp = stamp.with_name(f"{stamp.name}.{os.getpid()}.tmp")
        tmp.write_text(digest)
        tmp.replace(stamp)
    except OSError:  # a read-only install: numba then caches elsewhere, or compiles afresh
        return False
    return True


def prepare_kernels() -> None:
    """Call before the first kernel of a process runs: drop stale cached kernels, choose numba's threads.

    numba reads its threading layer when its first parallel kernel starts; ``workqueue`` does not spin
    between kernels, so torch's and NumPy's threads get the cores in between. Both are decided here,
    where the kernels are used, never at import.
    """
    drop_stale_kernels()
    numba.config.THREADING_LAYER = "workqueue"


class EnvState(NamedTuple):
    """The B environments' arrays as the kernels take them (updated in place; see :func:`step`)."""

    q: np.ndarray
    """(B, dof) float64: joint angles, rad."""
    qd: np.ndarray
    """(B, dof) float64: joint velocities, rad/s."""
    target: np.ndarray
    """(B, 2) float64: polar target (ρ in m, angle in rad)."""
    action: np.ndarray
    """(B, dof) float64: this step's actions (clipped to [−1, 1] inside)."""
    active: np.ndarray
    """(B,) bool: still running."""
    returns: np.ndarray
    """(B,) float64: undiscounted returns so far."""
    steps: np.ndarray
    """(B,) int64: steps taken."""
    success: np.ndarray
    """(B,) bool: reached d < threshold."""
    handoff: np.ndarray
    """(B,) bool: handed over to the PyBullet reference."""
    contacted: np.ndarray
    """(B,) bool: the modelled block acted on the arm."""
    obs: np.ndarray
    """(B, obs_size) float64: observations."""
    reward: np.ndarray
    """(B,) float64: this step's rewards."""
    done: np.ndarray
    """(B,) bool: terminated this step."""


def env_state(state: dict[str, np.ndarray], action: np.ndarray) -> EnvState:
    """The :class:`EnvState` of the ``state`` dict of :func:`step` and the actions' array."""
    return EnvState(
        state["joint_angles"], state["joint_velocities"], state["target"], action, state["active"],
        state["returns"], state["steps"], state["success"], state["handoff"], state["contact"],
        state["observation"], state["reward"], state["done"],
    )


@numba.njit(cache=True)
def gather(active, steps, max_steps, lo, hi, index):
    """Pack the environments ``lo … hi−1`` that are active and have taken fewer than ``max_steps`` steps
    into ``index`` (int64, length ≥ hi − lo), in order; returns their count n."""
    n = 0
    for e in range(lo, hi):
        if active[e] and steps[e] < max_steps:
            index[n] = e
            n += 1
    return n


@numba.njit(cache=True)
def block_goals(p, target, lo, hi):
    """(hi − lo, 3): :func:`~taskcomplexity.tasks.mechanics.goal_at` (θ, gx, gy) of environments lo … hi−1,
    constant over their episodes (the fused rollout computes them once per episode, :func:`_step` per step)."""
    goals = np.empty((hi - lo, 3))
    for e in range(lo, hi):
        goals[e - lo, 0], goals[e - lo, 1], goals[e - lo, 2] = goal_at(p, target[e, 0], target[e, 1])
    return goals


@numba.njit(cache=True)
def step_block(arm, inv, p, zone, index, n, state, dt, substeps, goals, lo):
    """One environment step of the n active environments ``index[:n]``, in place (the mechanics of one step).

    ``arm`` is the :class:`~taskcomplexity.tasks.dynamics.ArmParams` record, ``p`` the
    :class:`~taskcomplexity.tasks.mechanics.TaskParams` record, ``zone`` the
    :class:`~taskcomplexity.tasks.contact.ContactZone`, ``state`` the :class:`EnvState`.
    The physics runs in lock-step over the n environments (:func:`~taskcomplexity.tasks.dynamics.integrate_block`);
    each environment's arithmetic is its own, so its result does not depend on which others share the
    block. Both :func:`step` and the fused RWG rollout (:mod:`taskcomplexity.tasks.rollout_kernel`) call
    this one definition. ``reward[e]`` and ``done[e]`` are set for the stepped environments only.
    ``goals[e − lo]`` holds environment e's target terms (:func:`block_goals`).
    """
    # without a block the physics runs on whole vectors (rollout_kernel.whole_vectors): the padded environments
    # start at rest at zero and are never read; with one its contact loops run on the stepped environments only
    columns = whole_vectors(n) if zone.mode == NO_CONTACT else n
    a1, a2, u, v, t1, t2, upper, touched = begin_step(p, index, n, state, columns)
    integrate_block(arm, inv, a1, a2, u, v, t1, t2, dt, substeps, zone, touched)
    finish_step(p, zone, index, n, state, goals, lo, a1, a2, u, v, upper, touched)


@numba.njit(cache=True)
def begin_step(p, index, n, state, columns=-1):
    """The first part of :func:`step_block`: the n environments' joint states and clipped torques as
    arrays (a1, a2, u, v, t1, t2) of length ``columns`` (default n; past n all zero), the upper arm's clearance
    before the step (``upper``, m; 0 without an obstacle) and the physics' ``touched`` flags (all False)."""
    q, qd, action = state.q, state.qd, state.action
    two_links = p.dof == 2
    obstacle = p.obstacle > 0
    m = n if columns < 0 else columns
    a1, u, t1 = np.zeros(m), np.zeros(m), np.zeros(m)
    a2, v, t2 = np.zeros(m), np.zeros(m), np.zeros(m)
    upper = np.zeros(m)
    touched = np.zeros(m, dtype=np.bool_)
    for j in range(n):
        e = index[j]
        a1[j], u[j] = q[e, 0], qd[e, 0]
        t1[j] = min(max(action[e, 0], -1.0), 1.0) * p.torque_scale1
        if two_links:
            a2[j], v[j] = q[e, 1], qd[e, 1]
            t2[j] = min(max(action[e, 1], -1.0), 1.0) * p.torque_scale2
        if obstacle:
            upper[j] = upper_arm_clearance_at(p, a1[j])  # measured before the step
    return a1, a2, u, v, t1, t2, upper, touched


@numba.njit(cache=True)
def finish_step(p, zone, index, n, state, goals, lo, a1, a2, u, v, upper, touched):
    """The last part of :func:`step_block`: store the integrated states, observe, reward, keep the books."""
    q, qd, target, action, active, returns, steps, success, handoff, contacted, obs, reward, done = state
    two_links = p.dof == 2
    obstacle = p.obstacle > 0
    handover = zone.mode == HANDOVER
    for j in range(n):
        e = index[j]
        reward[e], done[e] = 0.0, False
        if handover and touched[j]:
            # the forearm entered the block's contact zone: keep the state before the step and
            # leave the episode to the PyBullet reference
            handoff[e] = True
            active[e] = False
            continue  # its observation is left as it was: no policy acts on it any more
        if touched[j]:
            contacted[e] = True
        q[e, 0], qd[e, 0] = a1[j], u[j]
        if two_links:
            q[e, 1], qd[e, 1] = a2[j], v[j]
        goal = goals[e - lo]
        d, elbow_x, elbow_y, ex, ey = observe_goal_at(
            p, q[e, 0], q[e, 1] if two_links else 0.0, qd[e, 0], goal[0], goal[1], goal[2], obs[e]
        )
        c1 = min(max(action[e, 0], -1.0), 1.0)
        effort = c1 * c1
        if two_links:
            c2 = min(max(action[e, 1], -1.0), 1.0)
            effort += c2 * c2
        hit = rewards.success(d, p.threshold)
        collision = False
        near = 0.0
        if obstacle:
            forearm = forearm_clearance_at(p, elbow_x, elbow_y, ex, ey)
            collision = rewards.collision(upper[j], forearm, p.collision_distance)
            near = rewards.proximity(upper[j], forearm, p.proximity_decay)
        r = rewards.reward(p.reward_kind, d, p.threshold, effort, collision, near, p.collision_penalty,
                           p.proximity_weight)
        done[e] = hit or collision
        reward[e] = r
        returns[e] += r
        steps[e] += 1
        if hit:
            success[e] = True
        if done[e]:
            active[e] = False


NO_LIMIT = np.iinfo(np.int64).max  # gather's max_steps when the step count does not limit an episode


@numba.njit(parallel=True, cache=True)
def _step(arm, p, zone, state, dt, substeps):
    active, steps, reward, done = state.active, state.steps, state.reward, state.done
    n_env = active.shape[0]
    inv = inverse_mass_matrix(arm)
    for blk in numba.prange((n_env + BLOCK - 1) // BLOCK):
        lo = blk * BLOCK
        hi = min(lo + BLOCK, n_env)
        for e in range(lo, hi):
            reward[e], done[e] = 0.0, False
        # the block's active environments, packed: the physics runs on them only
        index = np.empty(hi - lo, dtype=np.int64)
        n = gather(active, steps, NO_LIMIT, lo, hi, index)
        if n > 0:
            step_block(arm, inv, p, zone, index, n, state, dt, substeps, block_goals(p, state.target, lo, hi), lo)


class KernelTask(NamedTuple):
    """A task as the kernels take it (what :class:`~taskcomplexity.tasks.batched.BatchedReaching` builds once).

    Attributes
    ----------
    arm : ArmParams
        :meth:`taskcomplexity.tasks.dynamics.ArmDynamics.params` of the arm.
    task : TaskParams
        :func:`taskcomplexity.tasks.mechanics.task_params` of the task.
    zone : ContactZone
        :func:`taskcomplexity.tasks.dynamics.contact_zone` of the task: with hand-overs, an environment
        whose forearm enters the block's contact zone keeps its state from before the step, is marked
        in ``handoff`` and made inactive; with the contact model, ``contact`` marks the environments
        the block acted on.
    time_step : float
        Physics time step, s.
    substeps : int
        Physics steps per environment step.
    """

    arm: ArmParams
    task: TaskParams
    zone: ContactZone
    time_step: float
    substeps: int


def step(kernel: KernelTask, state: dict[str, np.ndarray], action: np.ndarray) -> None:
    """Advance every active environment by one environment step, in place.

    Parameters
    ----------
    kernel : KernelTask
    state : dict of ndarray
        ``joint_angles``, ``joint_velocities`` (B, dof) float64; ``target`` (B, 2); ``active``,
        ``success``, ``handoff``, ``contact``, ``done`` (B,) bool; ``returns``, ``reward`` (B,) float64;
        ``steps`` (B,) int64; ``observation`` (B, obs_size) float64. Updated in place: ``reward``
        and ``done`` are this step's (0 and False for environments that were not active).
    action : ndarray (B, dof), float64
        Clipped to [−1, 1] inside.
    """
    _step(kernel.arm, kernel.task, kernel.zone, env_state(state, action), float(kernel.time_step),
          int(kernel.substeps))
