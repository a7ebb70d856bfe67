"""Task semantics shared by both backends: angle wrapping, kinematics, observations, clearances, rewards.

Two forms, side by side:

- scalar numba functions of one environment on the :class:`TaskParams` record
  (:func:`observe_at`, split into the episode's constant target terms :func:`goal_at` and
  :func:`observe_goal_at`; :func:`upper_arm_clearance_at`, :func:`forearm_clearance_at`), which the batched
  backend's step kernel (:mod:`taskcomplexity.tasks.step_kernel`) inlines;
- array functions for the PyBullet reference and the batched backend's reset (leading dimensions
  are batch dimensions). :func:`upper_arm_clearance`, :func:`forearm_clearance` and
  :func:`reward_terms` take NumPy arrays and evaluate the scalar definitions (the clearances) and
  :func:`taskcomplexity.tasks.rewards.reward`. :func:`observe` works on NumPy arrays and torch
  tensors alike (the array library is picked from the input); ``tests/tasks/test_step_kernel.py``
  holds :func:`observe_at` to it. (It stays array-generic because the batched reset computes its
  first observation in torch, whose vectorised cos/sin differ from libm's in the last bit for ~0.5 %
  of states: evaluating the scalar form there would change the batched returns in the last bits.)

Units: metres, radians, seconds.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

try:  # torch is a hard dependency of the package, but keep this module importable without it
    import torch
except ImportError:  # pragma: no cover
    torch = None

from taskcomplexity.tasks import rewards
from taskcomplexity.tasks.spec import LINK_WIDTH, ArmSpec, TaskSpec

TWO_PI = 2.0 * math.pi


class TaskParams(NamedTuple):
    """The kernels' record of a task's semantics (floats; lengths in m, torques in N·m).

    A tuple of floats: numba passes it by value and the compiler keeps the fields in registers.
    Without an obstacle the obstacle's fields are 0.
    """

    dof: float
    """Number of links, 1 or 2."""
    round_scale: float
    """10^decimals where the task rounds the observed angles (to 1/round_scale rad), else 0."""
    length1: float
    """Upper arm length, m."""
    length2: float
    """Forearm length, m (0 for a 1-link arm)."""
    threshold: float
    """Success distance, m."""
    reward_kind: float
    """:attr:`taskcomplexity.tasks.rewards.RewardKind.code` of the task's reward."""
    torque_scale1: float
    """Shoulder torque per unit action, N·m."""
    torque_scale2: float
    """Elbow torque per unit action, N·m (0 for a 1-link arm)."""
    obstacle: float
    """1 with an obstacle, else 0."""
    obstacle_x: float
    """Block centre x, m."""
    obstacle_y: float
    """Block centre y, m."""
    reach: float
    """r_o + t_o/2: what d₂ subtracts from the forearm's distance to the block centre, m."""
    collision_distance: float
    """A clearance at or below this is a collision, m."""
    collision_penalty: float
    """Reward penalty of a collision."""
    proximity_weight: float
    """Weight of the proximity term."""
    proximity_decay: float
    """Decay of the proximity term, 1/m."""
    segment_points: float
    """The forearm is sampled at k = 0 … segment_points for d₂."""
    block_half: float
    """Half side of the block's footprint core (shrunk by the collision margin), m."""
    link_half_x: float
    """Half length of link 1's box core, m."""
    link_half_y: float
    """Half width of link 1's box core, m."""
    link_centre: float
    """Centre of link 1's box along its axis from the shoulder, m."""


def task_params(task: TaskSpec) -> TaskParams:
    """The kernels' :class:`TaskParams` record of ``task``."""
    arm = task.arm
    two = arm.dof == 2
    values = dict(
        dof=float(arm.dof),
        round_scale=10.0**arm.angle_decimals if task.rounds_angles else 0.0,
        length1=float(arm.links[0].length),
        length2=float(arm.links[1].length) if two else 0.0,
        threshold=float(task.reward.threshold),
        reward_kind=rewards.reward_kind(task.reward.kind).code,
        torque_scale1=float(arm.torque_scale[0]),
        torque_scale2=float(arm.torque_scale[1]) if two else 0.0,
    )
    obstacle = arm.obstacle
    none = {name: 0.0 for name in TaskParams._fields[len(values):]}
    if obstacle is None:
        return TaskParams(**values, **none)
    link = arm.links[0]
    ox, oy = obstacle.position
    return TaskParams(
        **values,
        obstacle=1.0,
        obstacle_x=float(ox),
        obstacle_y=float(oy),
        reach=float(obstacle.obstacle_radius + obstacle.link_thickness / 2),
        collision_distance=float(obstacle.collision_distance),
        collision_penalty=float(obstacle.collision_penalty),
        proximity_weight=float(obstacle.proximity_weight),
        proximity_decay=float(obstacle.proximity_decay),
        segment_points=float(obstacle.segment_points),
        block_half=float(obstacle.scale * BLOCK_FOOTPRINT / 2 - COLLISION_MARGIN),
        link_half_x=float(link.box_length / 2 - COLLISION_MARGIN),
        link_half_y=float(LINK_WIDTH / 2 - COLLISION_MARGIN),
        link_centre=float(link.box_origin),
    )


@numba.njit(cache=True)
def wrap_at(q, scale):
    """:func:`wrap_angle` of one angle: round half to even at 1/scale rad (scale 0: no rounding), mod 2π."""
    if scale > 0.0:
        q = np.round(q * scale) / scale
    return np.remainder(q, TWO_PI)


@numba.njit(cache=True)
def _point_to_box(px, py, half_x, half_y):
    dx = max(abs(px) - half_x, 0.0)
    dy = max(abs(py) - half_y, 0.0)
    return np.sqrt(dx * dx + dy * dy)


@numba.njit(cache=True)
def upper_arm_clearance_at(p, q1):
    """d₁ of one environment (:func:`upper_arm_clearance`) from the raw shoulder angle q1, m, clipped at 0."""
    half, hx, hy, cx, ox, oy = p.block_half, p.link_half_x, p.link_half_y, p.link_centre, p.obstacle_x, p.obstacle_y
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


@numba.njit(cache=True)
def forearm_clearance_at(p, elbow_x, elbow_y, eff_x, eff_y):
    """d₂ of one environment (:func:`forearm_clearance`) over the sampled forearm points, m, clipped at 0."""
    points = int(p.segment_points)
    nearest = np.inf  # squared: sqrt is monotone and correctly rounded, so sqrt(min) = min(sqrt) exactly
    for k in range(points + 1):
        f = k / points
        dx = elbow_x + f * (eff_x - elbow_x) - p.obstacle_x
        dy = elbow_y + f * (eff_y - elbow_y) - p.obstacle_y
        nearest = min(nearest, dx * dx + dy * dy)
    nearest = np.sqrt(nearest)
    return max(nearest - p.reach, 0.0)


@numba.njit(cache=True)
def goal_at(p, radius, angle):
    """The observation's target terms of one environment, constant over its episode: (θ, gx, gy).

    θ is the observed target angle (1-link arm: wrapped, and rounded where the task rounds; 2-link arm: the
    raw angle, unobserved), (gx, gy) = ρ·(cos θ, sin θ) the Cartesian target, m. Computed once per
    episode by the fused rollout; :func:`observe_goal_at` takes them.
    """
    theta = wrap_at(angle, p.round_scale) if p.dof == 1 else angle
    return theta, radius * np.cos(theta), radius * np.sin(theta)


@numba.njit(cache=True)
def observe_goal_at(p, q1, q2, qd1, theta, gx, gy, obs):
    """:func:`observe_at` with the target's terms (θ, gx, gy) of :func:`goal_at`: fills ``obs`` and returns
    (d, elbow x, elbow y, effector x, effector y), m."""
    scale = p.round_scale
    if p.dof == 1:
        l1 = p.length1
        phi = wrap_at(q1, scale)
        ex, ey = l1 * np.cos(phi), l1 * np.sin(phi)
        dx, dy = ex - gx, ey - gy
        obs[0], obs[1], obs[2], obs[3], obs[4] = phi, ex, ey, theta, gx
        obs[5], obs[6], obs[7], obs[8] = gy, dx, dy, qd1
        return np.sqrt(dx * dx + dy * dy), 0.0, 0.0, ex, ey
    a = wrap_at(q1, scale)
    b = a + wrap_at(q2, scale)
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    elbow_x, elbow_y = p.length1 * ca, p.length1 * sa
    ex, ey = elbow_x + p.length2 * cb, elbow_y + p.length2 * sb
    dx, dy = ex - gx, ey - gy
    obs[0], obs[1], obs[2], obs[3], obs[4] = ca, cb, sa, sb, gx
    obs[5], obs[6], obs[7], obs[8], obs[9] = gy, ex, ey, dx, dy
    return np.sqrt(dx * dx + dy * dy), elbow_x, elbow_y, ex, ey


@numba.njit(cache=True)
def observe_at(p, q1, q2, qd1, radius, angle, obs):
    """:func:`observe` of one environment (q2 unused by a 1-link arm) at polar target (ρ, angle): fills
    ``obs`` and returns (d, elbow x, elbow y, effector x, effector y), m (the elbow is (0, 0) for a 1-link arm)."""
    theta, gx, gy = goal_at(p, radius, angle)
    return observe_goal_at(p, q1, q2, qd1, theta, gx, gy, obs)


def xp_of(x):
    """The array namespace of ``x``: ``torch`` for tensors, ``numpy`` otherwise."""
    if torch is not None and isinstance(x, torch.Tensor):
        return torch
    return np


def wrap_angle(q, decimals: int | None):
    """w(q): round to ``decimals`` decimals (round half to even of 10^d·q), then reduce mod 2π.

    ``decimals=None`` skips the rounding. Output in [0, 2π).
    """
    xp = xp_of(q)
    if decimals is not None:
        scale = 10.0**decimals
        q = xp.round(q * scale) / scale
    return xp.remainder(q, TWO_PI)


def initial_state(arm: ArmSpec, uniforms):
    """Map four U[0, 1) variates per episode to a reset state.

    Parameters
    ----------
    arm : ArmSpec
    uniforms : array (..., 4)
        Columns: joint 1 angle, joint 2 angle (unused by a 1-link arm), target radius, target angle.

    Returns
    -------
    joint_angles : array (..., dof), radians in [0, 2π)
    target : array (..., 2)
        Target in polar form (radius ρ in metres, angle in radians).
    """
    xp = xp_of(uniforms)
    joint_angles = TWO_PI * uniforms[..., : arm.dof]
    low, high = arm.target_radius
    radius = low + (high - low) * uniforms[..., 2]
    angle = TWO_PI * uniforms[..., 3]
    return joint_angles, xp.stack([radius, angle], -1)


def _stack(xp, columns):
    return xp.stack(columns, -1)


def forward_kinematics(task: TaskSpec, joint_angles):
    """Observed joint angles, elbow and end-effector positions.

    Parameters
    ----------
    joint_angles : array (..., dof)
        Raw joint angles from the simulator, radians (unbounded).

    Returns
    -------
    q_hat : array (..., dof)
        w(q): wrapped (and rounded where the task rounds) angles.
    elbow : array (..., 2)
        Position of the last joint (the base for a 1-link arm), metres.
    effector : array (..., 2)
        End-effector position, metres.
    """
    xp = xp_of(joint_angles)
    decimals = task.arm.angle_decimals if task.rounds_angles else None
    q_hat = wrap_angle(joint_angles, decimals)
    lengths = [link.length for link in task.arm.links]
    if task.arm.dof == 1:
        phi = q_hat[..., 0]
        effector = _stack(xp, [lengths[0] * xp.cos(phi), lengths[0] * xp.sin(phi)])
        return q_hat, xp.zeros_like(effector), effector
    q1, q12 = q_hat[..., 0], q_hat[..., 0] + q_hat[..., 1]
    elbow = _stack(xp, [lengths[0] * xp.cos(q1), lengths[0] * xp.sin(q1)])
    effector = elbow + _stack(xp, [lengths[1] * xp.cos(q12), lengths[1] * xp.sin(q12)])
    return q_hat, elbow, effector


def target_position(task: TaskSpec, target):
    """Observed target angle term and Cartesian target.

    The 1-link observation carries the target angle, wrapped (and rounded) like the joint angle;
    the 2-link observation carries the raw Cartesian target.

    Returns
    -------
    target_angle : array (...,)
    goal : array (..., 2)
    """
    xp = xp_of(target)
    radius, angle = target[..., 0], target[..., 1]
    if task.arm.dof == 1:
        decimals = task.arm.angle_decimals if task.rounds_angles else None
        angle = wrap_angle(angle, decimals)
    return angle, _stack(xp, [radius * xp.cos(angle), radius * xp.sin(angle)])


def observe(task: TaskSpec, joint_angles, joint_velocities, target):
    """Observation vector and end-effector/target geometry after a step.

    Parameters
    ----------
    joint_angles, joint_velocities : array (..., dof)
        Raw simulator state (rad, rad/s).
    target : array (..., 2)
        Polar target (ρ, angle).

    Returns
    -------
    observation : array (..., 9) for a 1-link arm, (..., 10) for a 2-link arm
        1-link: [w(q), l cos w(q), l sin w(q), w(θ), R cos w(θ), R sin w(θ), ex−gx, ey−gy, q̇].
        2-link: [cos q̂₁, cos(q̂₁+q̂₂), sin q̂₁, sin(q̂₁+q̂₂), gx, gy, ex, ey, ex−gx, ey−gy].
    distance : array (...,)
        d = ‖e − g‖, metres, from the observed (rounded) values.
    elbow, effector : array (..., 2)
    """
    xp = xp_of(joint_angles)
    q_hat, elbow, effector = forward_kinematics(task, joint_angles)
    target_angle, goal = target_position(task, target)
    delta = effector - goal
    if task.arm.dof == 1:
        columns = [
            q_hat[..., 0],
            effector[..., 0],
            effector[..., 1],
            target_angle,
            goal[..., 0],
            goal[..., 1],
            delta[..., 0],
            delta[..., 1],
            joint_velocities[..., 0],
        ]
    else:
        q1, q12 = q_hat[..., 0], q_hat[..., 0] + q_hat[..., 1]
        columns = [
            xp.cos(q1),
            xp.cos(q12),
            xp.sin(q1),
            xp.sin(q12),
            goal[..., 0],
            goal[..., 1],
            effector[..., 0],
            effector[..., 1],
            delta[..., 0],
            delta[..., 1],
        ]
    distance = xp.sqrt(delta[..., 0] ** 2 + delta[..., 1] ** 2)
    return _stack(xp, columns), distance, elbow, effector


def forearm_clearance(task: TaskSpec, elbow, effector):
    """d₂: clearance between the forearm and the obstacle, metres, clipped at 0 (NumPy arrays).

    The forearm is sampled at p_k = a + (k/K)(b − a), k = 0…K, and d₂ = min_k ‖p_k − o‖ − (r_o + t_o/2)
    (:func:`forearm_clearance_at` per environment).

    Parameters
    ----------
    elbow, effector : array (..., 2)
        a and b, m.

    Returns
    -------
    array (...,)
    """
    elbow, effector = np.broadcast_arrays(np.asarray(elbow, dtype=np.float64), np.asarray(effector, dtype=np.float64))
    out = np.empty(elbow.shape[:-1])
    _forearm_clearances(task_params(task), elbow.reshape(-1, 2), effector.reshape(-1, 2), out.reshape(-1))
    return out


@numba.njit(cache=True)
def _forearm_clearances(p, elbow, effector, out):
    for e in range(out.shape[0]):
        out[e] = forearm_clearance_at(p, elbow[e, 0], elbow[e, 1], effector[e, 0], effector[e, 1])


def reward_terms(task: TaskSpec, action, distance, upper_clearance=None, forearm_clearance_=None):
    """Per-step reward and its terms, by :func:`taskcomplexity.tasks.rewards.reward` (NumPy arrays).

    Parameters
    ----------
    action : array (..., dof)
        Clipped action in [−1, 1].
    distance : array (...,)
        End-effector distance d, metres.
    upper_clearance, forearm_clearance_ : array (...,), optional
        d₁ and d₂ of the obstacle task (clipped at 0), metres.

    Returns
    -------
    reward : array (...,)
    terms : dict of array (...,)
        The signed terms the reward kind reports (:attr:`~taskcomplexity.tasks.rewards.RewardKind.terms`:
        ``distance``, ``action``, and with an obstacle ``collision`` and ``proximity`` for a dense
        reward), and ``success``.
    collision : array (...,) of bool
        Whether the obstacle was hit (all False without an obstacle).
    """
    kind = rewards.reward_kind(task.reward.kind)
    distance = np.asarray(distance, dtype=np.float64)
    effort = (np.asarray(action, dtype=np.float64) ** 2).sum(-1)
    success = rewards.success(distance, task.reward.threshold)
    obstacle = task.arm.obstacle
    if obstacle is None:
        collision, near, penalty, weight = np.zeros_like(success), 0.0, 0.0, 0.0
    else:
        upper = np.asarray(upper_clearance, dtype=np.float64)
        forearm = np.asarray(forearm_clearance_, dtype=np.float64)
        collision = rewards.collision(upper, forearm, obstacle.collision_distance)
        near = rewards.proximity(upper, forearm, obstacle.proximity_decay)
        penalty, weight = obstacle.collision_penalty, obstacle.proximity_weight
    reward = rewards.rewards(kind.name, distance, task.reward.threshold, effort, collision, near, penalty, weight)
    signed = rewards.shaped_terms(distance, effort, np.asarray(collision, dtype=np.float64), near, penalty, weight)
    terms = {
        name: value
        for name, value in zip(rewards.TERMS, signed, strict=True)
        if name in kind.terms and (obstacle is not None or name not in rewards.OBSTACLE_TERMS)
    }
    terms["success"] = success
    return reward, terms, collision


# --- the obstacle's geometry as PyBullet's closest-point query sees it -------------------------

# pybullet_data block.urdf is a 0.10 × 0.018 × 0.018 box; stood upright (rotated π/2 about y) its
# footprint in the arm's plane is 0.018 × 0.018 before scaling.
BLOCK_FOOTPRINT = 0.018
BLOCK_LENGTH = 0.10  # its long side, vertical once stood upright
# PyBullet's URDF importer gives every collision shape a 0.001 m margin: a box's closest distance is
# measured between cores shrunk by the margin, minus both margins (boxes with rounded edges).
COLLISION_MARGIN = 0.001


def upper_arm_clearance(task: TaskSpec, joint_angles):
    """d₁: closest distance between link 1's box and the block in the plane, metres, clipped at 0.

    Matches ``pybullet.getClosestPoints`` for disjoint boxes (both vertical ranges overlap, so the
    3-D distance is the planar one): the distance between the margin-shrunk cores minus the margins
    (:func:`upper_arm_clearance_at` per environment). Uses the raw (unrounded) shoulder angle, as the
    simulator does.

    Parameters
    ----------
    joint_angles : array (..., 2)
        NumPy array, rad.

    Returns
    -------
    array (...,)
    """
    q1 = np.ascontiguousarray(np.asarray(joint_angles, dtype=np.float64)[..., 0])
    out = np.empty(q1.shape)
    _upper_arm_clearances(task_params(task), q1.reshape(-1), out.reshape(-1))
    return out


@numba.njit(cache=True)
def _upper_arm_clearances(p, q1, out):
    for e in range(out.shape[0]):
        out[e] = upper_arm_clearance_at(p, q1[e])
