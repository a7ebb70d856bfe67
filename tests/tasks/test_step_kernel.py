"""The fused step kernel computes exactly what tasks.mechanics defines (the PyBullet env's semantics)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.spec import make_task, preset_tasks

B = 400


def _random_state(task, rng):
    q0, target = mechanics.initial_state(task.arm, rng.random((B, 4)))
    q0 = q0 + rng.normal(0.0, 20.0, q0.shape)  # unbounded raw angles, both signs
    q0[:20] = np.round(q0[:20], 2) + 0.005  # exactly on a rounding half
    if task.arm.obstacle is not None:  # put a third of the forearms near the block
        q0[: B // 3, 0] = np.radians(31.0) + rng.normal(0.0, 0.05, B // 3)
        q0[: B // 3, 1] = rng.normal(0.0, 0.1, B // 3)
    qd0 = rng.normal(0.0, 3.0, q0.shape)
    action = rng.uniform(-1.5, 1.5, (B, task.arm.dof))
    return q0, qd0, target, action


CASES = [(arm, reward, "pybullet") for arm, reward in preset_tasks()] + [("two_link_obstacle", "dense", "model")]


@pytest.mark.parametrize(("arm", "reward", "contacts"), CASES)
def test_observation_reward_and_done_are_those_of_mechanics(arm, reward, contacts):
    task = make_task(arm, reward)
    rng = np.random.default_rng(7)
    q0, qd0, target, action = _random_state(task, rng)
    env = BatchedReaching(task, B, contacts)
    env.reset(torch.from_numpy(q0), torch.from_numpy(target))
    env.joint_velocities.copy_(torch.from_numpy(qd0))
    env.active[-10:] = False  # already done: must not move or earn
    active = env.active.numpy().copy()
    observation, reward_, done = env.step(torch.from_numpy(action))
    moved = active & ~env.handoff.numpy()

    q1 = env.joint_angles.numpy()
    obs, distance, elbow, effector = mechanics.observe(task, q1, env.joint_velocities.numpy(), target)
    clipped = np.clip(action, -1.0, 1.0)
    upper = forearm = None
    if task.arm.obstacle is not None:
        upper = mechanics.upper_arm_clearance(task, q0)
        forearm = mechanics.forearm_clearance(task, elbow, effector)
    expected, terms, collision = mechanics.reward_terms(task, clipped, distance, upper, forearm)

    np.testing.assert_allclose(observation.numpy()[moved], obs[moved], rtol=0, atol=1e-12)
    np.testing.assert_allclose(reward_.numpy()[moved], expected[moved], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(done.numpy()[moved], (terms["success"] | collision)[moved])
    np.testing.assert_array_equal(env.returns.numpy(), np.where(moved, reward_.numpy(), 0.0))
    np.testing.assert_array_equal(env.steps.numpy(), moved.astype(int))
    # environments that were not active stay where they were and earn nothing
    np.testing.assert_array_equal(q1[~active], q0[~active])
    assert (reward_.numpy()[~moved] == 0).all() and not done.numpy()[~moved].any()
    assert moved.sum() > B // 2
    if contacts == "model":
        assert not env.handoff.numpy().any() and env.contact.numpy()[: B // 3].mean() > 0.3
        assert collision[moved].any() and not collision[moved].all()  # both branches exercised
    elif task.arm.obstacle is not None:
        handoff = env.handoff.numpy()
        assert handoff[: B // 3].mean() > 0.3  # forearms near the block were handed over,
        np.testing.assert_array_equal(q1[handoff], q0[handoff])  # from the state before the step
        assert (upper[moved] < 0.6).any() and (forearm[moved] < 0.2).any()  # proximity terms exercised


def test_cached_kernels_are_dropped_when_any_kernel_source_changes(tmp_path):
    from taskcomplexity.tasks import step_kernel

    kernel = tmp_path / "dynamics._step-1.py311.nbi"
    other = tmp_path / "unrelated.nbi"
    kernel.write_text("compiled from old code")
    other.write_text("not ours")
    assert step_kernel.drop_stale_kernels(tmp_path)  # no stamp yet: the cache is not trusted
    assert not kernel.exists() and other.exists()
    kernel.write_text("compiled from the current code")
    assert not step_kernel.drop_stale_kernels(tmp_path)  # same sources: kept
    assert kernel.exists()
    (tmp_path / "taskcomplexity-kernels.sha256").write_text("digest of other sources")
    assert step_kernel.drop_stale_kernels(tmp_path)
    assert not kernel.exists()
