"""The batched contact model of the obstacle task against PyBullet (tasks/contact.py).

PyBullet's contact dynamics are chaotic (``test_batched.py`` shows it), so the model is held to
PyBullet on a single slow contact, where both are well conditioned, and on the distribution of
random-policy episodes, where the contact-free dynamics are far off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from scipy import stats

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.pybullet_env import ReachingEnv
from taskcomplexity.tasks.spec import make_task

TASK = make_task("two_link_obstacle", "dense")
BLOCK_ANGLE = math.atan2(TASK.arm.obstacle.position[1], TASK.arm.obstacle.position[0])


@pytest.mark.parametrize(("omega", "elbow"), [(1.0, 0.0), (-1.0, 0.3), (2.0, 0.0)])
def test_a_slow_sweep_into_the_block_follows_pybullet(omega, elbow):
    """The forearm sweeps into the block, is stopped along the normal and slides around it."""
    q0 = np.array([BLOCK_ANGLE - math.copysign(0.06, omega) - elbow * 0.5, elbow])
    qd0 = np.array([omega, 0.0])
    reference = ReachingEnv(task=TASK)
    try:
        reference.reset(options={"joint_angles": q0, "joint_velocities": qd0, "target": [0.5, 3.0]})
        reference.step(np.zeros(2))
        q_ref, qd_ref = reference.joint_state()
    finally:
        reference.close()
    model = BatchedReaching(TASK, 1, contacts="model")
    model.reset(torch.from_numpy(q0[None]), torch.tensor([[0.5, 3.0]]))
    model.joint_velocities.copy_(torch.from_numpy(qd0[None]))
    free = BatchedReaching(make_task("two_link", "dense"), 1)  # the same arm without the block
    free.reset(torch.from_numpy(q0[None]), torch.tensor([[0.5, 3.0]]))
    free.joint_velocities.copy_(torch.from_numpy(qd0[None]))
    model.step(torch.zeros(1, 2))
    free.step(torch.zeros(1, 2))
    assert bool(model.contact[0])
    np.testing.assert_allclose(model.joint_angles[0].numpy(), q_ref, atol=2e-3, rtol=0)
    np.testing.assert_allclose(model.joint_velocities[0].numpy(), qd_ref, atol=1e-2, rtol=0)
    # the block changed the motion by far more than the tolerance
    assert np.abs(free.joint_angles[0].numpy() - q_ref).max() > 0.1


def test_random_policy_episodes_have_pybullets_distribution():
    settings = dict(policies=100, episodes=5, seed=3)
    exact = run_rwg(TASK, NetworkSpec(), PriorSpec(), RWGSettings(**settings), "pybullet")
    model = run_rwg(TASK, NetworkSpec(), PriorSpec(), RWGSettings(**settings, contacts="model"), "batched")
    assert model.contacts > 0.6 * model.returns.size  # the block acts in most episodes
    for name in ("returns", "steps"):
        a, b = getattr(exact, name).ravel(), getattr(model, name).ravel()
        assert stats.ks_2samp(a, b).pvalue > 0.01, name
    collided = [((c.steps < TASK.max_steps) & ~c.success).mean() for c in (exact, model)]
    assert collided[0] > 0.6 and abs(collided[0] - collided[1]) < 0.06
    # without the block's forces most of these arms would sweep through it and live longer
    assert abs(exact.steps.mean() - model.steps.mean()) < 2.0


def test_the_trigonometry_free_gate_never_misses_a_pose_near_the_block():
    """near_block prunes by elbow angle and forearm direction before measuring; it must be conservative."""
    from taskcomplexity.tasks import contact
    from taskcomplexity.tasks.dynamics import contact_zone

    zone = contact_zone(TASK, "model")
    l1 = TASK.arm.links[0].length
    rng = np.random.default_rng(5)
    q1 = np.concatenate([rng.uniform(-20, 20, 20000), BLOCK_ANGLE + rng.normal(0, 0.5, 80000)])
    q2 = rng.uniform(-20, 20, q1.size)
    # the exact test: distance from the block to the forearm's axis segment, against the zone radius
    ex, ey = l1 * np.cos(q1), l1 * np.sin(q1)
    ux, uy = np.cos(q1 + q2), np.sin(q1 + q2)
    rx, ry = zone.ox - ex, zone.oy - ey
    t = np.clip(rx * ux + ry * uy, zone.x0, zone.x1)
    near = (rx - t * ux) ** 2 + (ry - t * uy) ** 2 < zone.radius ** 2
    gate = np.array([contact.near_block(zone, l1, a, b) for a, b in zip(q1, q2, strict=True)])
    assert near.sum() > 1000  # the sample does reach the block
    np.testing.assert_array_equal(gate, near)  # after the pruning, the gate is the exact test


def test_one_sweep_solves_happen_at_pybullets_measured_rates():
    """The stand-in for the ground-plane flicker fires at the configured rates, on any poses."""
    from taskcomplexity.tasks import contact
    from taskcomplexity.tasks.dynamics import contact_zone

    zone = contact_zone(TASK, "model")
    rng = np.random.default_rng(8)
    poses = np.column_stack([BLOCK_ANGLE + rng.normal(0, 0.2, 40000), rng.uniform(-3, 3, 40000)])
    for fresh, rate in ((True, contact.P_SINGLE_FRESH), (False, contact.P_SINGLE_CONTINUING)):
        fired = np.mean([contact.single_sweep(zone, fresh, a, b) for a, b in poses])
        assert abs(fired - rate) < 4 * np.sqrt(rate * (1 - rate) / len(poses)) + 1e-3, (fresh, fired)


def test_a_one_sweep_solve_keeps_the_first_normal_impulse():
    """One sweep: the normal impulse is not corrected for the friction impulse that follows it."""
    from taskcomplexity.tasks import contact
    from taskcomplexity.tasks.dynamics import ArmDynamics, contact_zone, inverse_mass_matrix
    from taskcomplexity.tasks.urdf import read_arm_urdf, urdf_path

    zone = contact_zone(TASK, "model")
    inv = inverse_mass_matrix(ArmDynamics(read_arm_urdf(urdf_path(TASK.arm))).params())
    l1 = TASK.arm.links[0].length
    q1, q2 = BLOCK_ANGLE - 0.004, 0.0  # the forearm's side overlapping the block
    points, ends, rows, impulse = contact.scratch()
    count, nx, ny = contact.detect(zone, l1, q1, q2, points, ends)
    assert count >= 1 and points[0, 2] < 0
    u, v = 1.0, -0.5  # pressing into the block and sliding
    single = contact.solve(zone, l1, q1, inv, u, v, points, count, nx, ny, 0.02, rows, impulse, True)
    converged = contact.solve(zone, l1, q1, inv, u, v, points, count, nx, ny, 0.02, rows, impulse, False)
    assert np.abs(np.subtract(single, converged)).max() > 1e-4  # the two differ ...
    row_n = rows[0]
    vn_single = row_n[0] * single[0] + row_n[1] * single[1]
    vn_converged = row_n[0] * converged[0] + row_n[1] * converged[1]
    assert vn_converged == pytest.approx(row_n[5], abs=1e-6)  # ... converged: exactly the target speed
    assert abs(vn_single - row_n[5]) > 1e-6  # one sweep: friction has moved it off the target
