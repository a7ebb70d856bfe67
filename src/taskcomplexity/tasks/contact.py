"""The forearm–block contact of the obstacle task, modelled the way Bullet's multibody solver does it.

PyBullet's response to the forearm striking the block is chaotic (perturbing the joint angles by
1e-12 rad changes its own returns), so no second implementation follows it episode by episode. This
model reproduces the mechanism, and with it the distribution of outcomes (tested against PyBullet in
``tests/tasks/test_contact.py``). Per physics step, from joint angles q and velocities v:

1. **Detection at the step's starting pose** (Bullet's box–box test, in the arm's plane): the
   forearm box (centre e + ½(x₀ + x₁)·u, half extents ½(x₁ − x₀) × ½w, u = (cos φ, sin φ), φ = q₁ + q₂,
   e the elbow) against the block's square (half side b, centre o). Separating axes u, u⊥, x̂, ŷ: no
   overlap on any of them, no contact (Bullet creates no contact at a positive distance). The axis
   of least overlap gives the normal n (from the block to the arm) unless the vertical overlap of the
   two boxes is smaller (a vertical normal does not act on revolute-z joints). The incident face of
   the other box, clipped to the reference face, gives ≤ 2 points p with penetration depths.
2. **Free velocity** v′ = v + dt·M⁻¹(τ − damping) (:mod:`taskcomplexity.tasks.dynamics`).
3. **Contact solve on v′**, projected Gauss–Seidel as Bullet's sequential-impulse solver: per point a
   normal row J_n = [n·p⊥, n·(p − e)⊥] (r⊥ = (−r_y, r_x)) with λ_n ≥ 0 and target velocity
   −erp·δ/dt for penetration δ = d + slop ≤ 0 (−δ/dt for δ > 0), restitution 0; then a friction row
   along t = n⊥ with |λ_t| ≤ μ·λ_n (μ = product of the two bodies' lateral frictions). Each impulse
   changes v by M⁻¹Jᵀλ. Sweeps stop after ``iterations`` or when the squared velocity residual of a
   sweep falls under Bullet's threshold — or after the first sweep where PyBullet stops there: when
   the forearm's flickering contact with the ground plane shares the solve (:func:`single_sweep`).
4. q ← q + dt·v″.

Parameters are PyBullet's in this world: ERP 0.08, linear slop 1e-5, 50 solver iterations, residual
threshold 1e-7, lateral frictions 0.5 (link) × 1.0 (block).
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

CONTACT_ERP = 0.08  # solverInfo.m_erp2 as PyBullet sets it
LINEAR_SLOP = 1e-5  # solverInfo.m_linearSlop as PyBullet sets it, m
SOLVER_ITERATIONS = 50  # PyBullet's numSolverIterations
RESIDUAL_THRESHOLD = 1e-7  # PyBullet's solverResidualThreshold (squared velocity residual of a sweep)
LINK_FRICTION = 0.5  # PyBullet's default lateral friction of a URDF link without <contact>
BLOCK_FRICTION = 1.0  # pybullet_data block.urdf's lateral friction
# Bullet's solver stops after its first sweep when the forearm's (inert) contact with the ground plane is in
# the same solve (see single_sweep). The rates are measured on PyBullet 3.2.7 by bench/calibrate_contacts.py
# (`make calibrate-contacts`; tests/rwg/test_contact_calibration.py holds them within 3 standard errors):
# in random-policy episodes of two_link_obstacle-dense (N = 300 × M = 5, seed 0) the plane contact is
# present at 46–49 % of the steps where one sweep and convergence differ; a sweep-1 exit follows at 75 % of
# those where the block contact is new (no overlap at the previous physics step) and at 3.8 % of the others,
# never without the plane: 0.349 ± 0.010 (848 of 2 433 steps) and 0.019 ± 0.001 (353 of 18 367). The
# earlier 0.415 (48 % × 86 %) could not be re-derived; the same measurement gives 0.41 ± 0.02 (48 %, 86 %)
# only with the action's torque applied twice in its first physics step.
P_SINGLE_FRESH = 0.349
P_SINGLE_CONTINUING = 0.019

CONE_BINS = 256  # bins of elbow angle in the table of forearm directions (see near_block)
NO_CONTACT, HANDOVER, MODEL = 0.0, 1.0, 2.0  # ContactZone.mode


class ContactZone(NamedTuple):
    """The kernels' record of the forearm–block contact (built by
    :func:`taskcomplexity.tasks.dynamics.contact_zone`; lengths in m, angles in rad).

    Scalars and the cone table in one record: every reader of the zone's geometry also reads the
    table (:func:`near_block`), and one argument keeps the kernels' signatures short. numba passes the
    record by value (the scalars as values, the table as an array view).
    """

    mode: float
    """NO_CONTACT (no block), HANDOVER (flag the environments that reach the block) or MODEL (contacts act)."""
    ox: float
    """Block centre x."""
    oy: float
    """Block centre y."""
    x0: float
    """Forearm box start along its axis from the elbow (−overhang)."""
    x1: float
    """Forearm box end along its axis from the elbow (its length)."""
    radius: float
    """Radius of the contact zone around the block."""
    half_side: float
    """Half side of the block's square footprint."""
    half_width: float
    """Half width of the forearm box."""
    z_overlap: float
    """Vertical overlap of the two boxes."""
    erp: float
    """Contact error reduction parameter."""
    slop: float
    """Linear slop, m."""
    mu: float
    """Friction coefficient (product of the two lateral frictions)."""
    iterations: float
    """Solver sweeps at most."""
    residual: float
    """Squared velocity residual under which the sweeps stop."""
    block_angle: float
    """Polar angle of the block."""
    window: float
    """|q₁ − block_angle| beyond which the elbow is out of reach."""
    single_fresh: float
    """Probability of a one-sweep solve when the block contact is new (see single_sweep)."""
    single_continuing: float
    """Probability of a one-sweep solve when the block contact continues."""
    cones: np.ndarray
    """(CONE_BINS, 2): per bin of q₁ over block_angle ± window, (centre, half-width) of the forearm
    directions q₁ + q₂ for which the forearm can be within ``radius`` of the block (see near_block)."""


def no_contact() -> ContactZone:
    """The zone of a task without a block (mode NO_CONTACT)."""
    return ContactZone(*([0.0] * (len(ContactZone._fields) - 1)), np.zeros((CONE_BINS, 2)))


@numba.njit(cache=True)
def scratch():
    """Work arrays of :func:`detect` and :func:`solve` (allocated once per block of environments)."""
    return np.empty((2, 3)), np.empty((2, 2)), np.empty((4, 6)), np.empty(4)


@numba.njit(cache=True)
def _clip(ax, ay, bx, by, cx, cy, tx, ty, half, out, count):
    """Clip segment a–b to the slab |(p − c)·t| ≤ half; append its ends to ``out`` (x, y rows)."""
    sa = (ax - cx) * tx + (ay - cy) * ty
    sb = (bx - cx) * tx + (by - cy) * ty
    if sa > sb:
        ax, ay, bx, by, sa, sb = bx, by, ax, ay, sb, sa
    if sb < -half or sa > half:
        return count
    for s in (max(sa, -half), min(sb, half)):
        f = 0.0 if sb == sa else (s - sa) / (sb - sa)
        out[count, 0] = ax + f * (bx - ax)
        out[count, 1] = ay + f * (by - ay)
        count += 1
    return count


@numba.njit(cache=True)
def detect(zone, l1, q1, q2, points, ends):
    """Contact points of the forearm box and the block at joint angles (q1, q2).

    Parameters
    ----------
    zone : ContactZone
        The contact record (:func:`taskcomplexity.tasks.dynamics.contact_zone`).
    l1 : float
        Upper-arm length (elbow distance from the shoulder), m.
    points : ndarray (2, 3), out
        Rows (x, y, d): contact point on the forearm (m) and signed distance d < 0 (−penetration, m),
        deepest first.
    ends : ndarray (2, 2)
        Work array.

    Returns
    -------
    count : int
        Number of points (0, 1 or 2).
    nx, ny : float
        Unit contact normal, from the block towards the arm.
    """
    ex, ey = l1 * np.cos(q1), l1 * np.sin(q1)
    ux, uy = np.cos(q1 + q2), np.sin(q1 + q2)
    wx, wy = -uy, ux
    hx = (zone.x1 - zone.x0) / 2
    hy = zone.half_width
    cx, cy = ex + ux * (zone.x0 + hx), ey + uy * (zone.x0 + hx)
    ox, oy, b = zone.ox, zone.oy, zone.half_side
    dx, dy = cx - ox, cy - oy
    best, kx, ky, arm_face = np.inf, 0.0, 0.0, False
    for axis in range(4):
        if axis == 0:
            ax, ay = ux, uy
        elif axis == 1:
            ax, ay = wx, wy
        elif axis == 2:
            ax, ay = 1.0, 0.0
        else:
            ax, ay = 0.0, 1.0
        ra = hx * abs(ux * ax + uy * ay) + hy * abs(wx * ax + wy * ay)
        overlap = ra + b * (abs(ax) + abs(ay)) - abs(dx * ax + dy * ay)
        if overlap <= 0.0:
            return 0, 0.0, 0.0  # separated
        if overlap < best:
            best, kx, ky, arm_face = overlap, ax, ay, axis < 2
    if best > zone.z_overlap:
        return 0, 0.0, 0.0  # the vertical axis overlaps least: a vertical normal, no joint effect
    if dx * kx + dy * ky <= 0.0:
        kx, ky = -kx, -ky
    nx, ny = kx, ky
    tx, ty = -ny, nx
    count = 0
    if arm_face:
        # reference: the forearm's face towards the block; incident: the block's face towards the arm
        ra_n = hx * abs(ux * nx + uy * ny) + hy * abs(wx * nx + wy * ny)
        ra_t = hx * abs(ux * tx + uy * ty) + hy * abs(wx * tx + wy * ty)
        if abs(nx) >= abs(ny):
            mx, my = (1.0 if nx > 0 else -1.0), 0.0
        else:
            mx, my = 0.0, (1.0 if ny > 0 else -1.0)
        px, py = ox + b * mx, oy + b * my
        n_ends = _clip(px - b * my, py + b * mx, px + b * my, py - b * mx, cx, cy, tx, ty, ra_t, ends, 0)
        for i in range(n_ends):
            pen = (ends[i, 0] - cx) * nx + (ends[i, 1] - cy) * ny + ra_n
            if pen > 0.0:
                points[count, 0] = ends[i, 0] - nx * pen
                points[count, 1] = ends[i, 1] - ny * pen
                points[count, 2] = -pen
                count += 1
    else:
        # reference: the block's face towards the arm; incident: the forearm face most against n
        best_dot = np.inf
        mx = my = hm = sx = sy = hs = 0.0
        for face in range(4):
            if face < 2:
                fx, fy, fh, gx, gy, gh = ux, uy, hx, wx, wy, hy
            else:
                fx, fy, fh, gx, gy, gh = wx, wy, hy, ux, uy, hx
            if face % 2 == 1:
                fx, fy = -fx, -fy
            dot = fx * nx + fy * ny
            if dot < best_dot:
                best_dot, mx, my, hm, sx, sy, hs = dot, fx, fy, fh, gx, gy, gh
        fx, fy = cx + hm * mx, cy + hm * my
        n_ends = _clip(fx + hs * sx, fy + hs * sy, fx - hs * sx, fy - hs * sy, ox, oy, tx, ty, b, ends, 0)
        for i in range(n_ends):
            pen = b - ((ends[i, 0] - ox) * nx + (ends[i, 1] - oy) * ny)
            if pen > 0.0:
                points[count, 0], points[count, 1], points[count, 2] = ends[i, 0], ends[i, 1], -pen
                count += 1
    if count == 2 and points[1, 2] < points[0, 2]:
        for c in range(3):
            points[0, c], points[1, c] = points[1, c], points[0, c]
    return count, nx, ny


@numba.njit(cache=True)
def solve(zone, l1, q1, inv, u, v, points, count, nx, ny, dt, rows, impulse, single=False):
    """Joint velocities after the contact impulses (step 3 of the module docstring).

    ``inv`` is M⁻¹ at this pose as (inv11, inv12, inv22); (u, v) the free joint velocities v′;
    ``rows`` (4, 6) and ``impulse`` (4,) are work arrays; ``single``: stop after the first sweep
    (:func:`single_sweep`). Returns (u″, v″).
    """
    ex, ey = l1 * np.cos(q1), l1 * np.sin(q1)
    tx, ty = -ny, nx
    # per row: J (2), M⁻¹Jᵀ (2), 1/(J M⁻¹ Jᵀ), target velocity
    for i in range(count):
        px, py = points[i, 0], points[i, 1]
        for r, (kx, ky) in enumerate(((nx, ny), (tx, ty))):
            row = rows[2 * i + r]
            row[0] = -kx * py + ky * px  # k · p⊥
            row[1] = -kx * (py - ey) + ky * (px - ex)  # k · (p − e)⊥
            row[2] = inv[0] * row[0] + inv[1] * row[1]
            row[3] = inv[1] * row[0] + inv[2] * row[1]
            row[4] = 1.0 / (row[0] * row[2] + row[1] * row[3])
        depth = points[i, 2] + zone.slop
        rows[2 * i, 5] = -depth / dt if depth > 0.0 else -zone.erp * depth / dt
    impulse[:] = 0.0
    du = dv = 0.0
    for _ in range(1 if single else int(zone.iterations)):
        residual = 0.0
        for friction in range(2):
            for i in range(count):
                k = 2 * i + friction
                row = rows[k]
                if friction:
                    limit = zone.mu * impulse[2 * i]
                    if limit <= 0.0:
                        continue
                    new = impulse[k] - (row[0] * (u + du) + row[1] * (v + dv)) * row[4]
                    new = min(max(new, -limit), limit)
                else:
                    new = max(0.0, impulse[k] + (row[5] - (row[0] * (u + du) + row[1] * (v + dv))) * row[4])
                change = new - impulse[k]
                impulse[k] = new
                du += row[2] * change
                dv += row[3] * change
                residual += (change / row[4]) ** 2
        if residual <= zone.residual:
            break
    return u + du, v + dv


@numba.njit(cache=True)
def single_sweep(zone, fresh, q1, q2):
    """Whether Bullet's solver would stop after one sweep at this physics step.

    The forearm's box rests exactly on the ground plane (its bottom face at z = 0), so Bullet keeps a
    contact manifold of four points at distance ±0 that flickers in and out with the rounding of the
    link's transform. When those points are in the solve and the block contact is new, PyBullet's
    result is exactly one sweep (normal rows, then friction rows), whatever numSolverIterations and
    solverResidualThreshold are: the block's normal impulse keeps its first-sweep value instead of
    being corrected for the friction impulse that followed it. With the plane removed PyBullet
    converges as :func:`solve` does. (Likely mechanism, not verified in Bullet's binary: the plane
    rows have a vertical normal, so J M⁻¹ Jᵀ = 0, and their 0/0 velocity residual is NaN, which
    ends the iteration loop, depending on where the rows fall in the solve order.) ``fresh``: the
    block had no contact at the previous physics step. The flicker is chaotic; a hash of the pose's
    low-order bits stands in for it.
    """
    x = np.sin(q1 * 12.9898 + q2 * 78.233) * 43758.5453
    x -= np.floor(x)
    return x < (zone.single_fresh if fresh else zone.single_continuing)


@numba.njit(cache=True)
def in_reach(zone, q1):
    """Whether the elbow, at shoulder angle q1, is within reach of the block (q₁ within the window)."""
    d = q1 - zone.block_angle
    d -= 2.0 * np.pi * np.floor(d * (0.5 / np.pi) + 0.5)
    return abs(d) <= zone.window


@numba.njit(cache=True)
def near_block(zone, l1, q1, q2):
    """Whether the forearm's box may be in contact range of the block (a conservative test).

    First without trigonometry: the elbow must lie within reach of the block, i.e. q₁ within
    ``zone.window`` of the block's polar angle, and the forearm must point at the block, i.e.
    q₁ + q₂ within the cone tabulated for that elbow angle; then the distance from the block to the
    forearm's axis segment against the zone radius.
    """
    # angles reduced to (−π, π] up to rounding, far below the tables' slack (multiplying, not dividing,
    # keeps this test cheap: it runs at every physics step)
    if not in_reach(zone, q1):
        return False
    window = zone.window
    d = q1 - zone.block_angle
    d -= 2.0 * np.pi * np.floor(d * (0.5 / np.pi) + 0.5)
    k = min(int((d + window) * (0.5 * CONE_BINS / window)), CONE_BINS - 1)
    a = q1 + q2 - zone.cones[k, 0]
    a -= 2.0 * np.pi * np.floor(a * (0.5 / np.pi) + 0.5)
    if abs(a) > zone.cones[k, 1]:
        return False
    ex, ey = l1 * np.cos(q1), l1 * np.sin(q1)
    dx, dy = np.cos(q1 + q2), np.sin(q1 + q2)
    rx, ry = zone.ox - ex, zone.oy - ey
    t = min(max(rx * dx + ry * dy, zone.x0), zone.x1)
    px, py = rx - t * dx, ry - t * dy
    return px * px + py * py < zone.radius * zone.radius
