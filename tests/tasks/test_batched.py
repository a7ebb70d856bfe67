"""The batched backend is step-for-step the PyBullet reference (environments.md): RWG and SAC run on it by default,
so its episodes must be the reference's."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, initial_states, run_rwg
from taskcomplexity.tasks import mechanics
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.pybullet_env import ReachingEnv
from taskcomplexity.tasks.spec import make_task, preset_tasks

EPISODES = 6
# Bullet's articulated-body algorithm and our closed-form chain dynamics sum the same terms in a
# different order; over 50 × 51 physics steps the joint state drifts by ~1e-7 at most.
STATE_TOL = 1e-6


@pytest.mark.parametrize(("arm", "reward"), preset_tasks())
def test_same_states_and_actions_give_the_same_trajectories(arm, reward):
    task = make_task(arm, reward)
    rng = np.random.default_rng(11)
    q0, target = mechanics.initial_state(task.arm, rng.random((EPISODES, 4)))
    actions = rng.uniform(-1.2, 1.2, size=(task.max_steps, EPISODES, task.arm.dof))
    batched = BatchedReaching(task, EPISODES)
    batched.reset(torch.from_numpy(q0), torch.from_numpy(target))
    reference = [ReachingEnv(task=task) for _ in range(EPISODES)]
    try:
        for env, q, g in zip(reference, q0, target, strict=True):
            env.reset(options={"joint_angles": q, "target": g})
        done = np.zeros(EPISODES, dtype=bool)
        compared = 0
        for t in range(task.max_steps):
            active = batched.active.numpy().copy()
            _, reward_b, done_b = batched.step(torch.from_numpy(actions[t]))
            for i, env in enumerate(reference):
                if done[i] or not active[i]:
                    continue
                if batched.handoff[i]:
                    done[i] = True  # the forearm entered the block's contact zone: see the next test
                    continue
                _, r, terminated, _, info = env.step(actions[t, i])
                q, qd = env.joint_state()
                np.testing.assert_allclose(batched.joint_angles[i].numpy(), q, atol=STATE_TOL, rtol=0)
                np.testing.assert_allclose(batched.joint_velocities[i].numpy(), qd, atol=STATE_TOL, rtol=0)
                assert reward_b[i].item() == pytest.approx(r, abs=1e-6)
                assert bool(done_b[i]) == terminated, f"step {t}, episode {i}"
                if task.arm.obstacle is not None:
                    assert bool(info["collision"]) == bool(done_b[i] and not info["success"])
                done[i] |= terminated
                compared += 1
        assert compared >= EPISODES  # the comparison really ran
    finally:
        for env in reference:
            env.close()


def test_obstacle_contacts_are_ill_conditioned_in_pybullet_itself():
    """Why contact episodes are handed over rather than compared state by state.

    After the forearm touches the block, PyBullet's own trajectory changes when the joint angles are
    perturbed by 1e-12 rad: no second implementation can follow it step by step there.
    """
    task = make_task("two_link_obstacle", "dense")
    changed = 0
    rng = np.random.default_rng(3)
    for _ in range(8):
        q = np.array([np.radians(31.0) - 0.35, 0.0])  # sweeping towards the block
        env_a, env_b = ReachingEnv(task=task), ReachingEnv(task=task)
        try:
            env_a.reset(options={"joint_angles": q, "target": [0.5, 2.0]})
            env_b.reset(options={"joint_angles": q + 1e-12, "target": [0.5, 2.0]})
            actions = rng.choice([-1.0, 1.0], size=(20, 2))
            actions[:, 0] = 1.0  # push the arm into the block
            for a in actions:
                _, ra, ta, _, _ = env_a.step(a)
                _, rb, tb, _, _ = env_b.step(a)
                if ta or tb:
                    break
            changed += abs(env_a.joint_state()[0] - env_b.joint_state()[0]).max() > 1e-6
        finally:
            env_a.close()
            env_b.close()
    assert changed >= 1


def _check_backends_agree(arm, reward, policies, episodes, allowed):
    """Equal returns on both backends, except episodes whose rounding (0.01 rad) or threshold (0.05 m)
    decision is straddled by float noise (at most ``allowed`` of them), and obstacle episodes that
    touched the block (finished on PyBullet after a hand-over; counted)."""
    task = make_task(arm, reward)
    settings = RWGSettings(policies=policies, episodes=episodes, seed=5)
    network, prior = NetworkSpec(), PriorSpec()
    fast = run_rwg(task, network, prior, settings, "batched")
    slow = run_rwg(task, network, prior, settings, "pybullet")
    different = np.abs(fast.returns - slow.returns) > 1e-6
    if task.arm.obstacle is None:
        assert fast.handoffs == 0
        assert different.sum() <= allowed, f"{different.sum()} of {different.size} episodes differ"
    else:
        # Without a contact, episodes agree exactly; the ill-conditioned contact episodes are counted.
        assert fast.handoffs > 0
        assert different.sum() <= fast.handoffs


@pytest.mark.parametrize(("arm", "reward"), preset_tasks())
def test_rwg_returns_agree_across_backends(arm, reward):
    """16 policies × 8 episodes: at most 2 of the 128 episodes straddle a rounding decision."""
    _check_backends_agree(arm, reward, 16, 8, allowed=2)


@pytest.mark.slow
@pytest.mark.parametrize(("arm", "reward"), preset_tasks())
def test_rwg_returns_agree_across_backends_at_1000_episodes(arm, reward):
    """50 policies × 20 episodes: fewer than 0.5 % of the episodes straddle a rounding decision."""
    _check_backends_agree(arm, reward, 50, 20, allowed=4)


@pytest.mark.parametrize(
    ("arm", "reward", "contacts"),
    [
        ("two_link", "sparse", "pybullet"),
        ("one_link_1m65", "dense", "pybullet"),
        ("two_link_obstacle", "dense", "pybullet"),
        ("two_link_obstacle", "dense", "model"),
    ],
)
def test_batched_results_do_not_depend_on_the_chunk_size(arm, reward, contacts):
    task = make_task(arm, reward)
    network, prior = NetworkSpec(hidden=(64, 64)), PriorSpec(kind="uniform")
    common = dict(policies=12, episodes=7, seed=2, contacts=contacts)
    whole = run_rwg(task, network, prior, RWGSettings(**common, chunk_policies=12), "batched")
    pieces = run_rwg(task, network, prior, RWGSettings(**common, chunk_policies=5), "batched")
    np.testing.assert_array_equal(whole.returns, pieces.returns)
    np.testing.assert_array_equal(whole.steps, pieces.steps)


def test_initial_states_are_the_same_for_both_backends_and_any_split():
    task = make_task("two_link", "dense")
    q_all, g_all = initial_states(task, 9, np.arange(10), 5)
    q_part, g_part = initial_states(task, 9, np.arange(4, 7), 5)
    np.testing.assert_array_equal(q_all[4:7], q_part)
    np.testing.assert_array_equal(g_all[4:7], g_part)
    assert (g_all[..., 0] >= 0.35).all() and (g_all[..., 0] <= 1.51).all()
