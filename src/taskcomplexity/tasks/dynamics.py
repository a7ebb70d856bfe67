"""Batched planar-arm dynamics, integrated the way PyBullet's Featherstone multibody does it.

One environment step = ``substeps`` physics steps; the joint torque acts in the first only (PyBullet
clears ``TORQUE_CONTROL`` torques after every ``stepSimulation``). Each physics step is Bullet's
semi-implicit Euler: q̈ = M(q)⁻¹ (τ − b⊙q̇ − D(q, q̇) − C(q, q̇)), q̇ ← clamp(q̇ + dt·q̈, ±100), q ← q + dt·q̇.

- M: joint-space mass matrix of a 1- or 2-link planar chain with centres of mass on the link axes.
- b: URDF joint damping (PyBullet adds −b·q̇ as a joint torque before each physics step).
- D: Bullet's default link damping, for every link a force m·v·(k₁ + k₂‖v‖) at the centre of mass and
  a torque I·ω·(k₁ + k₂|ω|), with k₁ = k₂ = 0.04 (linear and angular), mapped to joint space by the
  link Jacobians.
- C: Coriolis and centrifugal terms (zero for the reference 2-link arm, whose centres of mass sit on
  their joints, so that M is constant).
- Bullet clamps every generalised velocity to ±100 (``m_maxCoordinateVelocity``).

The inner loop (:func:`integrate_block`) runs inside the batched backend's fused numba step kernel
(:mod:`taskcomplexity.tasks.step_kernel`): at the paper's scale (2.5·10⁸ environment steps × 51
physics steps per task) element-wise tensor operations would spend their time moving memory.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from taskcomplexity.tasks import contact
from taskcomplexity.tasks.urdf import LinkDynamics

LINK_DAMPING = 0.04  # btMultiBody default m_linearDamping = m_angularDamping
MAX_COORDINATE_VELOCITY = 100.0  # btMultiBody default m_maxCoordinateVelocity, rad/s


@dataclass(frozen=True)
class ArmDynamics:
    """Physical parameters of a planar chain, as a flat float64 vector for the kernel.

    Layout: ``[dof, k, vmax, (mass, com, inertia_zz, joint_damping, next_joint) per link]``.
    """

    links: tuple[LinkDynamics, ...]
    link_damping: float = LINK_DAMPING
    max_velocity: float = MAX_COORDINATE_VELOCITY

    def vector(self) -> np.ndarray:
        values = [float(len(self.links)), self.link_damping, self.max_velocity]
        for link in self.links:
            values += [link.mass, link.com, link.inertia_zz, link.joint_damping, link.next_joint]
        return np.asarray(values, dtype=np.float64)

    def mass_matrix(self, q2: float = 0.0) -> np.ndarray:
        """Joint-space mass matrix (kg·m²) at elbow angle ``q2`` (ignored for one link)."""
        out = np.zeros((len(self.links), len(self.links)))
        _mass_matrix(self.vector(), q2, out)
        return out


@numba.njit(cache=True, inline="always")
def _mass_matrix(p, q2, out):
    m1, c1, i1 = p[3], p[4], p[5]
    if p[0] == 1:
        out[0, 0] = i1 + m1 * c1 * c1
        return
    l1 = p[7]
    m2, c2, i2 = p[8], p[9], p[10]
    cq = np.cos(q2)
    out[0, 0] = i1 + m1 * c1 * c1 + i2 + m2 * (l1 * l1 + c2 * c2 + 2.0 * l1 * c2 * cq)
    out[0, 1] = i2 + m2 * (c2 * c2 + l1 * c2 * cq)
    out[1, 0] = out[0, 1]
    out[1, 1] = i2 + m2 * c2 * c2


@numba.njit(cache=True, inline="always")
def _one_link_step(p, q, qd, tau, dt):
    k, vmax = p[1], p[2]
    m, c, inertia, b = p[3], p[4], p[5], p[6]
    v = c * qd
    force = tau - b * qd - inertia * qd * (k + k * abs(qd)) - c * m * v * (k + k * abs(v))
    qd = qd + dt * force / (inertia + m * c * c)
    qd = min(max(qd, -vmax), vmax)
    return q + dt * qd, qd


@numba.njit(cache=True, inline="always")
def _two_link_step(p, q1, q2, u, qd2, tau1, tau2, dt):
    k, vmax = p[1], p[2]
    m1, c1, i1, b1, l1 = p[3], p[4], p[5], p[6], p[7]
    m2, c2, i2, b2 = p[8], p[9], p[10], p[11]
    w = u + qd2  # absolute angular velocity of the forearm
    # link 1: torque about its centre of mass and force at it
    f1 = tau1 - b1 * u - i1 * u * (k + k * abs(u)) - m1 * c1 * c1 * u * (k + k * abs(c1 * u))
    f2 = tau2 - b2 * qd2
    # link 2: angular damping acts on both joints
    ang = i2 * w * (k + k * abs(w))
    f1 -= ang
    f2 -= ang
    if c2 == 0.0:
        # centre of mass on the elbow: v = l1·u·e⊥(q1), M constant, no Coriolis terms
        f1 -= m2 * l1 * l1 * u * (k + k * abs(l1 * u))
        a11 = i1 + m1 * c1 * c1 + i2 + m2 * l1 * l1
        a12 = i2
        a22 = i2
    else:
        cq, sq = np.cos(q2), np.sin(q2)
        # link 2: linear damping of its centre of mass, v = l1·u·e⊥(q1) + c2·w·e⊥(q1+q2)
        speed = np.sqrt(l1 * l1 * u * u + c2 * c2 * w * w + 2.0 * l1 * c2 * u * w * cq)
        s = m2 * (k + k * speed)
        along1 = l1 * u + c2 * w * cq  # v · e⊥(q1)
        along12 = l1 * u * cq + c2 * w  # v · e⊥(q1+q2)
        f1 -= s * (l1 * along1 + c2 * along12)
        f2 -= s * c2 * along12
        # Coriolis and centrifugal terms
        h = m2 * l1 * c2 * sq
        f1 += h * (2.0 * u * qd2 + qd2 * qd2)
        f2 -= h * u * u
        a11 = i1 + m1 * c1 * c1 + i2 + m2 * (l1 * l1 + c2 * c2 + 2.0 * l1 * c2 * cq)
        a12 = i2 + m2 * (c2 * c2 + l1 * c2 * cq)
        a22 = i2 + m2 * c2 * c2
    det = a11 * a22 - a12 * a12
    acc1 = (a22 * f1 - a12 * f2) / det
    acc2 = (a11 * f2 - a12 * f1) / det
    u = min(max(u + dt * acc1, -vmax), vmax)
    qd2 = min(max(qd2 + dt * acc2, -vmax), vmax)
    return q1 + dt * u, q2 + dt * qd2, u, qd2


@numba.njit(cache=True, inline="always")
def _two_link_step_const(p, inv, q1, q2, u, qd2, tau1, tau2, dt):
    """:func:`_two_link_step` for a forearm whose centre of mass is on the elbow (M constant).

    ``inv`` holds M⁻¹ as (inv11, inv12, inv22); the arithmetic is otherwise the same.
    """
    k, vmax = p[1], p[2]
    m1, c1, i1, b1, l1 = p[3], p[4], p[5], p[6], p[7]
    m2, i2, b2 = p[8], p[10], p[11]
    w = u + qd2
    ang = i2 * w * (k + k * abs(w))
    f1 = tau1 - b1 * u - i1 * u * (k + k * abs(u)) - m1 * c1 * c1 * u * (k + k * abs(c1 * u)) - ang
    f1 -= m2 * l1 * l1 * u * (k + k * abs(l1 * u))
    f2 = tau2 - b2 * qd2 - ang
    u = min(max(u + dt * (inv[0] * f1 + inv[1] * f2), -vmax), vmax)
    qd2 = min(max(qd2 + dt * (inv[1] * f1 + inv[2] * f2), -vmax), vmax)
    return q1 + dt * u, q2 + dt * qd2, u, qd2


BLOCK = 256  # environments advanced in lock-step, so the compiler can interleave (and vectorise) them


@numba.njit(cache=True)
def inverse_mass_matrix(params):
    """M⁻¹ of an arm whose forearm centre of mass is on the elbow, as (inv11, inv12, inv22)."""
    inv = np.zeros(3)
    if params[0] == 2 and params[9] == 0.0:
        m1, c1, i1, l1, m2, i2 = params[3], params[4], params[5], params[7], params[8], params[10]
        a11, a12, a22 = i1 + m1 * c1 * c1 + i2 + m2 * l1 * l1, i2, i2
        det = a11 * a22 - a12 * a12
        inv[0], inv[1], inv[2] = a22 / det, -a12 / det, a11 / det
    return inv


@numba.njit(cache=True, inline="always")
def _inverse_at(params, const_inv, q2):
    """M⁻¹ at elbow angle q2 as (inv11, inv12, inv22) (``const_inv`` when M is constant)."""
    if params[9] == 0.0:
        return const_inv
    m = np.empty((2, 2))
    _mass_matrix(params, q2, m)
    det = m[0, 0] * m[1, 1] - m[0, 1] * m[0, 1]
    return np.array([m[1, 1] / det, -m[0, 1] / det, m[0, 0] / det])


@numba.njit(cache=True, inline="always")
def _free_step(params, inv, const, two_links, a1, a2, u, v, t1, t2, on, dt):
    """One contact-free physics step of every environment of the block (a loop the compiler vectorises)."""
    n = a1.shape[0]
    if const:
        for j in range(n):
            a1[j], a2[j], u[j], v[j] = _two_link_step_const(params, inv, a1[j], a2[j], u[j], v[j], on * t1[j],
                                                            on * t2[j], dt)
    elif two_links:
        for j in range(n):
            a1[j], a2[j], u[j], v[j] = _two_link_step(params, a1[j], a2[j], u[j], v[j], on * t1[j], on * t2[j], dt)
    else:
        for j in range(n):
            a1[j], u[j] = _one_link_step(params, a1[j], u[j], on * t1[j], dt)


@numba.njit(cache=True, inline="always")
def integrate_block(params, inv, a1, a2, u, v, t1, t2, dt, substeps, zone, touched):
    """One environment step of n environments in lock-step, in place on length-n arrays.

    ``a1, a2`` joint angles, ``u, v`` joint velocities, ``t1, t2`` torques of the first physics step
    (``a2, v, t2`` unused by a 1-link arm). ``zone`` (:func:`contact_zone`) selects what happens near
    the block: mode 0, no block; mode 1, ``touched[j]`` is set when environment j's forearm enters the
    block's contact zone (for a hand-over); mode 2, contacts act (:mod:`taskcomplexity.tasks.contact`)
    and ``touched[j]`` is set when one did.

    Every physics step is a contact-free step of all n environments, then a cheap test of which
    elbows are within reach of the block, then the exact work for those few.
    """
    n = a1.shape[0]
    two_links = params[0] == 2
    const = two_links and params[9] == 0.0
    mode = int(zone[0]) if two_links else 0
    l1 = params[7]
    b1, b2 = np.empty(n if mode == 2 else 0), np.empty(n if mode == 2 else 0)
    reach = np.zeros(n if mode > 0 else 0, dtype=np.bool_)
    was = np.zeros(n if mode == 2 else 0, dtype=np.bool_)  # block contact at the previous physics step
    points, ends, rows, impulse = contact.scratch()
    for s in range(substeps):
        on = 1.0 if s == 0 else 0.0  # the torque acts in the first physics step only
        if mode == 2:  # detection happens at the physics step's starting pose
            b1[:] = a1
            b2[:] = a2
            for j in range(n):
                reach[j] = contact.in_reach(zone, a1[j])
        _free_step(params, inv, const, two_links, a1, a2, u, v, t1, t2, on, dt)
        if mode == 1:
            for j in range(n):
                reach[j] = contact.in_reach(zone, a1[j])
            for j in range(n):
                if reach[j] and not touched[j]:
                    touched[j] = contact.near_block(zone, l1, a1[j], a2[j])
        elif mode == 2:
            for j in range(n):
                if not reach[j] or not contact.near_block(zone, l1, b1[j], b2[j]):
                    was[j] = False
                    continue
                count, nx, ny = contact.detect(zone, l1, b1[j], b2[j], points, ends)
                if count == 0:
                    was[j] = False
                    continue
                touched[j] = True
                single = contact.single_sweep(zone, not was[j], b1[j], b2[j])
                was[j] = True
                u[j], v[j] = contact.solve(
                    zone, l1, b1[j], _inverse_at(params, inv, b2[j]), u[j], v[j], points, count, nx, ny, dt, rows,
                    impulse, single,
                )
                a1[j], a2[j] = b1[j] + dt * u[j], b2[j] + dt * v[j]


CONTACT_BREAKING_THRESHOLD = 0.02  # PyBullet's default, m
CONTACT_MODES = {"pybullet": 1.0, "model": 2.0}
NO_OBSTACLE = np.zeros(contact.SIZE)


def contact_zone(task, contacts: str = "pybullet") -> np.ndarray:
    """Kernel parameters of the forearm–block contact (layout: :mod:`taskcomplexity.tasks.contact`).

    ``contacts`` is ``"pybullet"`` (mode 1: flag the environments whose forearm enters the contact
    zone, for a hand-over to PyBullet) or ``"model"`` (mode 2: contacts act, as
    :mod:`~taskcomplexity.tasks.contact` models them). The forearm box spans x ∈ [x₀, x₁] = [−overhang,
    length] along its axis from the elbow; the zone radius bounds the box's half-diagonal section
    plus the block's half-diagonal plus PyBullet's contact breaking threshold (0.02 m), so every
    physical contact of the two boxes is inside it.
    """
    from taskcomplexity.tasks.mechanics import BLOCK_FOOTPRINT, BLOCK_LENGTH
    from taskcomplexity.tasks.pybullet_env import ARM_BASE_POSITION
    from taskcomplexity.tasks.spec import LINK_OVERHANG, LINK_WIDTH

    obstacle = task.arm.obstacle
    if obstacle is None:
        return NO_OBSTACLE
    if contacts not in CONTACT_MODES:
        raise ValueError(f"contacts must be one of {list(CONTACT_MODES)}, got {contacts!r}")
    zone = np.zeros_like(NO_OBSTACLE)
    half_side = obstacle.scale * BLOCK_FOOTPRINT / 2
    zone[contact.MODE] = CONTACT_MODES[contacts]
    zone[contact.OX], zone[contact.OY] = obstacle.position
    zone[contact.X0], zone[contact.X1] = -LINK_OVERHANG, task.arm.links[1].length
    radius = LINK_WIDTH / 2 * np.sqrt(2) + half_side * np.sqrt(2) + CONTACT_BREAKING_THRESHOLD + 0.005
    zone[contact.ZONE_RADIUS] = radius
    zone[contact.HALF_SIDE] = half_side
    zone[contact.HALF_WIDTH] = LINK_WIDTH / 2
    base_z = ARM_BASE_POSITION[2]
    block_half_height = obstacle.scale * BLOCK_LENGTH / 2
    zone[contact.Z_OVERLAP] = min(base_z + LINK_WIDTH / 2, obstacle.height + block_half_height) - max(
        base_z - LINK_WIDTH / 2, obstacle.height - block_half_height
    )
    zone[contact.ERP] = contact.CONTACT_ERP
    zone[contact.SLOP] = contact.LINEAR_SLOP
    zone[contact.MU] = contact.LINK_FRICTION * contact.BLOCK_FRICTION
    zone[contact.ITERATIONS] = contact.SOLVER_ITERATIONS
    zone[contact.RESIDUAL] = contact.RESIDUAL_THRESHOLD
    zone[contact.SINGLE_FRESH] = contact.P_SINGLE_FRESH
    zone[contact.SINGLE_CONTINUING] = contact.P_SINGLE_CONTINUING
    # the elbow (at l₁ from the shoulder) must be within reach of the block: the law of cosines
    # bounds |q₁ − block angle| (plus a hair for rounding)
    l1, rho = task.arm.links[0].length, float(np.hypot(*obstacle.position))
    reach = max(LINK_OVERHANG, task.arm.links[1].length) + radius
    cosine = (l1 * l1 + rho * rho - reach * reach) / (2 * l1 * rho)
    zone[contact.BLOCK_ANGLE] = float(np.arctan2(obstacle.position[1], obstacle.position[0]))
    zone[contact.WINDOW] = float(np.arccos(cosine)) + 1e-6 if cosine > -1.0 else 4.0
    zone[contact.CONE :] = _pointing_cones(l1, obstacle.position, zone[contact.BLOCK_ANGLE], zone[contact.WINDOW],
                                           radius).ravel()
    return zone


def _pointing_cones(l1: float, block, angle: float, window: float, radius: float) -> np.ndarray:
    """Per bin of elbow angle q₁ ∈ angle ± window: (centre, half-width) of the forearm directions q₁ + q₂
    for which the block can be within ``radius`` of the forearm (a conservative table).

    From an elbow at e, a point on the forearm's ray within ``radius`` of the block o requires the ray
    to deviate from the direction of o − e by at most asin(radius/|o − e|). Each bin takes the hull of
    that cone over 33 elbow angles across the bin, widened by the largest change between two of them.
    """
    bins = contact.CONE_BINS
    edges = angle - window + 2 * window * np.arange(bins + 1) / bins
    q = edges[:-1, None] + (edges[1:] - edges[:-1])[:, None] * np.linspace(0.0, 1.0, 33)[None, :]
    rx, ry = block[0] - l1 * np.cos(q), block[1] - l1 * np.sin(q)
    distance = np.hypot(rx, ry)
    if (distance <= radius).any():  # the elbow itself can be inside the zone: no pruning
        return np.tile([0.0, 4.0], (bins, 1))
    direction = np.unwrap(np.arctan2(ry, rx), axis=1)
    half = np.arcsin(radius / distance)
    slack = np.abs(np.diff(direction, axis=1)).max(axis=1) + np.abs(np.diff(half, axis=1)).max(axis=1) + 1e-6
    low, high = (direction - half).min(axis=1) - slack, (direction + half).max(axis=1) + slack
    return np.stack([(low + high) / 2, (high - low) / 2], axis=1)
