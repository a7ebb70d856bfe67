"""The occupancy stage: recorded state–action pairs, W₂ to the trained SAC actor, its tables and its verdict."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import open_dict

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, sample_policies
from taskcomplexity.report.format import of_total
from taskcomplexity.rwg.occupancy import pair_size, record_occupancies
from taskcomplexity.seeding import episode_reset_seeds
from taskcomplexity.stages.occupancy_stage import OccupancySettings, compute_tables
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task
from taskcomplexity.verdict import OUTCOMES

PENDULUM = GymTask("Pendulum-v1")


def _policies(task, indices, seed=4):
    return sample_policies(NetworkSpec(hidden=(8,)), PriorSpec(), task.observation_size, task.action_size, seed,
                           np.asarray(indices))


def test_the_pairs_are_the_policys_own_rwg_episodes():
    policies = _policies(PENDULUM, [5, 9])
    pairs = record_occupancies(PENDULUM, policies, seed=4, episodes=2, pairs=10_000)
    assert [p.shape for p in pairs] == [(400, pair_size(PENDULUM))] * 2  # 2 episodes × 200 steps, obs 3 + action 1
    # the first pair of policy 9: its RWG reset (seed, n=9, e=0), and what the policy did there
    env = PENDULUM.make_env()
    first, _ = env.reset(seed=int(episode_reset_seeds(4, np.array([9]), np.array([0]))[0]))
    np.testing.assert_allclose(pairs[1][0, :3], first)
    obs = torch.from_numpy(np.asarray(first, dtype=np.float64)).view(1, 1, -1).expand(2, 1, -1).contiguous()
    unit = policies.act(obs)[1:2, 0].numpy()
    np.testing.assert_allclose(pairs[1][0, 3:], decode_actions(PENDULUM.action_space, unit)[0], rtol=1e-6)
    # the same seed gives the same pairs; thinning keeps evenly spaced ones
    again = record_occupancies(PENDULUM, _policies(PENDULUM, [9]), seed=4, episodes=2, pairs=40)[0]
    np.testing.assert_array_equal(again, pairs[1][np.linspace(0, 399, 40).round().astype(int)])


def test_discrete_actions_are_one_hot_and_arm_episodes_end_where_the_env_ends_them():
    cart = GymTask("CartPole-v1")
    pairs = record_occupancies(cart, _policies(cart, [0, 1, 2]), seed=0, episodes=3, pairs=10_000)
    for p in pairs:
        assert p.shape[1] == 4 + 2
        np.testing.assert_array_equal(p[:, 4:].sum(axis=1), 1.0)
    arm = make_task("one_link_1m0", "dense")
    pairs = record_occupancies(arm, _policies(arm, [0, 1]), seed=0, episodes=2, pairs=10_000)
    assert all(p.shape[1] == 9 + 1 and p.shape[0] <= 2 * arm.max_steps for p in pairs)
    assert np.all(np.abs(np.concatenate(pairs)[:, 9]) <= 1.0)  # tanh outputs: the arm's clipped action


def test_the_tables_hold_the_mean_its_bootstrap_and_the_welch_batches():
    distances = np.random.default_rng(0).gamma(4.0, 0.5, size=40)
    settings = OccupancySettings(policies=40, resamples=200, batches=4)
    tables = compute_tables(distances, settings, episodes=5, reference_pairs=250)
    row = tables["occupancy.parquet"].iloc[0]
    assert row["ot_distance"] == pytest.approx(distances.mean())
    assert row["ot_distance_variance"] == pytest.approx(distances.var(ddof=1))
    sd = distances.std(ddof=1) / np.sqrt(len(distances))  # the bootstrap sd of a mean is about its standard error
    assert row["ot_distance_sd"] == pytest.approx(sd, rel=0.25)
    assert row["ot_distance_ci_low"] < row["ot_distance"] < row["ot_distance_ci_high"]
    batches = tables["batches.parquet"]
    assert batches["policies"].tolist() == [10] * 4
    np.testing.assert_allclose(batches["ot_distance"], distances.reshape(4, 10).mean(axis=1))


@pytest.mark.parametrize(("key", "value", "match"), [("policies", 5, r"occupancy.policies must be at least 2 × occupancy.batches = 10 .*got 5"),
                                                     ("episodes", 0, "occupancy.episodes must be an integer >= 1"),
                                                     ("batches", 1, "occupancy.batches must be an integer >= 2")])
def test_bad_settings_are_one_line_naming_the_key(key, value, match):
    with pytest.raises(ConfigError, match=match):
        dataclasses.replace(OccupancySettings(), **{key: value}).validate()


@pytest.fixture(scope="module")
def with_sac(tmp_path_factory):
    """Three dense arm tasks at smoke size with SAC trained (200 steps, one seed): the whole chain and its report."""
    from taskcomplexity.study.chain import study_artefacts
    from taskcomplexity.study.plan import read_plan
    from taskcomplexity.study.run import run_study

    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=["experiment=smoke", "sac.total_steps=200", "sac.eval_every=100",
                                           "sac.checkpoint_every=100", "occupancy.policies=10",
                                           "occupancy.batches=2", "occupancy.episodes=2", "occupancy.resamples=50",
                                           "learning_path.policies=10", "learning_path.batches=2",
                                           "learning_path.episodes=4"])
    GlobalHydra.instance().clear()
    with open_dict(cfg):
        cfg.paths.outputs = str(tmp_path_factory.mktemp("occupancy") / "outputs")
        cfg.study.tasks = cfg.study.tasks[:3]
        dense = {"one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense"}
        cfg.study.relations = [r for r in cfg.study.relations if {r.easier, r.harder} <= dense]
        cfg.study.orders = {"dense": ["one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense"]}
    index = run_study(cfg)
    return cfg, study_artefacts(read_plan(cfg)), index


def test_with_sac_trained_every_task_gets_a_distance_and_the_verdict_judges_it(with_sac):
    cfg, artefacts, index = with_sac
    assert set(artefacts.further["occupancy"]) == {"one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense"}
    for artefact in artefacts.further["occupancy"].values():
        distances = pd.read_parquet(artefact.file("distances.parquet"))["distance"]
        assert len(distances) == 10 and np.all(distances > 0) and np.isfinite(distances).all()
    verdict = pd.read_parquet(artefacts.verdict.file("verdict.parquet"))
    judged = verdict[verdict["metric"] == "ot_distance"]
    assert len(judged) == 3  # the three relations among the dense tasks
    assert set(judged["outcome"]) <= set(OUTCOMES) - {"undefined"}  # 2 batches of 5 distances a task: tested
    values = pd.read_parquet(artefacts.verdict.file("values.parquet"))
    assert set(values.loc[values["metric"] == "ot_distance", "task"]) == set(artefacts.further["occupancy"])
    # the report answers the open question from the verdict: one sentence, and the relation-by-relation table
    report = (index.parent / "report.md").read_text()
    agree = int((judged["outcome"] == "agree").sum())
    contradict = int((judged["outcome"] == "contradict").sum())
    agreed = of_total(agree, 3, "known relation")
    assert f"W₂ to SAC's policy agrees with {agreed} and contradicts {contradict}" in report
    table = pd.read_csv(index.parent / "tables" / "beyond_the_paper.csv")
    assert list(table.columns[3:]) == ["PIC", "POIC", "W₂ to SAC's policy", "learning-path PIC",
                                       "learning-path POIC", "PIC under DMPs", "POIC under DMPs"] and len(table) == 3
    assert (index.parent / "figures" / "learning_path.png").stat().st_size > 0
    # the values table: each task's value ± the sd of its batch estimates, both from the verdict artefact
    shown = pd.read_csv(index.parent / "tables" / "beyond_the_paper_values.csv")
    samples = pd.read_parquet(artefacts.verdict.file("samples.parquet"))
    assert len(shown) == 3 and "W₂ to SAC's policy" in shown.columns and "PIC" in shown.columns
    for cell, task in zip(shown["W₂ to SAC's policy"], ["one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense"],
                          strict=True):
        value = values.loc[(values["metric"] == "ot_distance") & (values["task"] == task), "value"].iloc[0]
        batch = samples.loc[(samples["metric"] == "ot_distance") & (samples["task"] == task), "value"]
        mean, sd = (float(x) for x in cell.split(" ± "))
        assert mean == pytest.approx(value, abs=6e-4) and sd == pytest.approx(batch.std(ddof=1), abs=6e-4)


def test_the_learning_path_runs_at_every_sac_snapshot_and_enters_the_verdict(with_sac):
    _, artefacts, _ = with_sac
    paths = artefacts.further["learning_path"]
    assert set(paths) == set(artefacts.further["occupancy"])
    for artefact in paths.values():
        path = pd.read_parquet(artefact.file("path.parquet"))
        assert path["step"].tolist() == [0, 100, 200]  # step 0 and every checkpoint of the 200-step SAC run
        row = pd.read_parquet(artefact.file("learning_path.parquet")).iloc[0]
        assert row["path_pic"] == pytest.approx(path["pic"].mean())
        assert row["path_poic"] == pytest.approx(path["poic"].mean())
        assert (row["policies"], row["episodes"], row["snapshots"]) == (10, 4, 3)
    values = pd.read_parquet(artefacts.verdict.file("values.parquet"))
    assert set(values.loc[values["metric"] == "path_pic", "task"]) == set(paths)


def test_the_occupancy_key_follows_its_settings_and_a_rerun_hits_the_cache(with_sac, caplog):
    from taskcomplexity.study.chain import study_artefacts
    from taskcomplexity.study.plan import read_plan

    cfg, artefacts, _ = with_sac
    again = study_artefacts(read_plan(cfg))
    assert {t: a.key for t, a in again.further["occupancy"].items()} == {t: a.key for t, a in artefacts.further["occupancy"].items()}
    with open_dict(cfg):
        cfg.occupancy.pairs = 50
    changed = study_artefacts(read_plan(cfg))
    assert not set(a.key for a in changed.further["occupancy"].values()) & set(a.key for a in artefacts.further["occupancy"].values())
    assert Path(changed.verdict.path) != Path(artefacts.verdict.path)
