"""SAC actor snapshots: the trained actor's mean action, as an RWG policy, along training and across resumes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch
from tensordict import TensorDict
from torchrl.envs.utils import ExplorationType, set_exploration_type

from taskcomplexity.config import build
from taskcomplexity.rl import SACSettings, train_sac_run
from taskcomplexity.rl.factories import make_actor_critic
from taskcomplexity.rl.snapshots import ActorSnapshots, actor_layers
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task


@pytest.fixture
def smoke(compose_config) -> SACSettings:
    return build(SACSettings, compose_config("sac=smoke").sac, "sac")


@pytest.mark.parametrize("task", [make_task("two_link", "dense"), GymTask("Pendulum-v1")],
                         ids=["two_link (Box ±1)", "Pendulum (Box ±2)"])
def test_a_snapshot_acts_as_the_actor_does_deterministically(task):
    seeds = (3, 7)
    actor, _ = make_actor_critic(task, hidden_sizes=(32, 16), seeds=seeds, goal_conditioned=False)
    with torch.no_grad():  # move the actor away from its initialisation, as training would
        for p in actor.parameters():
            p.add_(0.3 * torch.randn_like(p))
    obs = torch.randn(len(seeds), 25, task.observation_size) * 3
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        expected = actor(TensorDict({"observation": obs}, batch_size=[len(seeds), 25]))["action"].numpy()
    snapshots = ActorSnapshots.stack([0], seeds, [actor_layers(actor, task.action_size)])
    policies = snapshots.policies()
    unit = policies.act(obs.double()).numpy()
    got = decode_actions(task.action_space, unit.reshape(-1, task.action_size)).reshape(expected.shape)
    np.testing.assert_allclose(got, expected, atol=1e-5)  # float32 actor, float64 replay (Pendulum: ×2)
    assert got.std() > 0.05  # not a constant: the test would see a wrong layer


def test_training_keeps_a_snapshot_at_step_0_and_every_checkpoint_and_they_survive_a_resume(smoke, tmp_path):
    task = make_task("one_link_1m0", "dense")
    settings = dataclasses.replace(smoke, seeds=(0, 1))
    curves, snapshots = train_sac_run(task, settings)
    assert snapshots.steps.tolist() == [0, 100, 200, 300]  # checkpoint_every = 100
    assert snapshots.seeds.tolist() == [0, 1]
    assert [w.shape for w in snapshots.weights] == [(4, 2, 9, 256), (4, 2, 256, 256), (4, 2, 256, 1)]
    assert not np.allclose(snapshots.weights[0][0], snapshots.weights[0][-1])  # the actor trained
    # an interrupted run resumes with the snapshots it had and ends with the same ones
    train_sac_run(task, settings, checkpoint_dir=tmp_path, stop_after=200)
    _, resumed = train_sac_run(task, settings, checkpoint_dir=tmp_path)
    assert resumed.steps.tolist() == snapshots.steps.tolist()
    for a, b in zip(resumed.weights + resumed.biases, snapshots.weights + snapshots.biases, strict=True):
        np.testing.assert_array_equal(a, b)
    # saved and loaded bit for bit
    snapshots.save(tmp_path / "actors.npz")
    loaded = ActorSnapshots.load(tmp_path / "actors.npz")
    for a, b in zip(loaded.weights + loaded.biases, snapshots.weights + snapshots.biases, strict=True):
        np.testing.assert_array_equal(a, b)


def test_seeds_trained_one_after_the_other_join_along_the_seed_axis(smoke):
    task = make_task("one_link_1m0", "dense")
    together = train_sac_run(task, dataclasses.replace(smoke, seeds=(0, 1), total_steps=100))[1]
    apart = train_sac_run(task, dataclasses.replace(smoke, seeds=(0, 1), total_steps=100,
                                                    train_seeds_together=False))[1]
    assert apart.seeds.tolist() == [0, 1] and apart.steps.tolist() == together.steps.tolist()
    assert apart.weights[0].shape == together.weights[0].shape
    np.testing.assert_array_equal(apart.weights[0][0], together.weights[0][0])  # step 0: each seed's own init
