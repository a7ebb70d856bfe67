"""The movement-primitive family (network=dmp, the paper's first proposal): its controller, its backends, its
config."""

from __future__ import annotations

import re

import numba
import numpy as np
import pytest
import torch

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.families import FAMILIES, network_from_config, sample_family
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.policies.primitives import ArmGeometry, PrimitiveSpec, primitive_parameters, sample_primitives
from taskcomplexity.rwg import RWGSettings, initial_states, resolve_backend, run_rwg
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.tasks.batched import BatchedReaching
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

SPEC = PrimitiveSpec()
ARMS = ["one_link_1m0", "one_link_1m65", "two_link"]


def _episodes(task, weights_scale, policies=6, episodes=8, seed=3):
    """Run DMP policies step by step on the batched env; (returns, success, steps, final joint angles, goal)."""
    prior = PriorSpec(variance=weights_scale**2) if weights_scale else PriorSpec(variance=1e-30)
    batch = sample_primitives(SPEC, prior, task, seed, np.arange(policies))
    q, target = initial_states(task, seed, np.arange(policies), episodes)
    env = BatchedReaching(task, policies * episodes)
    obs = env.reset(torch.from_numpy(q.reshape(policies * episodes, -1)), torch.from_numpy(target.reshape(-1, 2)))
    state = batch.begin(obs.view(policies, episodes, -1))
    for _ in range(task.max_steps):
        action, state = batch.respond(obs.view(policies, episodes, -1), state)
        obs, _, _ = env.step(action.reshape(policies * episodes, -1))
    return env.success.numpy(), state


@pytest.mark.parametrize("arm", ARMS)
def test_the_spring_alone_reaches_every_target(arm):
    """With (almost) zero weights the DMP is the spring to the IK goal, and the tracking controller gets
    the end effector within the 0.05 m threshold in every episode (48 of 48)."""
    success, _ = _episodes(make_task(arm, "dense"), 0.0)
    assert success.all()


@pytest.mark.parametrize("arm", ARMS)
def test_the_plan_starts_at_the_observed_configuration_and_ends_at_the_target(arm):
    task = make_task(arm, "sparse")  # the 1-link sparse task observes unrounded angles; the 2-link rounds
    geometry = ArmGeometry.of(task)
    q, target = initial_states(task, 1, np.arange(4), 5)
    env = BatchedReaching(task, 20)
    obs = env.reset(torch.from_numpy(q.reshape(20, -1)), torch.from_numpy(target.reshape(-1, 2))).view(4, 5, -1)
    batch = sample_primitives(SPEC, PriorSpec(), task, 1, np.arange(4))
    plan = batch.begin(obs).trajectory  # (4, 5, T + 1, J)
    assert plan.shape == (4, 5, task.max_steps + 1, task.arm.dof)
    # start: the observed configuration equals the true one modulo 2π (to the observation's rounding)
    wrapped = np.remainder(plan[:, :, 0] - q + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(wrapped, 0.0, atol=0.005 + 1e-9 if task.rounds_angles else 1e-9)
    # end: forward kinematics of the last planned configuration is (nearly) the target (the spring has
    # settled by then; what remains of the forcing, faded with the phase, moves it by millimetres)
    end = plan[:, :, -1]
    if task.arm.dof == 1:
        tip = geometry.lengths[0] * np.stack([np.cos(end[..., 0]), np.sin(end[..., 0])], -1)
        reach = target[..., 0:1] - geometry.lengths[0]  # the 1-link target sits just beyond the tip's circle
    else:
        l1, l2 = geometry.lengths
        tip = (l1 * np.stack([np.cos(end[..., 0]), np.sin(end[..., 0])], -1)
               + l2 * np.stack([np.cos(end.sum(-1)), np.sin(end.sum(-1))], -1))
        reach = np.zeros(target.shape[:-1] + (1,))
    goal = target[..., :1] * np.stack([np.cos(target[..., 1]), np.sin(target[..., 1])], -1)
    np.testing.assert_allclose(np.linalg.norm(tip - goal, axis=-1), reach[..., 0], atol=0.01)  # 1/5 of the threshold
    # and the plan takes the shorter way round: no joint travels more than π
    assert (np.abs(plan[:, :, -1] - plan[:, :, 0]) <= np.pi + 1e-9).all()


def test_weights_shape_the_movement():
    """Different weights give different plans from the same state; the prior's scale sets how different."""
    task = make_task("two_link", "dense")
    q, target = initial_states(task, 0, np.zeros(3, dtype=int), 1)
    env = BatchedReaching(task, 3)
    obs = env.reset(torch.from_numpy(q.reshape(3, -1)), torch.from_numpy(target.reshape(-1, 2))).view(3, 1, -1)
    spread = []
    for variance in (0.01, 1.0):
        plan = sample_primitives(SPEC, PriorSpec(variance=variance), task, 0, np.arange(3)).begin(obs).trajectory
        spread.append(np.abs(plan[0] - plan[1]).max())
    assert 0 < spread[0] < spread[1]


def test_parameters_are_the_prior_draw_times_the_spring_unit():
    prior = PriorSpec(kind="uniform", low=-2.0, high=2.0)
    w = primitive_parameters(SPEC, prior, 2, seed=4, policy=7)
    assert w.shape == (2, SPEC.basis)
    from taskcomplexity.seeding import policy_generator

    np.testing.assert_array_equal(w, SPEC.weight_unit * prior.draw(policy_generator(4, 7), SPEC.basis, 2))
    assert SPEC.weight_unit == pytest.approx(25.0 * 25.0 / 4)


@pytest.mark.parametrize(("arm", "reward"), [("one_link_1m0", "dense"), ("one_link_1m65", "sparse"),
                                             ("two_link", "dense"), ("two_link", "sparse")])
def test_batched_and_pybullet_backends_agree(arm, reward):
    """The same DMP policies on both backends: equal returns, except episodes whose rounding or threshold
    decision float noise straddles (at most 2 of 48)."""
    task = make_task(arm, reward)
    settings = RWGSettings(policies=8, episodes=6, seed=11)
    fast = run_rwg(task, SPEC, PriorSpec(), settings, "batched")
    slow = run_rwg(task, SPEC, PriorSpec(), settings, "pybullet")
    different = np.abs(fast.returns - slow.returns) > 1e-6
    assert different.sum() <= 2, f"{different.sum()} of {different.size} episodes differ"
    assert fast.success.mean() > 0.5  # goal-directed: most episodes reach the target


def test_obstacle_hand_over_continues_the_plan_on_pybullet():
    """Episodes that reach the block finish on PyBullet with the policy's own state at the hand-over (its
    plan and its last observation), so they equal the episodes run on PyBullet from the start; contact
    episodes are ill-conditioned in PyBullet itself, so only those may differ."""
    task = make_task("two_link_obstacle", "dense")
    settings = RWGSettings(policies=6, episodes=6, seed=2, contacts="pybullet")
    fast = run_rwg(task, SPEC, PriorSpec(), settings, "batched")
    slow = run_rwg(task, SPEC, PriorSpec(), settings, "pybullet")
    assert fast.handoffs > 0
    different = np.abs(fast.returns - slow.returns) > 1e-6
    assert different.sum() <= fast.handoffs // 2, (different.sum(), fast.handoffs)


def test_returns_do_not_depend_on_the_chunking():
    task = make_task("two_link_obstacle", "dense")
    common = dict(policies=9, episodes=5, seed=4, contacts="model")
    whole = run_rwg(task, SPEC, PriorSpec(), RWGSettings(**common, chunk_policies=9), "batched")
    pieces = run_rwg(task, SPEC, PriorSpec(), RWGSettings(**common, chunk_policies=4), "batched")
    np.testing.assert_array_equal(whole.returns, pieces.returns)
    np.testing.assert_array_equal(whole.steps, pieces.steps)


def test_config_picks_the_family_and_refuses_what_it_cannot_run():
    assert isinstance(network_from_config({"hidden": [32, 32]}), NetworkSpec)
    assert network_from_config({"family": "dmp", "basis": 5}) == PrimitiveSpec(basis=5)
    with pytest.raises(ConfigError, match=re.escape(f"network.family must be one of {list(FAMILIES)}, got 'rbf'")):
        network_from_config({"family": "rbf"})
    with pytest.raises(ConfigError, match="network.hidden is not a known key"):
        network_from_config({"family": "dmp", "hidden": [3]})
    with pytest.raises(ConfigError, match="network.movement_steps must be an integer >= 1"):
        network_from_config({"family": "dmp", "movement_steps": 0})
    arm = make_task("two_link", "dense")
    assert resolve_backend(arm, "auto", SPEC) == "batched"
    with pytest.raises(ConfigError, match=r"^network.family=dmp cannot run on backend=gym for task two_link-dense: "
                                          r"the family runs on batched, pybullet \(allowed: auto, batched, pybullet\)$"):
        resolve_backend(arm, "gym", SPEC)
    with pytest.raises(ConfigError, match=r"^network.family=dmp cannot run on backend=auto for task Pendulum-v1: the "
                                          r"family runs on batched, pybullet, the task on kernel, gym \(allowed: "
                                          r"another network.family\)$"):
        resolve_backend(GymTask("Pendulum-v1"), "auto", SPEC)
    with pytest.raises(ConfigError, match=r"^backend=kernel is not available for task two_link-dense with "
                                          r"network.family=dmp \(allowed: auto, batched, pybullet\)$"):
        resolve_backend(arm, "kernel", SPEC)
    with pytest.raises(ConfigError, match="needs a reaching arm"):
        sample_family(GymTask("Pendulum-v1"), SPEC, PriorSpec(), 0, np.arange(2))


def test_the_family_keys_the_returns_and_leaves_the_mlp_keys_alone():
    task = make_task("one_link_1m0", "dense")
    settings = RWGSettings(policies=10, episodes=4)
    mlp = RWGRequest(task, NetworkSpec(), PriorSpec(), settings)
    dmp = RWGRequest(task, SPEC, PriorSpec(), settings)
    assert "family" not in mlp.identity()["network"]  # the default family adds nothing to the MLP keys
    assert dmp.identity()["network"]["family"] == "dmp"
    assert len({mlp.key, dmp.key, RWGRequest(task, PrimitiveSpec(basis=5), PriorSpec(), settings).key}) == 3


@pytest.mark.parametrize("arm", ["one_link_1m0", "two_link"])
def test_a_large_batch_split_over_threads_gets_the_same_actions_bit_for_bit(arm, monkeypatch):
    """respond splits a large batch over policies, one part per thread: every number as on one thread."""
    from taskcomplexity.policies import primitives  # respond reads numba's thread count when it runs

    task = make_task(arm, "dense")
    policies, episodes = 7, 40
    batch = sample_primitives(SPEC, PriorSpec(), task, 5, np.arange(policies))
    q, target = initial_states(task, 5, np.arange(policies), episodes)

    def run(threads: int, per_thread: int):
        monkeypatch.setattr(numba, "get_num_threads", lambda: threads)
        monkeypatch.setattr(primitives, "PARALLEL_ENVIRONMENTS", per_thread)
        env = BatchedReaching(task, policies * episodes)
        obs = env.reset(torch.from_numpy(q.reshape(policies * episodes, -1)), torch.from_numpy(target.reshape(-1, 2)))
        with batch.select(slice(None)) as own:
            state = own.begin(obs.view(policies, episodes, -1))
            actions = []
            for _ in range(12):
                action, state = own.respond(obs.view(policies, episodes, -1), state)
                actions.append(action.numpy().copy())
                obs, _, _ = env.step(action.reshape(policies * episodes, -1))
            split = own._workers is not None
        return np.stack(actions), state.previous, split

    alone, previous, split = run(1, 10**9)
    assert not split
    for threads in (2, 3):
        together, previous_together, split = run(threads, 1)
        assert split and np.array_equal(together, alone) and np.array_equal(previous_together, previous)
    assert np.abs(alone).max() > 0.05  # the actions are not all zero
