"""The PyBullet reference environments follow environments.md."""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest

import taskcomplexity  # noqa: F401 - registers the ids
from taskcomplexity.tasks.pybullet_env import ReachingEnv
from taskcomplexity.tasks.registration import gym_ids
from taskcomplexity.tasks.rewards import reward_kind
from taskcomplexity.tasks.spec import REWARDS, arm_presets, preset_tasks

ONE_LINK = [t for t in preset_tasks() if not t[0].startswith("two_link")]
TWO_LINK = [t for t in preset_tasks() if t[0].startswith("two_link")]


@pytest.fixture
def make_env():
    envs = []

    def _make(arm, reward):
        env = ReachingEnv(arm=arm, reward=reward)
        envs.append(env)
        return env

    yield _make
    for env in envs:
        env.close()


def w(x, rounded):
    """The spec's angle map, written independently of the library: round(x, 2) mod 2π."""
    return (round(x, 2) if rounded else x) % (2 * math.pi)


@pytest.mark.parametrize(("arm", "reward"), preset_tasks())
def test_observation_has_the_documented_length_and_dtype(make_env, arm, reward):
    env = make_env(arm, reward)
    obs, _ = env.reset(seed=0)
    assert obs.shape == ((9,) if arm.startswith("one_link") else (10,))
    assert obs.dtype == np.float64
    assert env.observation_space.contains(obs)


@pytest.mark.parametrize(("arm", "reward"), ONE_LINK)
def test_one_link_observation_layout_and_dense_or_sparse_reward(make_env, arm, reward):
    env = make_env(arm, reward)
    length, radius = env.task.arm.links[0].length, env.task.arm.target_radius[0]
    q, theta = 1.23456, 4.56789
    env.reset(options={"joint_angles": [q], "target": [radius, theta]})
    obs, r, terminated, truncated, _ = env.step([0.0])  # at rest, no torque: the arm does not move
    rounded = reward == "dense"
    wq, wt = w(q, rounded), w(theta, rounded)
    ex, ey = length * math.cos(wq), length * math.sin(wq)
    gx, gy = radius * math.cos(wt), radius * math.sin(wt)
    expected = [wq, ex, ey, wt, gx, gy, ex - gx, ey - gy, 0.0]
    np.testing.assert_allclose(obs, expected, atol=1e-12)
    d = math.hypot(ex - gx, ey - gy)
    assert r == pytest.approx(-(d**2) if reward == "dense" else -1.0, abs=1e-12)
    assert not terminated and not truncated


@pytest.mark.parametrize(("arm", "reward"), TWO_LINK)
def test_two_link_observation_layout_and_reward(make_env, arm, reward):
    env = make_env(arm, reward)
    q1, q2, rho, alpha = 2.34567, 5.67891, 0.9, 4.0
    env.reset(options={"joint_angles": [q1, q2], "target": [rho, alpha]})
    obs, r, terminated, _, info = env.step([0.0, 0.0])
    a, b = w(q1, True), w(q2, True)
    ex = 0.70 * math.cos(a) + 0.95 * math.cos(a + b)
    ey = 0.70 * math.sin(a) + 0.95 * math.sin(a + b)
    gx, gy = rho * math.cos(alpha), rho * math.sin(alpha)
    expected = [math.cos(a), math.cos(a + b), math.sin(a), math.sin(a + b), gx, gy, ex, ey, ex - gx, ey - gy]
    np.testing.assert_allclose(obs, expected, atol=1e-12)
    d = math.hypot(ex - gx, ey - gy)
    if reward == "sparse":
        assert r == -1.0
    elif arm == "two_link":
        assert r == pytest.approx(-(d**2), abs=1e-12)
    else:  # obstacle: proximity terms from both clearances, no collision here
        assert not info["collision"]
        expected_r = -(d**2 + 5 * (math.exp(-2.5 * info["upper_clearance"]) + math.exp(-2.5 * info["forearm_clearance"])))
        assert r == pytest.approx(expected_r, abs=1e-12)
    assert not terminated


@pytest.mark.parametrize(("arm", "reward"), ONE_LINK + [("two_link", "dense"), ("two_link", "sparse")])
def test_dense_reward_charges_the_clipped_action_not_the_torque(make_env, arm, reward):
    env = make_env(arm, reward)
    env.reset(seed=1)
    action = np.full(env.task.arm.dof, 3.0)  # clipped to 1
    _, r, _, _, info = env.step(action)
    if reward == "dense":
        assert info["reward_action"] == pytest.approx(-env.task.arm.dof, abs=1e-12)
        assert r == pytest.approx(-(info["distance"] ** 2) - env.task.arm.dof, abs=1e-12)
    else:
        assert r in (0.0, -1.0)


@pytest.mark.parametrize(("arm", "reward"), ONE_LINK)
def test_one_link_terminates_inside_the_threshold(make_env, arm, reward):
    env = make_env(arm, reward)
    radius = env.task.arm.target_radius[0]
    env.reset(options={"joint_angles": [1.0], "target": [radius, 1.0]})  # d = R − l = 0.01 m
    _, r, terminated, _, info = env.step([0.0])
    assert info["distance"] == pytest.approx(0.01, abs=1e-12)
    assert terminated
    assert r == (0.0 if reward == "sparse" else pytest.approx(-1e-4, abs=1e-12))


@pytest.mark.parametrize(("arm", "reward"), [("two_link", "dense"), ("two_link", "sparse")])
def test_two_link_terminates_inside_the_threshold_and_not_outside(make_env, arm, reward):
    env = make_env(arm, reward)
    q1, q2 = 0.5, 1.0
    ex = 0.70 * math.cos(q1) + 0.95 * math.cos(q1 + q2)
    ey = 0.70 * math.sin(q1) + 0.95 * math.sin(q1 + q2)
    rho, alpha = math.hypot(ex, ey), math.atan2(ey, ex)
    for offset, inside in [(0.049, True), (0.051, False)]:
        env.reset(options={"joint_angles": [q1, q2], "target": [rho + offset, alpha]})
        _, r, terminated, _, info = env.step([0.0, 0.0])
        assert info["distance"] == pytest.approx(offset, abs=1e-9)
        assert terminated is inside
        if reward == "sparse":
            assert r == (0.0 if inside else -1.0)


def test_every_arm_preset_file_has_its_gym_ids():
    """An arm added as conf/arm/<name>.yaml gets an id per reward it allows; no second list to keep."""
    from taskcomplexity.cli import CONF_DIR

    arms = sorted(path.stem for path in (CONF_DIR / "arm").glob("*.yaml"))
    assert sorted({arm for arm, _ in preset_tasks()}) == arms
    # every reward kind for an arm without an obstacle, the dense one only for an arm with one
    obstacle = {arm for arm, spec in arm_presets().items() if spec.obstacle is not None}
    assert set(preset_tasks()) == {(arm, kind) for arm in arms for kind in REWARDS
                                   if arm not in obstacle or reward_kind(kind).obstacle}
    assert {"two_link_obstacle"} <= obstacle and ("two_link_obstacle", "sparse") not in preset_tasks()
    for arm, reward in preset_tasks():
        assert gym_ids()[(arm, reward)] in gymnasium.registry


@pytest.mark.parametrize(("arm", "reward"), preset_tasks())
def test_registered_id_truncates_after_50_steps(arm, reward):
    env = gymnasium.make(gym_ids()[(arm, reward)])
    try:
        env.reset(seed=0)
        dof = env.unwrapped.task.arm.dof
        for step in range(1, 51):
            _, _, terminated, truncated, _ = env.step(np.zeros(dof))
            if terminated:
                pytest.skip("this seed's start is inside the threshold")
            assert truncated is (step == 50)
    finally:
        env.close()


@pytest.mark.parametrize(("arm", "reward"), preset_tasks())
def test_same_seed_same_episode(make_env, arm, reward):
    rng = np.random.default_rng(7)
    dof = 1 if arm.startswith("one_link") else 2
    actions = rng.uniform(-1, 1, size=(20, dof))
    runs = []
    for _ in range(2):
        env = make_env(arm, reward)
        obs, _ = env.reset(seed=123)
        trace = [obs]
        for a in actions:
            obs, r, terminated, _, _ = env.step(a)
            trace.append(np.append(obs, r))
            if terminated:
                break
        runs.append(np.concatenate(trace))
    np.testing.assert_array_equal(runs[0], runs[1])
    other = make_env(arm, reward)
    assert not np.array_equal(other.reset(seed=124)[0], runs[0][: other.observation_space.shape[0]])


@pytest.mark.parametrize(("arm", "inertia", "scale", "dt", "mass", "com"), [
    ("one_link_1m0", 2.25377325, 30.0, 0.01, 6.75, 0.50),
    ("one_link_1m65", 10.109953125, 156.0, 0.01, 11.475, 0.80),
])
def test_one_step_from_rest_is_an_impulse_then_50_damped_coasting_substeps(make_env, arm, inertia, scale, dt, mass, com):
    env = make_env(arm, "dense")
    env.reset(options={"joint_angles": [0.0], "target": [1.0, 3.0]})
    env.step([1.0])
    _, velocity = env.joint_state()
    # Spec: the torque acts for one sub-step (impulse τ·dt/I), then the arm coasts 50 sub-steps under
    # Bullet's link damping, k = 0.04: a torque I_c·ω·(k + k|ω|) and a force m·v·(k + k|v|) at the
    # centre of mass (v = r·ω), integrated by explicit Euler.
    k, i_c = 0.04, inertia - mass * com**2
    omega = scale * dt / inertia
    for _ in range(50):
        damping = i_c * omega * (k + k * abs(omega)) + mass * com**2 * omega * (k + k * abs(com * omega))
        omega -= dt * damping / inertia
    assert velocity[0] == pytest.approx(omega, abs=1e-6)
    assert velocity[0] < scale * dt / inertia  # damping did slow it


def test_obstacle_collision_ends_the_episode_with_the_penalty_in_that_steps_reward(make_env):
    env = make_env("two_link_obstacle", "dense")
    # The straight arm at q1 = 0.58 rad passes 1.25·sin(0.58 − 31°) = 0.0487 m from the block centre:
    # d₂ = 0.0487 − (0.02 + 0.05/2) = 0.0037 ≤ 0.005, a collision for the reward model, while the
    # real boxes are still 0.012 m apart (no contact force moves the arm).
    env.reset(options={"joint_angles": [0.58, 0.0], "target": [0.5, 0.0]})
    _, r, terminated, _, info = env.step([0.0, 0.0])
    assert info["forearm_clearance"] == pytest.approx(1.25 * math.sin(0.58 - math.radians(31)) - 0.045, abs=1e-3)
    assert info["collision"] and terminated
    assert info["reward_collision"] == -1000.0
    assert r <= -1000.0


def test_obstacle_upper_arm_clearance_is_pybullets_closest_distance(make_env):
    env = make_env("two_link_obstacle", "dense")
    env.reset(options={"joint_angles": [math.radians(31.0), math.pi], "target": [0.5, 0.0]})
    # Link 1 points at the block. Bullet measures boxes with rounded edges: each box's core is shrunk by
    # the URDF importer's collision margin (0.001 m) and the margins are subtracted from the distance
    # between the cores. Along the 31° ray the block core's nearest corner is at
    # 1.25 − (0.0081 − 0.001)·(cos 31° + sin 31°); the link's end face stays at 0.70.
    link_margin, block_margin = 0.001, 0.001
    a = math.radians(31.0)
    block_face = 1.25 - (0.0081 - block_margin) * (math.cos(a) + math.sin(a))
    expected = block_face - (0.70 - link_margin) - (link_margin + block_margin)
    assert env.upper_arm_clearance() == pytest.approx(expected, abs=1e-6)


def test_connecting_to_pybullet_prints_nothing_and_leaves_both_streams_working(capfd):
    env = ReachingEnv(arm="two_link", reward="dense")
    try:
        print("before")
        env.reset(seed=0)
        env.step(np.zeros(2))
        print("after")
        import sys

        print("still stderr", file=sys.stderr)
    finally:
        env.close()
    out, err = capfd.readouterr()
    assert out == "before\nafter\n"  # no "argv[0]=" from PyBullet's connection
    assert err == "still stderr\n"  # no build-time banner, and stderr works after the block
