"""Task semantics shared by both backends: angle wrapping, kinematics, observations, rewards.

The functions work on NumPy arrays (the PyBullet backend, one environment) and on torch tensors
(the batched backend's reset, many environments) alike: leading dimensions are batch dimensions and
the array library is picked from the input; :func:`reward_terms` takes NumPy arrays and evaluates
:func:`taskcomplexity.tasks.rewards.reward`, the one definition of what an agent earns. This is the
definition of what an agent observes; only the integration of the dynamics differs between backends.

Units: metres, radians, seconds.
"""

from __future__ import annotations

import math

import numpy as np

try:  # torch is a hard dependency of the package, but keep this module importable without it
    import torch
except ImportError:  # pragma: no cover
    torch = None

from taskcomplexity.tasks import rewards
from taskcomplexity.tasks.spec import LINK_WIDTH, ArmSpec, TaskSpec

TWO_PI = 2.0 * math.pi


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
    """d₂: clearance between the forearm and the obstacle, metres, clipped at 0.

    The forearm is sampled at p_k = a + (k/K)(b − a), k = 0…K, and d₂ = min_k ‖p_k − o‖ − (r_o + t_o/2).
    """
    xp = xp_of(elbow)
    obstacle = task.arm.obstacle
    ox, oy = obstacle.position
    k = np.arange(obstacle.segment_points + 1, dtype=np.float64) / obstacle.segment_points
    if xp is not np:
        k = torch.as_tensor(k, dtype=elbow.dtype, device=elbow.device)
    px = elbow[..., :1] + k * (effector[..., :1] - elbow[..., :1])
    py = elbow[..., 1:] + k * (effector[..., 1:] - elbow[..., 1:])
    nearest = xp.sqrt((px - ox) ** 2 + (py - oy) ** 2).min(-1)
    if xp is not np:
        nearest = nearest.values
    clearance = nearest - (obstacle.obstacle_radius + obstacle.link_thickness / 2)
    return xp.clip(clearance, 0.0, None)


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


def _point_to_box(px, py, half_x, half_y, xp):
    """Distance from points (px, py) to the axis-aligned box [−half_x, half_x] × [−half_y, half_y]."""
    dx = xp.clip(xp.abs(px) - half_x, 0.0, None)
    dy = xp.clip(xp.abs(py) - half_y, 0.0, None)
    return xp.sqrt(dx * dx + dy * dy)


def upper_arm_clearance(task: TaskSpec, joint_angles):
    """d₁: closest distance between link 1's box and the block in the plane, metres, clipped at 0.

    Matches ``pybullet.getClosestPoints`` for disjoint boxes (both vertical ranges overlap, so the
    3-D distance is the planar one): the distance between the margin-shrunk cores minus the margins.
    Uses the raw (unrounded) shoulder angle, as the simulator does.

    Parameters
    ----------
    joint_angles : array (..., 2)
    """
    xp = xp_of(joint_angles)
    obstacle = task.arm.obstacle
    link = task.arm.links[0]
    ox, oy = obstacle.position
    block_half = obstacle.scale * BLOCK_FOOTPRINT / 2 - COLLISION_MARGIN
    # link 1 core, in its own frame: x ∈ [−overhang, length] shrunk by the margin, centred at cx
    half_x = link.box_length / 2 - COLLISION_MARGIN
    half_y = LINK_WIDTH / 2 - COLLISION_MARGIN
    cx = link.box_origin
    q = joint_angles[..., 0]
    c, s = xp.cos(q), xp.sin(q)
    best = None
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            # a block corner, in link 1's frame
            bx, by = ox + sx * block_half, oy + sy * block_half
            lx, ly = c * bx + s * by - cx, -s * bx + c * by
            d_block_corner = _point_to_box(lx, ly, half_x, half_y, xp)
            # a link corner, in the block's (axis-aligned) frame
            ax, ay = cx + sx * half_x, sy * half_y
            wx, wy = c * ax - s * ay - ox, s * ax + c * ay - oy
            d_link_corner = _point_to_box(wx, wy, block_half, block_half, xp)
            pair = xp.minimum(d_block_corner, d_link_corner)
            best = pair if best is None else xp.minimum(best, pair)
    return xp.clip(best - 2 * COLLISION_MARGIN, 0.0, None)
