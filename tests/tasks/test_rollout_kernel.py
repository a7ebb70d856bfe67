"""The fused RWG rollout is the step-by-step path (PolicyBatch.act, then BatchedReaching.step) in one kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies
from taskcomplexity.rwg import initial_states
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.rollout_kernel import forward
from taskcomplexity.tasks.spec import make_task, preset_tasks

NETWORKS = [
    NetworkSpec(),  # the paper's: 32-32 ReLU, tanh output, no biases
    NetworkSpec(hidden=(64,), bias=True, activation="tanh"),
    NetworkSpec(hidden=(), output="linear", input_bias=True),  # linear policy: raw outputs, clipped by the step
    NetworkSpec(hidden=(5, 3), activation="tanh", output="linear", bias=True, input_bias=True),
]
CASES = [(arm, reward, "pybullet") for arm, reward in preset_tasks()] + [("two_link_obstacle", "dense", "model")]
POLICIES, EPISODES = 8, 24
# The kernel's matrix products sum in another order than NumPy's BLAS, so an action that is not saturated
# can differ in its last bits; over 50 steps the joint state then differs by ~1e-11 (measured: < 5e-11 in
# returns over 4096 episodes of every case). An episode whose rounding (0.01 rad), threshold (0.05 m) or
# contact decision falls within that noise would take another path: allowed once per case (not seen).
RETURN_TOL = 1e-8
STATE_TOL = 1e-6
STRADDLES = 1


def _run(task, policies, joint_angles, target, contacts, fused):
    n = joint_angles.shape[0] * joint_angles.shape[1]
    env = BatchedReaching(task, n, contacts)
    obs = env.reset(torch.from_numpy(joint_angles.reshape(n, -1)), torch.from_numpy(target.reshape(n, 2)))
    if fused:
        env.rollout(*policies.packed(), activation=policies.activation, output=policies.output,
                    bias=policies.biases is not None, input_bias=policies.input_bias)
    else:
        with policies:
            for _ in range(task.max_steps):
                action = policies.act(obs.view(len(policies), -1, obs.shape[1])).reshape(n, -1)
                obs, _, _ = env.step(action)
    return env


@pytest.mark.parametrize("network", NETWORKS, ids=lambda n: f"{n.hidden}-{n.activation}-{n.output}")
@pytest.mark.parametrize(("arm", "reward", "contacts"), CASES)
def test_the_fused_rollout_gives_the_step_by_step_returns(arm, reward, contacts, network):
    task = make_task(arm, reward)
    policies = sample_policies(network, PriorSpec(), task.observation_size, task.action_size, 3, np.arange(POLICIES))
    joint_angles, target = initial_states(task, 3, policies.indices, EPISODES)
    old = _run(task, policies, joint_angles, target, contacts, fused=False)
    new = _run(task, policies, joint_angles, target, contacts, fused=True)

    differ = (np.abs(new.returns.numpy() - old.returns.numpy()) > RETURN_TOL) | (new.steps != old.steps).numpy()
    assert differ.sum() <= STRADDLES, f"{differ.sum()} of {differ.size} episodes differ"
    same = ~differ
    for name in ("success", "handoff", "contact"):
        np.testing.assert_array_equal(getattr(new, name).numpy()[same], getattr(old, name).numpy()[same], name)
    # the state where every episode stopped (for a hand-over: where PyBullet continues it)
    np.testing.assert_allclose(new.joint_angles.numpy()[same], old.joint_angles.numpy()[same], atol=STATE_TOL, rtol=0)
    np.testing.assert_allclose(new.joint_velocities.numpy()[same], old.joint_velocities.numpy()[same],
                               atol=STATE_TOL, rtol=0)
    np.testing.assert_array_equal(new.active.numpy()[same], old.active.numpy()[same])
    assert (old.steps.numpy() > 1).mean() > 0.5  # the episodes really ran
    if contacts == "model":
        assert new.contact.numpy().any()
    elif task.arm.obstacle is not None:
        assert new.handoff.numpy().any()


def _kernel_actions(policies, obs, episodes):
    """Every environment's action by the kernel's own forward pass (:func:`forward`), one policy at a time."""
    weights, layer_sizes = policies.packed()
    n_obs, width = obs.shape[1], int(layer_sizes.max())
    actions = np.empty((obs.shape[0], int(layer_sizes[-1])))
    for p in range(len(policies)):
        h, g = np.zeros((width, episodes)), np.zeros((width, episodes))
        h[:n_obs] = obs[p * episodes:(p + 1) * episodes].T
        if policies.input_bias:
            h[n_obs] = 1.0
        out = forward(weights[p], layer_sizes, policies.biases is not None, policies.activation == "relu",
                      policies.output == "tanh", h, g, episodes)
        actions[p * episodes:(p + 1) * episodes] = out[:actions.shape[1]].T
    return actions


@pytest.mark.parametrize("network", NETWORKS[:2], ids=lambda n: f"{n.hidden}-{n.activation}-{n.output}")
@pytest.mark.parametrize(("arm", "reward", "contacts"), CASES)
def test_the_fused_rollout_is_the_step_by_step_path_bit_for_bit(arm, reward, contacts, network):
    # with the kernel's own forward pass driving BatchedReaching.step, the fused rollout (the target's
    # terms once per episode, the step split over begin_step / integrate_block / finish_step) gives the
    # same returns, lengths, flags and final states exactly
    task = make_task(arm, reward)
    policies = sample_policies(network, PriorSpec(), task.observation_size, task.action_size, 5, np.arange(4))
    joint_angles, target = initial_states(task, 5, policies.indices, EPISODES)
    n = len(policies) * EPISODES
    old = BatchedReaching(task, n, contacts)
    obs = old.reset(torch.from_numpy(joint_angles.reshape(n, -1)), torch.from_numpy(target.reshape(n, 2)))
    for _ in range(task.max_steps):
        obs, _, _ = old.step(torch.from_numpy(_kernel_actions(policies, obs.numpy(), EPISODES)))
    new = _run(task, policies, joint_angles, target, contacts, fused=True)
    for name in ("returns", "steps", "success", "handoff", "contact", "joint_angles", "joint_velocities", "active"):
        np.testing.assert_array_equal(getattr(new, name).numpy(), getattr(old, name).numpy(), name)
    assert (old.steps.numpy() > 1).mean() > 0.5 and old.returns.numpy().std() > 0  # the episodes really ran


@pytest.mark.parametrize("network", NETWORKS, ids=lambda n: f"{n.hidden}-{n.activation}-{n.output}")
def test_the_kernels_forward_pass_is_the_policy_batchs(network):
    obs_size, act_size = 10, 2
    policies = sample_policies(network, PriorSpec(kind="uniform"), obs_size, act_size, 7, np.arange(3))
    x = np.random.default_rng(0).normal(0.0, 3.0, (3, 37, obs_size))
    expected = policies.act(torch.from_numpy(x)).numpy()
    weights, layer_sizes = policies.packed()
    assert layer_sizes.tolist() == [obs_size + network.input_bias, *network.hidden, act_size]
    width = int(layer_sizes.max())
    for p in range(3):
        h, g = np.zeros((width, 40)), np.zeros((width, 40))  # wider than used: columns 37.. are ignored
        h[:obs_size, :37] = x[p].T
        if network.input_bias:
            h[obs_size] = 1.0
        out = forward(weights[p], layer_sizes, network.bias, network.activation == "relu", network.output == "tanh",
                      h, g, 37)
        # the same sums in another order: float64 rounding only
        np.testing.assert_allclose(out[:act_size, :37].T, expected[p], rtol=1e-12, atol=1e-12)
        # and each environment's outputs are its own, bit for bit, whichever environments share the pass
        # (what keeps the returns independent of the chunking)
        for e in (0, 5, 36):
            h1, g1 = np.zeros((width, 1)), np.zeros((width, 1))
            h1[:obs_size, 0] = x[p, e]
            h1[obs_size:, 0] = 1.0 if network.input_bias else 0.0
            alone = forward(weights[p], layer_sizes, network.bias, network.activation == "relu",
                            network.output == "tanh", h1, g1, 1)
            np.testing.assert_array_equal(alone[:act_size, 0], out[:act_size, e])
            # and they are the plain in-order sums, bit for bit (what the blocked products must keep)
            np.testing.assert_array_equal(out[:act_size, e], _in_order(weights[p], layer_sizes, network,
                                                                        [*x[p, e], 1.0]))


def _in_order(w, layer_sizes, network, x):
    """The packed MLP on one input column by the definition: Σᵢ from 0 in order i = 0, 1, …, then the bias."""
    off, layers = 0, len(layer_sizes) - 1
    x = list(x[:layer_sizes[0]])
    for k in range(layers):
        fan_in, fan_out = int(layer_sizes[k]), int(layer_sizes[k + 1])
        y = []
        for j in range(fan_out):
            total = 0.0
            for i in range(fan_in):
                total = total + float(w[off + j * fan_in + i]) * x[i]
            y.append(total)
        off += fan_in * fan_out
        if network.bias:
            y = [v + float(w[off + j]) for j, v in enumerate(y)]
            off += fan_out
        if k < layers - 1:
            y = [max(v, 0.0) for v in y] if network.activation == "relu" else [math.tanh(v) for v in y]
        elif network.output == "tanh":
            y = [math.tanh(v) for v in y]
        x = y
    return np.array(x)


def test_a_rollout_refuses_policies_that_do_not_fit_the_environments():
    task = make_task("two_link", "dense")
    policies = sample_policies(NetworkSpec(), PriorSpec(), task.observation_size, task.action_size, 0, np.arange(3))
    env = BatchedReaching(task, 10)
    with pytest.raises(ValueError, match="do not split evenly over 3 policies"):
        env.rollout(*policies.packed())
    one_link = sample_policies(NetworkSpec(), PriorSpec(), 9, 1, 0, np.arange(2))
    with pytest.raises(ValueError, match="do not fit observation size 10"):
        env.rollout(*one_link.packed())


# rwg.precision=float32: the forward pass in float32. Random policies with N(0, 1) weights are steep near the
# surfaces where an action switches sign, so the rounding of the actions moves a few episodes onto another path
# (measured at 100 × 50: up to 0.3 sd on single 2-link episodes, the 99th percentile below 6e-4 sd): the
# returns agree as a distribution, and episode by episode for almost all of them.
FLOAT32_CASES = [("one_link_1m0", "dense"), ("one_link_1m65", "sparse"), ("two_link", "dense")]


@pytest.mark.parametrize(("arm", "reward"), FLOAT32_CASES)
def test_a_float32_forward_pass_gives_float64_s_returns_but_for_the_rounding_of_the_actions(arm, reward):
    from taskcomplexity.rwg import RWGSettings, simulate_chunk

    task = make_task(arm, reward)
    runs = {p: simulate_chunk(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=40, episodes=25, precision=p),
                              0, 40, "batched") for p in ("float64", "float32")}
    wide, narrow = runs["float64"], runs["float32"]
    scale = wide.returns.std()
    difference = np.abs(wide.returns - narrow.returns) / scale
    assert np.quantile(difference, 0.98) < 1e-3  # episode by episode, almost all
    assert difference.max() < 1.0
    assert abs(wide.returns.mean() - narrow.returns.mean()) < 0.02 * scale
    assert abs(wide.success.mean() - narrow.success.mean()) <= 0.01
    assert np.array_equal(wide.policy, narrow.policy)


def test_a_float32_forward_pass_has_its_own_key_and_float64_keeps_the_old_one():
    from taskcomplexity.rwg import RWGSettings
    from taskcomplexity.stages.rwg_stage import RWGRequest

    task, settings = make_task("two_link", "dense"), RWGSettings(policies=20, episodes=6)
    default = RWGRequest(task, NetworkSpec(), PriorSpec(), settings)
    assert "precision" not in default.identity()
    wide = RWGRequest(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=6, precision="float64"))
    narrow = RWGRequest(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=6, precision="float32"))
    assert wide.key == default.key != narrow.key and narrow.identity()["precision"] == "float32"


def test_float32_is_refused_where_there_is_no_batched_mlp_forward_pass():
    from taskcomplexity.errors import ConfigError
    from taskcomplexity.policies.primitives import PrimitiveSpec
    from taskcomplexity.rwg import RWGSettings
    from taskcomplexity.stages.rwg_stage import RWGRequest
    from taskcomplexity.tasks.gym_task import GymTask

    narrow = RWGSettings(policies=20, episodes=6, precision="float32")
    with pytest.raises(ConfigError, match=r"rwg\.precision=float32 .* backend=pybullet"):
        RWGRequest(make_task("two_link", "dense"), NetworkSpec(), PriorSpec(), narrow, "pybullet")
    with pytest.raises(ConfigError, match=r"rwg\.precision=float32 .* backend=kernel"):
        RWGRequest(GymTask("Pendulum-v1"), NetworkSpec(), PriorSpec(), narrow)
    with pytest.raises(ConfigError, match=r"rwg\.precision=float32 .* network\.family=dmp"):
        RWGRequest(make_task("two_link", "dense"), PrimitiveSpec(), PriorSpec(), narrow)
    obstacle = make_task("two_link_obstacle", "dense")  # chaotic contacts: float64 whatever the setting
    assert RWGRequest(obstacle, NetworkSpec(), PriorSpec(), narrow).key == \
        RWGRequest(obstacle, NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=6)).key
    with pytest.raises(ConfigError, match=r"rwg\.precision must be one of \['float64', 'float32'\], got 'float16'"):
        RWGSettings(precision="float16").validate()


def test_the_reports_methods_say_which_tasks_ran_a_float32_forward_pass():
    from taskcomplexity.report.methods import float32_note
    from taskcomplexity.rwg import RWGSettings
    from taskcomplexity.stages.rwg_stage import RWGRequest

    narrow = RWGSettings(policies=20, episodes=6, precision="float32")
    requests = [RWGRequest(make_task(arm), NetworkSpec(), PriorSpec(), narrow)
                for arm in ("one_link_1m0", "two_link", "two_link_obstacle")]
    assert float32_note(requests) == "; the policies' forward pass in float32 on 2 of 3 tasks (the others float64)"
    assert float32_note(requests[:2]) == "; the policies' forward pass in float32 on 2 of 2 tasks"
    assert float32_note([RWGRequest(make_task("two_link"), NetworkSpec(), PriorSpec(), RWGSettings())]) == ""
