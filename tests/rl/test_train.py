"""End to end: the smoke configuration trains (gradient updates happen) and writes a tidy learning curve."""

from __future__ import annotations

import dataclasses
import random

import numpy as np
import pandas as pd
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.config import build
from taskcomplexity.errors import ArtefactError, ConfigError
from taskcomplexity.rl import CURVE_COLUMNS, SACSettings, train_sac, train_sac_seeds
from taskcomplexity.rl.checkpoint import load_checkpoint
from taskcomplexity.rl.factories import make_actor_critic, make_collector, make_env, make_loss
from taskcomplexity.tasks.spec import make_task

TASK = make_task("one_link_1m0", "dense")


@pytest.fixture
def smoke(compose_config) -> SACSettings:
    """taskcomplexity/conf/sac/smoke.yaml: 300 steps, 100 of warm-up, evaluation every 100 steps."""
    return build(SACSettings, compose_config("sac=smoke").sac, "sac")


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    """One smoke run of ``train_sac`` with a checkpoint directory, and the global state around it."""
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        settings = build(SACSettings, compose("config", overrides=["sac=smoke"]).sac, "sac")
    GlobalHydra.instance().clear()
    directory = tmp_path_factory.mktemp("smoke")

    def global_state():
        numpy_key = np.random.get_state()[1].copy()  # noqa: NPY002 - the legacy global generator is the point
        return torch.get_rng_state(), numpy_key, random.getstate(), torch.get_num_threads()

    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(123)
        before = global_state()
        curve = train_sac(TASK, settings, seed=0, checkpoint_dir=directory)
        after = global_state()
    return settings, directory, curve, before, after


def test_smoke_run_writes_the_documented_columns_one_row_per_evaluation(smoke_run):
    settings, _, curve, *_ = smoke_run
    assert tuple(curve.columns) == CURVE_COLUMNS
    assert curve["env_step"].tolist() == [0, 100, 200, 300]  # step 0, every eval_every, the end
    assert curve["env_step"].is_monotonic_increasing
    assert set(curve["task"]) == {"one_link_1m0-dense"}
    assert set(curve["variant"]) == {"sac"}
    assert set(curve["seed"]) == {0}
    assert curve["eval/return_mean"].notna().all() and np.isfinite(curve["eval/return_mean"]).all()
    assert (curve["eval/return_std"] >= 0).all()
    assert curve["eval/success_rate"].between(0, 1).all()
    # 50-step episodes: a training episode has ended by step 100, none before step 0
    assert np.isnan(curve["train/episode_return"].iloc[0]) and curve["train/episode_return"].iloc[1:].notna().all()
    assert curve["time/seconds"].is_monotonic_increasing


def test_smoke_run_makes_one_gradient_update_per_step_after_warm_up(smoke_run):
    settings, directory, *_ = smoke_run
    checkpoint = load_checkpoint(directory)
    updates = settings.total_steps - settings.warmup_steps  # 200
    for optimiser in checkpoint["optimisers"]:
        steps = {int(state["step"]) for state in optimiser["state"].values()}
        assert steps == {updates}
    # and the trained actor differs from its initialisation (same seed → same initial weights)
    actor, critics = make_actor_critic(TASK, hidden_sizes=settings.hidden_sizes, seeds=(0,), goal_conditioned=False)
    initial = make_loss(actor, critics, gamma=0.99, alpha=0.2, loss_function="l2").state_dict()
    trained = checkpoint["loss"]
    actor_keys = [k for k in trained if k.startswith("actor_network_params")]
    assert actor_keys
    for key in actor_keys:
        assert not torch.equal(trained[key], initial[key]), key


def test_training_leaves_the_callers_random_state_and_threads_untouched(smoke_run):
    *_, before, after = smoke_run
    assert torch.equal(before[0], after[0])
    assert np.array_equal(before[1], after[1])
    assert before[2] == after[2] and before[3] == after[3]


def test_a_finished_run_is_returned_from_its_checkpoint_and_a_foreign_checkpoint_is_refused(smoke_run):
    settings, directory, curve, *_ = smoke_run
    again = train_sac(TASK, settings, seed=0, checkpoint_dir=directory)
    pd.testing.assert_frame_equal(again, curve)
    with pytest.raises(ArtefactError, match="belongs to a different run"):
        train_sac(TASK, dataclasses.replace(settings, alpha=0.3), seed=0, checkpoint_dir=directory)


def test_the_collector_acts_with_the_parameters_the_loss_trains():
    actor, critics = make_actor_critic(TASK, hidden_sizes=(8, 8), seeds=(0, 1), goal_conditioned=False)
    loss = make_loss(actor, critics, gamma=0.99, alpha=0.2, loss_function="l2")
    trained = {p.data_ptr() for p in loss.actor_network_params.values(True, True)}
    env = make_env(TASK, 2, goal_conditioned=False)
    collector = make_collector(env, actor, frames_per_batch=4, init_random_frames=0)
    try:
        assert {p.data_ptr() for p in collector.policy.parameters()} == trained
    finally:
        collector.shutdown()


def test_a_seed_gets_the_same_initial_networks_whatever_it_trains_with():
    alone, _ = make_actor_critic(TASK, hidden_sizes=(8, 8), seeds=(3,), goal_conditioned=False)
    group, _ = make_actor_critic(TASK, hidden_sizes=(8, 8), seeds=(0, 3), goal_conditioned=False)
    for a, g in zip(alone.parameters(), group.parameters(), strict=True):
        assert torch.equal(a[0], g[1])


def test_her_on_the_obstacle_task_is_refused_naming_the_task(smoke):
    with pytest.raises(ConfigError, match="two_link_obstacle-dense has no goal-conditioned view"):
        train_sac_seeds(make_task("two_link_obstacle", "dense"), dataclasses.replace(smoke, her=True))


def test_seeds_trained_one_by_one_are_each_the_one_seed_run(tmp_path):
    tiny = SACSettings(
        total_steps=60, warmup_steps=20, eval_every=30, eval_episodes=1, checkpoint_every=60, seeds=(0, 1),
        train_seeds_together=False, hidden_sizes=(16, 16),
    )
    curves = train_sac_seeds(TASK, tiny, checkpoint_dir=tmp_path)
    assert curves["seed"].tolist() == [0, 0, 0, 1, 1, 1]
    assert (tmp_path / "seed-0").is_dir() and (tmp_path / "seed-1").is_dir()
    alone = train_sac(TASK, tiny, seed=1)
    columns = [c for c in CURVE_COLUMNS if c != "time/seconds"]
    pd.testing.assert_frame_equal(curves[curves["seed"] == 1][columns].reset_index(drop=True), alone[columns])


def test_a_run_on_the_cpu_by_name_is_the_default_run_and_a_checkpoint_serves_both(tmp_path):
    tiny = SACSettings(total_steps=60, warmup_steps=20, eval_every=30, eval_episodes=1, checkpoint_every=60,
                       seeds=(0,), hidden_sizes=(16, 16))
    default = train_sac(TASK, tiny, seed=0, checkpoint_dir=tmp_path)
    named = train_sac(TASK, dataclasses.replace(tiny, device="cpu"), seed=0)
    columns = [c for c in CURVE_COLUMNS if c != "time/seconds"]
    pd.testing.assert_frame_equal(named[columns], default[columns])
    # the finished checkpoint of the default run is this run's too: the device is no part of a CPU run's identity
    again = train_sac(TASK, dataclasses.replace(tiny, device="cpu"), seed=0, checkpoint_dir=tmp_path)
    pd.testing.assert_frame_equal(again, default)
