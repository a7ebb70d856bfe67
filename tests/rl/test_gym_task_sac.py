"""SAC on any task: a gymnasium id with Box actions trains (gradient updates happen) and writes a curve;
discrete action spaces are skipped with one line; budgets come from the study file."""

from __future__ import annotations

import logging

import gymnasium
import numpy as np
import pandas as pd
import pytest
import torch
from gymnasium import spaces
from torchrl.envs.utils import ExplorationType, set_exploration_type

from taskcomplexity.commands import sac as sac_command
from taskcomplexity.config import build
from taskcomplexity.errors import ConfigError
from taskcomplexity.rl import CURVE_COLUMNS, SACSettings, train_sac
from taskcomplexity.rl.checkpoint import load_checkpoint
from taskcomplexity.rl.factories import make_actor_critic, make_env, make_loss, success_info_key
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.sac_stage import CURVES, MISSING_ATTR, SKIPPED_ATTR, sac_identity, study_sac_curves
from taskcomplexity.study_data import study_from_config
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

PENDULUM = GymTask("Pendulum-v1")
# Pendulum-v1's reward per step is −(θ² + 0.1·θ̇² + 0.001·u²) ∈ [−16.2736044, 0]; 200 steps per episode.
PENDULUM_WORST_RETURN = -16.2736044 * 200
# One checkpoint segment: the forced reset at a segment boundary would cut Pendulum's 200-step episodes
# short (an episode cut there is not a training return).
SMOKE = SACSettings(total_steps=300, warmup_steps=100, eval_every=100, eval_episodes=2, checkpoint_every=300,
                    seeds=(0,))


@pytest.fixture(scope="module")
def pendulum_run(tmp_path_factory):
    directory = tmp_path_factory.mktemp("pendulum")
    curve = train_sac(PENDULUM, SMOKE, seed=0, checkpoint_dir=directory)
    return curve, load_checkpoint(directory)


def test_sac_on_pendulum_writes_the_documented_curve(pendulum_run):
    curve, _ = pendulum_run
    assert tuple(curve.columns) == CURVE_COLUMNS
    assert curve["env_step"].tolist() == [0, 100, 200, 300]
    assert set(curve["task"]) == {"Pendulum-v1"} and set(curve["variant"]) == {"sac"}
    returns = curve["eval/return_mean"]
    assert np.isfinite(returns).all()
    assert returns.between(PENDULUM_WORST_RETURN, 0.0).all()
    assert (curve["eval/return_std"] >= 0).all()
    # Pendulum's info reports no success and no solved_return was given: unknown, not 0
    assert curve["eval/success_rate"].isna().all()
    # 200-step episodes: the first training episode ends at step 200
    assert curve["train/episode_return"].iloc[:2].isna().all()
    assert curve["train/episode_return"].iloc[2:].between(PENDULUM_WORST_RETURN, 0.0).all()


def test_sac_on_pendulum_makes_one_gradient_update_per_step_after_warm_up(pendulum_run):
    _, checkpoint = pendulum_run
    for optimiser in checkpoint["optimisers"]:
        assert {int(state["step"]) for state in optimiser["state"].values()} == {300 - 100}
    actor, critics = make_actor_critic(PENDULUM, hidden_sizes=SMOKE.hidden_sizes, seeds=(0,), goal_conditioned=False)
    initial = make_loss(actor, critics, gamma=0.99, alpha=0.2, loss_function="l2").state_dict()
    actor_keys = [k for k in checkpoint["loss"] if k.startswith("actor_network_params")]
    assert actor_keys and all(not torch.equal(checkpoint["loss"][k], initial[k]) for k in actor_keys)


def test_the_actor_acts_within_the_box_bounds_of_the_task():
    """Pendulum's torque is in [−2, 2]: the tanh output is scaled there, not left in [−1, 1]."""
    actor, _ = make_actor_critic(PENDULUM, hidden_sizes=(16, 16), seeds=(0,), goal_conditioned=False)
    env = make_env(PENDULUM, 1, goal_conditioned=False)
    try:
        td = env.reset(seed=[0]).expand(1, 4000).clone()  # (seeds, samples)
        with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
            actions = actor(td).get("action")
    finally:
        env.close()
    assert actions.shape == (1, 4000, 1)
    assert actions.abs().max() <= 2.0
    # The initial policy's Gaussian has scale ≈ softplus(0)+ ≈ 0.7 before tanh, so about a quarter of
    # the samples land beyond ±1 once scaled by 2: far from none.
    assert (actions.abs() > 1.0).float().mean() > 0.1
    assert actor.spec["action"].space.high.max() == 2.0


def test_discrete_actions_are_refused_with_one_line():
    with pytest.raises(ConfigError, match=r"SAC cannot run on task CartPole-v1: discrete actions") as err:
        train_sac(GymTask("CartPole-v1"), SMOKE, seed=0)
    assert "\n" not in str(err.value)


def test_her_on_a_gym_task_is_refused_with_one_line():
    with pytest.raises(ConfigError, match=r"sac\.her=true needs a goal-conditioned view, and task Pendulum-v1 has none"):
        train_sac(PENDULUM, SACSettings(total_steps=300, warmup_steps=100, her=True), seed=0)


def _study(*entries) -> object:
    return study_from_config({"name": "t", "tasks": list(entries)})


def test_the_study_skips_discrete_tasks_with_one_log_line_and_says_so_in_the_curves(tmp_path, caplog):
    study = _study({"id": "cart", "task": "cartpole"})
    with caplog.at_level(logging.INFO, logger="taskcomplexity.stages.sac_stage"):
        curves = study_sac_curves(Cache(tmp_path), [(study.task("cart"), GymTask("CartPole-v1"))], {})
    assert curves.empty and tuple(curves.columns) == CURVE_COLUMNS
    assert curves.attrs[SKIPPED_ATTR] == {"cart": "discrete actions"}
    assert [r.getMessage() for r in caplog.records] == ["SAC skipped for cart: discrete actions"]
    assert not (tmp_path / "sac").exists()  # nothing trained, nothing cached


def test_the_study_refuses_a_task_without_a_budget_naming_sac_total_steps(tmp_path):
    study = _study({"id": "pend", "task": "pendulum"})
    with pytest.raises(ConfigError, match=r"no SAC budget for task pend: set sac\.total_steps"):
        study_sac_curves(Cache(tmp_path), [(study.task("pend"), PENDULUM)], {"total_steps": None})
    assert not (tmp_path / "sac").exists()


def test_each_study_task_trains_for_its_own_budget_and_solved_return_scores_it(tmp_path):
    study = _study({"id": "pend", "task": "pendulum", "sac_steps": 200, "solved_return": -1.0e6})
    node = {"seeds": [0], "warmup_steps": 100, "eval_every": 100, "eval_episodes": 1, "hidden_sizes": [16, 16],
            "checkpoint_every": 100}
    curves = study_sac_curves(Cache(tmp_path), [(study.task("pend"), PENDULUM)], node)
    assert curves["env_step"].tolist() == [0, 100, 200]  # the entry's sac_steps, not the default
    assert set(curves["task"]) == {"pend"}  # the study's id
    assert (curves["eval/success_rate"] == 1.0).all()  # every Pendulum return is above −10⁶
    assert curves.attrs[SKIPPED_ATTR] == {}
    # the cache key hashes the resolved budget (and the threshold), and a second call reuses the artefact
    (key_dir,) = [p for p in (tmp_path / "sac").iterdir() if not p.name.startswith(".")]
    again = study_sac_curves(Cache(tmp_path), [(study.task("pend"), PENDULUM)], node)
    pd.testing.assert_frame_equal(again, curves)
    assert pd.read_parquet(key_dir / CURVES)["env_step"].max() == 200
    settings = build(SACSettings, {**node, "total_steps": 200}, "sac")
    assert sac_identity(PENDULUM, settings, solved_return=-1.0e6)["settings"]["total_steps"] == 200


def test_cached_only_shows_the_curves_the_cache_holds_and_never_trains(tmp_path):
    study = _study({"id": "pend", "task": "pendulum", "sac_steps": 200})
    node = {"seeds": [0], "warmup_steps": 100, "eval_every": 100, "eval_episodes": 1, "hidden_sizes": [16, 16],
            "checkpoint_every": 100}
    tasks = [(study.task("pend"), PENDULUM)]
    empty = study_sac_curves(Cache(tmp_path), tasks, node, cached_only=True)
    assert empty.empty and empty.attrs[MISSING_ATTR] == ["pend"]
    assert not (tmp_path / "sac").exists()  # nothing trained, nothing written
    trained = study_sac_curves(Cache(tmp_path), tasks, node)
    shown = study_sac_curves(Cache(tmp_path), tasks, node, cached_only=True)
    pd.testing.assert_frame_equal(shown, trained)
    assert shown.attrs[MISSING_ATTR] == []
    # other settings are another curve: not shown
    other = study_sac_curves(Cache(tmp_path), tasks, {**node, "seeds": [1]}, cached_only=True)
    assert other.empty and other.attrs[MISSING_ATTR] == ["pend"]
    # a task without a budget has no curve to show: missing, not an error (nothing is trained)
    unbudgeted = _study({"id": "pend", "task": "pendulum"})
    none = study_sac_curves(Cache(tmp_path), [(unbudgeted.task("pend"), PENDULUM)], node, cached_only=True)
    assert none.empty and none.attrs[MISSING_ATTR] == ["pend"]


class _Flag(gymnasium.Env):
    """One float to push; the info's ``is_success`` is ``succeed`` from the first step on."""

    def __init__(self, succeed: bool = True):
        self.succeed = succeed
        self.observation_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)
        self.action_space = spaces.Box(-3.0, 3.0, (1,), dtype=np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action):
        return np.zeros(1, dtype=np.float32), float(-abs(action[0])), False, False, {"is_success": self.succeed}


gymnasium.register("TaskcomplexityTestFlag-v0", entry_point=_Flag, max_episode_steps=10)


@pytest.mark.parametrize("succeed", [True, False])
def test_success_is_read_from_the_envs_info_when_it_reports_it(succeed):
    task = GymTask("TaskcomplexityTestFlag-v0", kwargs={"succeed": succeed})
    assert success_info_key(task) == "is_success"
    assert success_info_key(PENDULUM) is None and success_info_key(make_task("one_link_1m0", "dense")) is None
    tiny = SACSettings(total_steps=40, warmup_steps=20, eval_every=20, eval_episodes=2, checkpoint_every=40,
                       seeds=(0,), hidden_sizes=(8, 8))
    # a solved_return every return reaches is ignored: the env's own report wins
    curve = train_sac(task, tiny, seed=0, solved_return=-1.0e6)
    assert curve["eval/success_rate"].tolist() == [float(succeed)] * 3


def test_pipelines_sac_finds_the_budget_of_the_composed_task_in_the_study(compose_config):
    cfg = compose_config("arm=two_link", "reward=sparse")
    entry = sac_command.study_entry_for(cfg, sac_command.task_from_config(cfg))
    assert (entry.id, entry.sac_steps) == ("two_link-sparse", 200_000)
    # a modified arm is not the study's task
    cfg = compose_config("arm=two_link", "reward=sparse", "arm.links.0.mass=7")
    assert sac_command.study_entry_for(cfg, sac_command.task_from_config(cfg)) is None


def test_pipelines_sac_without_a_budget_fails_with_one_line_naming_sac_total_steps(compose_config, capsys):
    with pytest.raises(SystemExit):
        sac_command.run(compose_config("task=pendulum"))
    err = capsys.readouterr().err.strip()
    assert "sac.total_steps" in err and "Pendulum-v1" in err and len(err.splitlines()) == 1


def test_pipelines_sac_trains_a_gym_task_into_the_cache(compose_config, tmp_path):
    cfg = compose_config("task=pendulum", "sac=smoke", "sac.eval_episodes=1")
    artefact = sac_command.run(cfg)
    curve = pd.read_parquet(artefact.file(CURVES))
    assert curve["env_step"].tolist() == [0, 100, 200, 300]
    assert curve["eval/return_mean"].between(PENDULUM_WORST_RETURN, 0.0).all()


def test_the_training_plan_counts_what_is_left_and_drops_what_the_cache_holds(tmp_path):
    from taskcomplexity.rl import with_budget
    from taskcomplexity.stages.sac_stage import SEED_STEPS_PER_SECOND, training_plan

    study = _study({"id": "pend", "task": "pendulum", "sac_steps": 200})
    node = {"seeds": [0, 1], "warmup_steps": 100, "eval_every": 100, "eval_episodes": 1, "hidden_sizes": [16, 16],
            "checkpoint_every": 100}
    runs = [(study.task("pend"), PENDULUM, with_budget(build(SACSettings, node, "sac"), 200, task_id="pend"))]
    minutes = max(1, round(400 / SEED_STEPS_PER_SECOND / 60))
    assert training_plan(Cache(tmp_path), runs).startswith(f"1 of 1 runs to train, 400 seed-steps: about {minutes} min")
    study_sac_curves(Cache(tmp_path), [(study.task("pend"), PENDULUM)], node)
    assert training_plan(Cache(tmp_path), runs) == "all 1 runs in the cache"
