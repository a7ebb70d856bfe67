"""The batched backend's environment step as one fused numba kernel.

Per environment, one call does what ``ReachingEnv.step`` does: clip the action, integrate the
physics (:func:`taskcomplexity.tasks.dynamics.integrate_block`), then observe and reward exactly as
:mod:`taskcomplexity.tasks.mechanics` defines it (observation, distance d, success, the obstacle's
clearances d₁ and d₂, collision), and keep the episode bookkeeping (return, length, done).

:mod:`~taskcomplexity.tasks.mechanics` stays the one definition of the task's semantics: it is what
the PyBullet reference runs, and ``tests/tasks/test_step_kernel.py`` holds this kernel to it on
random states. The kernel exists for speed: at the paper's scale the same arithmetic as ~40
separate tensor operations per step spent most of its time moving memory.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba
import numpy as np

from taskcomplexity.tasks.dynamics import BLOCK, integrate_block, inverse_mass_matrix
from taskcomplexity.tasks.mechanics import BLOCK_FOOTPRINT, COLLISION_MARGIN, TWO_PI
from taskcomplexity.tasks.spec import LINK_WIDTH, TaskSpec

KERNEL_MODULES = ("step_kernel", "rollout_kernel", "dynamics", "contact", "mechanics")


def drop_stale_kernels(directory: Path | None = None) -> bool:
    """Delete numba's on-disk kernels of this package when any of their sources changed.

    numba keys a cached kernel on its own file only: after an edit to :mod:`dynamics` or
    :mod:`contact` it would go on loading a :func:`_step` compiled from the old code. A digest of all
    the kernel sources, stamped next to the cache, catches that. Returns whether anything was dropped.
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


# layout of the task vector
DOF, ROUND, L1, L2, THRESHOLD, SPARSE, SCALE1, SCALE2 = range(8)
OBSTACLE, OX, OY, REACH, COLLIDE, PENALTY, WEIGHT, DECAY, POINTS = range(8, 17)
BLOCK_HALF, HALF_X, HALF_Y, CX = range(17, 21)
TASK_VECTOR_SIZE = 21


def task_vector(task: TaskSpec) -> np.ndarray:
    """The task's semantics as a flat float64 vector for the kernel (layout: the constants above)."""
    arm = task.arm
    p = np.zeros(TASK_VECTOR_SIZE)
    p[DOF] = arm.dof
    p[ROUND] = 10.0**arm.angle_decimals if task.rounds_angles else 0.0
    p[L1] = arm.links[0].length
    p[L2] = arm.links[1].length if arm.dof == 2 else 0.0
    p[THRESHOLD] = task.reward.threshold
    p[SPARSE] = 1.0 if task.reward.kind == "sparse" else 0.0
    p[SCALE1] = arm.torque_scale[0]
    p[SCALE2] = arm.torque_scale[1] if arm.dof == 2 else 0.0
    obstacle = arm.obstacle
    if obstacle is not None:
        link = arm.links[0]
        p[OBSTACLE] = 1.0
        p[OX], p[OY] = obstacle.position
        p[REACH] = obstacle.obstacle_radius + obstacle.link_thickness / 2
        p[COLLIDE] = obstacle.collision_distance
        p[PENALTY] = obstacle.collision_penalty
        p[WEIGHT] = obstacle.proximity_weight
        p[DECAY] = obstacle.proximity_decay
        p[POINTS] = obstacle.segment_points
        p[BLOCK_HALF] = obstacle.scale * BLOCK_FOOTPRINT / 2 - COLLISION_MARGIN
        p[HALF_X] = link.box_length / 2 - COLLISION_MARGIN
        p[HALF_Y] = LINK_WIDTH / 2 - COLLISION_MARGIN
        p[CX] = link.box_origin
    return p


@numba.njit(cache=True, inline="always")
def _wrap(q, scale):
    """mechanics.wrap_angle: round half to even at 1/scale rad (scale 0: no rounding), mod 2π."""
    if scale > 0.0:
        q = np.round(q * scale) / scale
    return np.remainder(q, TWO_PI)


@numba.njit(cache=True, inline="always")
def _point_to_box(px, py, half_x, half_y):
    dx = max(abs(px) - half_x, 0.0)
    dy = max(abs(py) - half_y, 0.0)
    return np.sqrt(dx * dx + dy * dy)


@numba.njit(cache=True, inline="always")
def _upper_arm_clearance(p, q1):
    """mechanics.upper_arm_clearance: d₁ from the raw shoulder angle, m, clipped at 0."""
    half, hx, hy, cx, ox, oy = p[BLOCK_HALF], p[HALF_X], p[HALF_Y], p[CX], p[OX], p[OY]
    c, s = np.cos(q1), np.sin(q1)
    best = np.inf
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            bx, by = ox + sx * half, oy + sy * half
            lx, ly = c * bx + s * by - cx, -s * bx + c * by
            ax, ay = cx + sx * hx, sy * hy
            wx, wy = c * ax - s * ay - ox, s * ax + c * ay - oy
            pair = min(_point_to_box(lx, ly, hx, hy), _point_to_box(wx, wy, half, half))
            best = min(best, pair)
    return max(best - 2 * COLLISION_MARGIN, 0.0)


@numba.njit(cache=True, inline="always")
def _forearm_clearance(p, elbow_x, elbow_y, eff_x, eff_y):
    """mechanics.forearm_clearance: d₂ over the sampled forearm points, m, clipped at 0."""
    points = int(p[POINTS])
    nearest = np.inf  # squared: sqrt is monotone and correctly rounded, so sqrt(min) = min(sqrt) exactly
    for k in range(points + 1):
        f = k / points
        dx = elbow_x + f * (eff_x - elbow_x) - p[OX]
        dy = elbow_y + f * (eff_y - elbow_y) - p[OY]
        nearest = min(nearest, dx * dx + dy * dy)
    nearest = np.sqrt(nearest)
    return max(nearest - p[REACH], 0.0)


@numba.njit(cache=True, inline="always")
def _observe(p, q1, q2, qd1, radius, angle, obs):
    """mechanics.observe for one environment: fills ``obs`` and returns (d, elbow, effector)."""
    scale = p[ROUND]
    if p[DOF] == 1:
        l1 = p[L1]
        phi = _wrap(q1, scale)
        ex, ey = l1 * np.cos(phi), l1 * np.sin(phi)
        theta = _wrap(angle, scale)
        gx, gy = radius * np.cos(theta), radius * np.sin(theta)
        dx, dy = ex - gx, ey - gy
        obs[0], obs[1], obs[2], obs[3], obs[4] = phi, ex, ey, theta, gx
        obs[5], obs[6], obs[7], obs[8] = gy, dx, dy, qd1
        return np.sqrt(dx * dx + dy * dy), 0.0, 0.0, ex, ey
    a = _wrap(q1, scale)
    b = a + _wrap(q2, scale)
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    elbow_x, elbow_y = p[L1] * ca, p[L1] * sa
    ex, ey = elbow_x + p[L2] * cb, elbow_y + p[L2] * sb
    gx, gy = radius * np.cos(angle), radius * np.sin(angle)
    dx, dy = ex - gx, ey - gy
    obs[0], obs[1], obs[2], obs[3], obs[4] = ca, cb, sa, sb, gx
    obs[5], obs[6], obs[7], obs[8], obs[9] = gy, ex, ey, dx, dy
    return np.sqrt(dx * dx + dy * dy), elbow_x, elbow_y, ex, ey


ARM_VECTOR_SIZE = 13  # ArmDynamics.vector() of a 2-link arm; a 1-link arm's is padded with zeros


def arm_vector(dynamics: np.ndarray) -> np.ndarray:
    """:meth:`~taskcomplexity.tasks.dynamics.ArmDynamics.vector` padded to ARM_VECTOR_SIZE (what the kernels take)."""
    out = np.zeros(ARM_VECTOR_SIZE)
    out[: len(dynamics)] = dynamics
    return out


@numba.njit(cache=True, inline="always")
def _arm_tuple(d):
    """The arm's parameters as a tuple: values, not memory, so that the compiler keeps them in registers
    across the physics loop (from an array it must reload them after every store to the state arrays,
    which keeps the loop from being vectorised: ~5× slower for the 1-link arm). Same arithmetic."""
    return (d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8], d[9], d[10], d[11], d[12])


@numba.njit(cache=True)
def step_block(dynamics, inv, p, zone, index, n, q, qd, target, action, active, returns, steps, success, handoff,
               contact, obs, reward, done, dt, substeps):
    """One environment step of the n active environments ``index[:n]``, in place (the mechanics of one step).

    The physics runs in lock-step over the n environments (:func:`~taskcomplexity.tasks.dynamics.integrate_block`);
    each environment's arithmetic is its own, so its result does not depend on which others share the
    block. Both :func:`step` and the fused RWG rollout (:mod:`taskcomplexity.tasks.rollout_kernel`) call
    this one definition. ``reward[e]`` and ``done[e]`` are set for the stepped environments only.
    """
    two_links = p[DOF] == 2
    obstacle = p[OBSTACLE] > 0
    handover = zone[0] == 1.0
    a1, u, t1 = np.empty(n), np.empty(n), np.empty(n)
    a2, v, t2 = np.zeros(n), np.zeros(n), np.zeros(n)
    upper = np.zeros(n)
    touched = np.zeros(n, dtype=np.bool_)
    for j in range(n):
        e = index[j]
        a1[j], u[j] = q[e, 0], qd[e, 0]
        t1[j] = min(max(action[e, 0], -1.0), 1.0) * p[SCALE1]
        if two_links:
            a2[j], v[j] = q[e, 1], qd[e, 1]
            t2[j] = min(max(action[e, 1], -1.0), 1.0) * p[SCALE2]
        if obstacle:
            upper[j] = _upper_arm_clearance(p, a1[j])  # measured before the step
    integrate_block(_arm_tuple(dynamics), inv, a1, a2, u, v, t1, t2, dt, substeps, zone, touched)
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
            contact[e] = True
        q[e, 0], qd[e, 0] = a1[j], u[j]
        if two_links:
            q[e, 1], qd[e, 1] = a2[j], v[j]
        d, elbow_x, elbow_y, ex, ey = _observe(
            p, q[e, 0], q[e, 1] if two_links else 0.0, qd[e, 0], target[e, 0], target[e, 1], obs[e]
        )
        hit = d < p[THRESHOLD]
        collision = False
        if p[SPARSE] > 0:
            r = (1.0 if hit else 0.0) - 1.0
        else:
            c1 = min(max(action[e, 0], -1.0), 1.0)
            effort = c1 * c1
            if two_links:
                c2 = min(max(action[e, 1], -1.0), 1.0)
                effort += c2 * c2
            r = -(d * d) + -effort
            if obstacle:
                forearm = _forearm_clearance(p, elbow_x, elbow_y, ex, ey)
                collision = upper[j] <= p[COLLIDE] or forearm <= p[COLLIDE]
                r += -p[PENALTY] * (1.0 if collision else 0.0)
                r += -p[WEIGHT] * (np.exp(-p[DECAY] * upper[j]) + np.exp(-p[DECAY] * forearm))
        done[e] = hit or collision
        reward[e] = r
        returns[e] += r
        steps[e] += 1
        if hit:
            success[e] = True
        if done[e]:
            active[e] = False


@numba.njit(parallel=True, cache=True)
def _step(dynamics, p, zone, q, qd, target, action, active, returns, steps, success, handoff, contact, obs, reward,
          done, dt, substeps):
    n_env = q.shape[0]
    inv = inverse_mass_matrix(dynamics)
    for blk in numba.prange((n_env + BLOCK - 1) // BLOCK):
        lo = blk * BLOCK
        # the block's active environments, packed: the physics runs on them only
        index = np.empty(min(BLOCK, n_env - lo), dtype=np.int64)
        n = 0
        for e in range(lo, lo + index.shape[0]):
            reward[e], done[e] = 0.0, False
            if active[e]:
                index[n] = e
                n += 1
        if n > 0:
            step_block(dynamics, inv, p, zone, index, n, q, qd, target, action, active, returns, steps, success,
                       handoff, contact, obs, reward, done, dt, substeps)


def step(
    dynamics: np.ndarray,
    task: np.ndarray,
    zone: np.ndarray,
    state: dict[str, np.ndarray],
    action: np.ndarray,
    time_step: float,
    substeps: int,
) -> None:
    """Advance every active environment by one environment step, in place.

    Parameters
    ----------
    dynamics : ndarray
        :meth:`taskcomplexity.tasks.dynamics.ArmDynamics.vector` of the arm (padded inside).
    task : ndarray
        :func:`task_vector` of the task.
    zone : ndarray
        :func:`taskcomplexity.tasks.dynamics.contact_zone` of the task: with hand-overs, an environment
        whose forearm enters the block's contact zone keeps its state from before the step, is marked
        in ``handoff`` and made inactive; with the contact model, ``contact`` marks the environments
        the block acted on.
    state : dict of ndarray
        ``joint_angles``, ``joint_velocities`` (B, dof) float64; ``target`` (B, 2); ``active``,
        ``success``, ``handoff``, ``contact``, ``done`` (B,) bool; ``returns``, ``reward`` (B,) float64;
        ``steps`` (B,) int64; ``observation`` (B, obs_size) float64. Updated in place: ``reward``
        and ``done`` are this step's (0 and False for environments that were not active).
    action : ndarray (B, dof), float64
        Clipped to [−1, 1] inside.
    """
    _step(
        arm_vector(dynamics), task, zone, state["joint_angles"], state["joint_velocities"], state["target"], action,
        state["active"], state["returns"], state["steps"], state["success"], state["handoff"], state["contact"],
        state["observation"], state["reward"], state["done"], float(time_step), int(substeps),
    )
