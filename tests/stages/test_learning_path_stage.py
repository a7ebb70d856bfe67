"""Learning-path PIC/POIC: policies around SAC's actor snapshots, run on RWG's backends, estimated along the path."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
import torch

from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.learning_path import LearningPath
from taskcomplexity.metrics.sample import Estimation, Sample
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rl.factories import make_actor_critic
from taskcomplexity.rl.snapshots import ActorSnapshots, actor_layers
from taskcomplexity.rwg import RWGSettings, simulate_chunk
from taskcomplexity.rwg.given_policies import run_policies
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.learning_path_stage import LearningPathSettings, chosen_snapshots, run_learning_path_stage
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

ARM = make_task("one_link_1m0", "dense")


def _snapshots(task, seeds=(0, 1), count=2) -> ActorSnapshots:
    """``count`` snapshots of an (untrained, then shifted) actor, as SAC would store them."""
    actor, _ = make_actor_critic(task, hidden_sizes=(16, 16), seeds=seeds, goal_conditioned=False)
    layers = []
    for _ in range(count):
        layers.append(actor_layers(actor, task.action_size))
        with torch.no_grad():
            for p in actor.parameters():
                p.add_(0.5)
    return ActorSnapshots.stack(np.arange(count) * 100, seeds, layers)


@pytest.mark.parametrize(("task", "backend"), [(ARM, "batched"), (ARM, "pybullet"), (GymTask("Pendulum-v1"), "kernel"),
                                               (GymTask("Pendulum-v1"), "gym")])
def test_given_policies_run_exactly_as_rwg_runs_the_same_policies(task, backend):
    network = NetworkSpec(hidden=(8,))
    settings = RWGSettings(policies=4, episodes=3, seed=5)
    reference = simulate_chunk(task, network, PriorSpec(), settings, 2, 4, backend=backend)
    from taskcomplexity.policies.mlp import sample_policies

    policies = sample_policies(network, PriorSpec(), task.observation_size, task.action_size, 5, np.arange(2, 4))
    got = run_policies(task, policies, seed=5, episodes=3, backend=backend)
    np.testing.assert_array_equal(got.returns, reference.returns)
    np.testing.assert_array_equal(got.steps, reference.steps)


def test_perturbations_are_gaussian_per_policy_and_vanish_with_sigma():
    snapshots = _snapshots(ARM)
    copies = snapshots.around(1, sigma=0.0, seed=0, indices=np.arange(3), seed_index=1)
    actor = snapshots.policies(1)
    for w, w0 in zip(copies.weights, actor.weights, strict=True):
        np.testing.assert_array_equal(w.numpy(), np.broadcast_to(w0.numpy()[1], w.shape))
    wide = snapshots.around(1, sigma=2.0, seed=0, indices=np.arange(200))
    eps = np.concatenate([((w - snapshots.policies(1).weights[i][0]) / 2.0).numpy().ravel()
                          for i, w in enumerate(wide.weights)])
    assert eps.mean() == pytest.approx(0.0, abs=0.01) and eps.std() == pytest.approx(1.0, rel=0.01)  # 7 and 5 SE
    # policy n's ε depends on (seed, k, n) only
    alone = snapshots.around(1, sigma=2.0, seed=0, indices=np.array([4]))
    np.testing.assert_array_equal(alone.weights[0].numpy()[0], wide.weights[0].numpy()[4])
    other_k = snapshots.around(0, sigma=2.0, seed=0, indices=np.array([4]))
    assert not np.allclose(other_k.weights[0].numpy() - snapshots.policies(0).weights[0].numpy()[0],
                           alone.weights[0].numpy() - snapshots.policies(1).weights[0].numpy()[0])


def test_with_sigma_zero_the_path_pic_is_that_of_copies_of_one_policy_zero():
    snapshots = _snapshots(ARM)
    samples = []
    for k in range(2):
        policies = snapshots.around(k, sigma=0.0, seed=0, indices=np.arange(20))
        run = run_policies(ARM, policies, seed=0, episodes=6, backend="batched", common_initial_states=True)
        assert np.ptp(run.returns, axis=0).max() == 0.0  # identical policies, common starts: identical rows
        samples.append(Sample(run.returns, Estimation(bins=200, resamples=20)))
    path = LearningPath(snapshots.steps, tuple(samples))
    assert path.pic == pytest.approx(0.0, abs=1e-12)  # H(R) − H(R|Θ) of equal histograms: rounding only
    assert path.poic == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(path.draws("pic"), 0.0, atol=1e-12)
    # and with σ > 0 the policies differ, so the return depends on the policy
    run = run_policies(ARM, snapshots.around(1, sigma=1.0, seed=0, indices=np.arange(20)), seed=0, episodes=6,
                       backend="batched", common_initial_states=True)
    assert np.ptp(run.returns, axis=0).max() > 1.0 and Sample(run.returns, Estimation(bins=200)).pic.pic > 0.1


def test_the_path_mean_and_its_bootstrap_use_the_same_rows_at_every_snapshot():
    rng = np.random.default_rng(0)
    matrices = [rng.normal(size=(30, 8)) + rng.normal(size=(30, 1)) * s for s in (0.5, 2.0, 4.0)]
    estimation = Estimation(bins=50, resamples=40)
    path = LearningPath(np.array([0, 10, 20]), tuple(Sample(m, estimation) for m in matrices))
    assert path.pic == pytest.approx(np.mean([Sample(m, estimation).pic.pic for m in matrices]))
    np.testing.assert_allclose(path.draws("pic"),
                               np.mean([Sample(m, estimation).bootstrap["pic"] for m in matrices], axis=0))
    rows = np.arange(10, 20)
    assert path.subsample(rows).pic == pytest.approx(np.mean([Sample(m[rows], estimation).pic.pic for m in matrices]))
    assert list(path.curve()["step"]) == [0, 10, 20]
    with pytest.raises(ValueError, match="same policies"):
        LearningPath(np.array([0, 1]), (Sample(matrices[0], estimation), Sample(matrices[1][:10], estimation)))


def test_snapshot_choice_and_bad_settings():
    assert chosen_snapshots(6, 1) == [0, 1, 2, 3, 4, 5]
    assert chosen_snapshots(6, 4) == [0, 4, 5]  # the last one always
    assert chosen_snapshots(1, 3) == [0]
    for key, value, match in (("sigma", -1.0, "learning_path.sigma must be a finite number >= 0, got -1.0"),
                              ("policies", 3, "learning_path.policies must be at least 2 × learning_path.batches"),
                              ("every", 0, "learning_path.every must be an integer >= 1, got 0"),
                              ("bins", 1, "learning_path.bins must be an integer >= 2 or null .metrics.bins., got 1")):
        with pytest.raises(ConfigError, match=match):
            dataclasses.replace(LearningPathSettings(), **{key: value}).validate()


def test_the_path_estimates_at_its_own_bins_not_at_the_studys(tmp_path):
    """N × M returns per snapshot at the study's B = 10⁵ put every return in a bin of its own, so PIC_k is
    about ln(N·M) − ln M = ln N (less only by tied returns) whatever the policies do; ``learning_path.bins`` gives the path its own B."""
    snapshots = _snapshots(ARM, seeds=(0,), count=2)
    snapshots.save(tmp_path / "actors.npz")
    request = RWGRequest(ARM, NetworkSpec(hidden=(16, 16)), PriorSpec(), RWGSettings(policies=20, episodes=6))
    metrics = MetricsSettings(bins=100_000, resamples=20)
    cache = Cache(tmp_path / "cache")

    def path_of(settings):
        artefact, _ = run_learning_path_stage(cache, request, "sac-key", tmp_path / "actors.npz", settings, metrics)
        return artefact, pd.read_parquet(artefact.file("path.parquet"))

    study_b = LearningPathSettings(policies=20, episodes=6, batches=2, sigma=1.0, bins=None)
    own_b = dataclasses.replace(study_b, bins=12)
    saturated, curve = path_of(study_b)
    assert (curve["pic"] <= np.log(20) + 1e-12).all() and (curve["pic"] > np.log(20) - 0.1).all()  # ~ceiling
    artefact, curve = path_of(own_b)
    assert artefact.key != saturated.key
    for k, pic in enumerate(curve["pic"]):
        policies = snapshots.around(k, sigma=1.0, seed=0, indices=np.arange(20))
        returns = run_policies(ARM, policies, seed=0, episodes=6, backend="batched").returns
        assert pic == pytest.approx(Sample(returns, Estimation(bins=12, resamples=20)).pic.pic, rel=1e-12)
        assert pic < np.log(20) - 0.5
