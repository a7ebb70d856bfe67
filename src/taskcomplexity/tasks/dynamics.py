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
from typing import NamedTuple

import numba
import numpy as np

from taskcomplexity.tasks import contact
from taskcomplexity.tasks.urdf import LinkDynamics

LINK_DAMPING = 0.04  # btMultiBody default m_linearDamping = m_angularDamping
MAX_COORDINATE_VELOCITY = 100.0  # btMultiBody default m_maxCoordinateVelocity, rad/s


class ArmParams(NamedTuple):
    """The kernels' record of an arm's physical parameters (floats; a 1-link arm's link-2 fields are 0).

    numba passes a tuple of floats by value: the compiler keeps the fields in registers across the
    physics loop (read from an array, they would be reloaded after every store to the state arrays,
    which keeps the loop from being vectorised: ~5× slower for the 1-link arm).
    """

    dof: float
    """Number of links, 1 or 2."""
    link_damping: float
    """Bullet's link damping k (linear and angular), 1/s."""
    max_velocity: float
    """Bullet's clamp on every joint velocity, rad/s."""
    mass1: float
    """Upper arm (link 1) mass, kg."""
    com1: float
    """Link 1 centre of mass along its axis from the shoulder, m."""
    inertia1: float
    """Link 1 inertia about z through its centre of mass, kg·m²."""
    joint_damping1: float
    """Shoulder joint damping, N·m·s/rad."""
    length1: float
    """Shoulder to elbow (link 1's next joint), m; 0 for a 1-link arm."""
    mass2: float = 0.0
    """Forearm (link 2) mass, kg."""
    com2: float = 0.0
    """Link 2 centre of mass along its axis from the elbow, m (0: on the elbow, M constant)."""
    inertia2: float = 0.0
    """Link 2 inertia about z through its centre of mass, kg·m²."""
    joint_damping2: float = 0.0
    """Elbow joint damping, N·m·s/rad."""


@dataclass(frozen=True)
class ArmDynamics:
    """Physical parameters of a planar chain of one or two links (read from its URDF)."""

    links: tuple[LinkDynamics, ...]
    link_damping: float = LINK_DAMPING
    max_velocity: float = MAX_COORDINATE_VELOCITY

    def params(self) -> ArmParams:
        """The kernels' :class:`ArmParams` record."""
        first = self.links[0]
        values = [float(len(self.links)), self.link_damping, self.max_velocity, first.mass, first.com,
                  first.inertia_zz, first.joint_damping, first.next_joint]
        if len(self.links) == 2:
            second = self.links[1]
            values += [second.mass, second.com, second.inertia_zz, second.joint_damping]
        return ArmParams(*(float(v) for v in values))

    def mass_matrix(self, q2: float = 0.0) -> np.ndarray:
        """Joint-space mass matrix (kg·m²) at elbow angle ``q2`` (ignored for one link)."""
        out = np.zeros((len(self.links), len(self.links)))
        _mass_matrix(self.params(), q2, out)
        return out


@numba.njit(cache=True)
def _mass_matrix(p, q2, out):
    m1, c1, i1 = p.mass1, p.com1, p.inertia1
    if p.dof == 1:
        out[0, 0] = i1 + m1 * c1 * c1
        return
    l1 = p.length1
    m2, c2, i2 = p.mass2, p.com2, p.inertia2
    cq = np.cos(q2)
    out[0, 0] = i1 + m1 * c1 * c1 + i2 + m2 * (l1 * l1 + c2 * c2 + 2.0 * l1 * c2 * cq)
    out[0, 1] = i2 + m2 * (c2 * c2 + l1 * c2 * cq)
    out[1, 0] = out[0, 1]
    out[1, 1] = i2 + m2 * c2 * c2


@numba.njit(cache=True)
def _one_link_step(p, q, qd, tau, dt):
    k, vmax = p.link_damping, p.max_velocity
    m, c, inertia, b = p.mass1, p.com1, p.inertia1, p.joint_damping1
    v = c * qd
    force = tau - b * qd - inertia * qd * (k + k * abs(qd)) - c * m * v * (k + k * abs(v))
    qd = qd + dt * force / (inertia + m * c * c)
    qd = min(max(qd, -vmax), vmax)
    return q + dt * qd, qd


@numba.njit(cache=True)
def _two_link_step(p, q1, q2, u, qd2, tau1, tau2, dt):
    k, vmax = p.link_damping, p.max_velocity
    m1, c1, i1, b1, l1 = p.mass1, p.com1, p.inertia1, p.joint_damping1, p.length1
    m2, c2, i2, b2 = p.mass2, p.com2, p.inertia2, p.joint_damping2
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


@numba.njit(cache=True)
def _two_link_step_const(p, inv, q1, q2, u, qd2, tau1, tau2, dt):
    """:func:`_two_link_step` for a forearm whose centre of mass is on the elbow (M constant).

    ``inv`` holds M⁻¹ as (inv11, inv12, inv22); the arithmetic is otherwise the same.
    """
    k, vmax = p.link_damping, p.max_velocity
    m1, c1, i1, b1, l1 = p.mass1, p.com1, p.inertia1, p.joint_damping1, p.length1
    m2, i2, b2 = p.mass2, p.inertia2, p.joint_damping2
    w = u + qd2
    ang = i2 * w * (k + k * abs(w))
    f1 = tau1 - b1 * u - i1 * u * (k + k * abs(u)) - m1 * c1 * c1 * u * (k + k * abs(c1 * u)) - ang
    f1 -= m2 * l1 * l1 * u * (k + k * abs(l1 * u))
    f2 = tau2 - b2 * qd2 - ang
    u = min(max(u + dt * (inv[0] * f1 + inv[1] * f2), -vmax), vmax)
    qd2 = min(max(qd2 + dt * (inv[1] * f1 + inv[2] * f2), -vmax), vmax)
    return q1 + dt * u, q2 + dt * qd2, u, qd2


BLOCK = 256  # environments advanced in lock-step, so the compiler can interleave (and vectorise) them
VECTOR = 8
"""Environments per vector of the compiled loops: 8 float64 in an AVX-512 register, 2 × 4 with AVX2. A loop over
n environments runs its vector body on whole vectors and leaves a slower scalar remainder; the kernels round a
block up to whole vectors where the extra environments cost nothing but their arithmetic."""


@numba.njit(cache=True)
def whole_vectors(n):
    """n rounded up to whole :data:`VECTOR` s."""
    return (n + VECTOR - 1) // VECTOR * VECTOR


@numba.njit(cache=True)
def row_length(n):
    """Row length (float64 values) of a work array with a row per quantity and n environment columns: whole
    vectors, and an odd number of them. Rows of 2 KiB (256 columns) put every other row 4 KiB apart, where the
    CPU takes loads for stores to the same address (4K aliasing): the forward pass of a 256-environment block
    ran 15–40 % slower than with 264-value rows (one thread, side by side)."""
    columns = whole_vectors(n)
    return columns + VECTOR if columns // VECTOR % 2 == 0 else columns



@numba.njit(cache=True)
def inverse_mass_matrix(params):
    """M⁻¹ of an arm whose forearm centre of mass is on the elbow, as (inv11, inv12, inv22)."""
    inv = np.zeros(3)
    if params.dof == 2 and params.com2 == 0.0:
        m1, c1, i1, l1 = params.mass1, params.com1, params.inertia1, params.length1
        m2, i2 = params.mass2, params.inertia2
        a11, a12, a22 = i1 + m1 * c1 * c1 + i2 + m2 * l1 * l1, i2, i2
        det = a11 * a22 - a12 * a12
        inv[0], inv[1], inv[2] = a22 / det, -a12 / det, a11 / det
    return inv


@numba.njit(cache=True)
def _inverse_at(params, const_inv, q2):
    """M⁻¹ at elbow angle q2 as (inv11, inv12, inv22) (``const_inv`` when M is constant)."""
    if params.com2 == 0.0:
        return const_inv
    m = np.empty((2, 2))
    _mass_matrix(params, q2, m)
    det = m[0, 0] * m[1, 1] - m[0, 1] * m[0, 1]
    return np.array([m[1, 1] / det, -m[0, 1] / det, m[0, 0] / det])


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def integrate_block(params, inv, a1, a2, u, v, t1, t2, dt, substeps, zone, touched):
    """One environment step of n environments in lock-step, in place on length-n arrays.

    ``a1, a2`` joint angles, ``u, v`` joint velocities, ``t1, t2`` torques of the first physics step
    (``a2, v, t2`` unused by a 1-link arm). ``zone`` (:func:`contact_zone`) selects what happens near
    the block: mode NO_CONTACT, no block; HANDOVER, ``touched[j]`` is set when environment j's
    forearm enters the block's contact zone (for a hand-over); MODEL, contacts act
    (:mod:`taskcomplexity.tasks.contact`) and ``touched[j]`` is set when one did.

    Every physics step is a contact-free step of all n environments, then a cheap test of which
    elbows are within reach of the block, then the exact work for those few.
    """
    n = a1.shape[0]
    two_links = params.dof == 2
    const = two_links and params.com2 == 0.0
    mode = zone.mode if two_links else contact.NO_CONTACT
    model, handover = mode == contact.MODEL, mode == contact.HANDOVER
    l1 = params.length1
    b1, b2 = np.empty(n if model else 0), np.empty(n if model else 0)
    reach = np.zeros(n if model or handover else 0, dtype=np.bool_)
    was = np.zeros(n if model else 0, dtype=np.bool_)  # block contact at the previous physics step
    points, ends, rows, impulse = contact.scratch()
    for s in range(substeps):
        on = 1.0 if s == 0 else 0.0  # the torque acts in the first physics step only
        if model:  # detection happens at the physics step's starting pose
            b1[:] = a1
            b2[:] = a2
            for j in range(n):
                reach[j] = contact.in_reach(zone, a1[j])
        _free_step(params, inv, const, two_links, a1, a2, u, v, t1, t2, on, dt)
        if handover:
            for j in range(n):
                reach[j] = contact.in_reach(zone, a1[j])
            for j in range(n):
                if reach[j] and not touched[j]:
                    touched[j] = contact.near_block(zone, l1, a1[j], a2[j])
        elif model:
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
CONTACT_MODES = {"pybullet": contact.HANDOVER, "model": contact.MODEL}


def contact_zone(task, contacts: str = "pybullet") -> contact.ContactZone:
    """Kernel record of the forearm–block contact (:class:`taskcomplexity.tasks.contact.ContactZone`).

    ``contacts`` is ``"pybullet"`` (mode HANDOVER: flag the environments whose forearm enters the
    contact zone, for a hand-over to PyBullet) or ``"model"`` (mode MODEL: contacts act, as
    :mod:`~taskcomplexity.tasks.contact` models them); a task without a block gets
    :func:`~taskcomplexity.tasks.contact.no_contact`. The forearm box spans x ∈ [x₀, x₁] = [−overhang,
    length] along its axis from the elbow; the zone radius bounds the box's half-diagonal section
    plus the block's half-diagonal plus PyBullet's contact breaking threshold (0.02 m), so every
    physical contact of the two boxes is inside it.
    """
    from taskcomplexity.tasks.mechanics import BLOCK_FOOTPRINT, BLOCK_LENGTH
    from taskcomplexity.tasks.pybullet_env import ARM_BASE_POSITION
    from taskcomplexity.tasks.spec import LINK_OVERHANG, LINK_WIDTH

    obstacle = task.arm.obstacle
    if obstacle is None:
        return contact.no_contact()
    if contacts not in CONTACT_MODES:
        raise ValueError(f"contacts must be one of {list(CONTACT_MODES)}, got {contacts!r}")
    half_side = obstacle.scale * BLOCK_FOOTPRINT / 2
    ox, oy = obstacle.position
    radius = LINK_WIDTH / 2 * np.sqrt(2) + half_side * np.sqrt(2) + CONTACT_BREAKING_THRESHOLD + 0.005
    base_z = ARM_BASE_POSITION[2]
    block_half_height = obstacle.scale * BLOCK_LENGTH / 2
    z_overlap = min(base_z + LINK_WIDTH / 2, obstacle.height + block_half_height) - max(
        base_z - LINK_WIDTH / 2, obstacle.height - block_half_height
    )
    # the elbow (at l₁ from the shoulder) must be within reach of the block: the law of cosines
    # bounds |q₁ − block angle| (plus a hair for rounding)
    l1, rho = task.arm.links[0].length, float(np.hypot(*obstacle.position))
    reach = max(LINK_OVERHANG, task.arm.links[1].length) + radius
    cosine = (l1 * l1 + rho * rho - reach * reach) / (2 * l1 * rho)
    block_angle = float(np.arctan2(obstacle.position[1], obstacle.position[0]))
    window = float(np.arccos(cosine)) + 1e-6 if cosine > -1.0 else 4.0
    return contact.ContactZone(
        mode=CONTACT_MODES[contacts], ox=float(ox), oy=float(oy), x0=-LINK_OVERHANG,
        x1=float(task.arm.links[1].length), radius=float(radius), half_side=float(half_side),
        half_width=LINK_WIDTH / 2, z_overlap=float(z_overlap), erp=contact.CONTACT_ERP, slop=contact.LINEAR_SLOP,
        mu=contact.LINK_FRICTION * contact.BLOCK_FRICTION, iterations=float(contact.SOLVER_ITERATIONS),
        residual=contact.RESIDUAL_THRESHOLD, block_angle=block_angle, window=window,
        single_fresh=contact.P_SINGLE_FRESH, single_continuing=contact.P_SINGLE_CONTINUING,
        cones=np.ascontiguousarray(_pointing_cones(l1, obstacle.position, block_angle, window, float(radius))),
    )


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
