"""``rwg.common_initial_states``: episode e of every policy starts from the same state, on every backend."""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, initial_states, run_rwg
from taskcomplexity.rwg.kernel_backend import reset_seeds
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task


def test_common_reset_seeds_depend_on_the_episode_only():
    common = reset_seeds(3, np.arange(5, 9), 6, common_initial_states=True)
    own = reset_seeds(3, np.arange(0, 9), 6)
    assert (common == common[0]).all() and len(set(common[0])) == 6
    np.testing.assert_array_equal(common[0], own[0])  # policy 0's resets in both modes
    assert not (own[5:] == own[0]).all()


@pytest.mark.parametrize("backend", ["kernel", "gym"])
def test_every_policy_starts_episode_e_from_the_same_state(backend):
    # Pendulum's first reward is −(θ₀² + 0.1·θ̇₀² + 0.001·u²): with common initial states the policies
    # differ in the torque term only (|0.001·u²| ≤ 0.004); with their own states, by up to π² + 0.1.
    task = GymTask("Pendulum-v1", max_steps=1)
    network, prior = NetworkSpec(hidden=(8,)), PriorSpec()
    common = run_rwg(task, network, prior, RWGSettings(policies=12, episodes=5, seed=4, common_initial_states=True),
                     backend=backend)
    own = run_rwg(task, network, prior, RWGSettings(policies=12, episodes=5, seed=4), backend=backend)
    assert np.ptp(common.returns, axis=0).max() <= 0.004 + 1e-12
    assert np.ptp(own.returns, axis=0).max() > 0.5
    np.testing.assert_array_equal(common.returns[0], own.returns[0])


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Pendulum-v1"])
def test_the_kernel_and_gym_backends_agree_with_common_initial_states(env_id):
    task = GymTask(env_id, max_steps=80)
    settings = RWGSettings(policies=5, episodes=4, seed=1, common_initial_states=True)
    kernel = run_rwg(task, NetworkSpec(), PriorSpec(), settings, backend="kernel")
    gym = run_rwg(task, NetworkSpec(), PriorSpec(), settings, backend="gym")
    np.testing.assert_allclose(kernel.returns, gym.returns, rtol=1e-12)


def test_the_arms_share_initial_states_too():
    joints, target = initial_states(make_task("two_link"), 2, np.arange(3, 7), 4, common=True)
    assert (joints == joints[:1]).all() and (target == target[:1]).all()
    np.testing.assert_array_equal(joints[0], initial_states(make_task("two_link"), 2, np.arange(1), 4)[0][0])


def test_the_option_is_keyed_only_when_set():
    task = GymTask("CartPole-v1")
    default = RWGRequest(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=4, episodes=3), "kernel")
    common = RWGRequest(task, NetworkSpec(), PriorSpec(),
                        RWGSettings(policies=4, episodes=3, common_initial_states=True), "kernel")
    assert default.identity()["common_initial_states"] is False
    assert common.identity()["common_initial_states"] is True and common.key != default.key
