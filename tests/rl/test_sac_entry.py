"""``sac.entry``: one study task's SAC runs from ``pipelines/sac.py`` (a job of ``make paper-jobs``) land under
the keys the study's chain looks up, so the study reads them from the cache and trains nothing."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from taskcomplexity.commands import sac as sac_command
from taskcomplexity.errors import ConfigError
from taskcomplexity.rl import WALL_CLOCK
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.sac_stage import MISSING_ATTR, study_sac_curves
from taskcomplexity.study.plan import read_plan, study_requests

SMOKE = ("experiment=smoke", "sac.eval_episodes=1", "sac.total_steps=200", "sac.seeds=[0]")


def test_a_study_tasks_runs_are_the_ones_the_study_finds(compose_config):
    cfg = compose_config(*SMOKE, "sac.entry=two_link-sparse")
    trained = sac_command.run(cfg)
    assert set(trained["variant"]) == {"sac", "sac+her"}  # every variant the study makes on a sparse task
    assert set(trained["task"]) == {"two_link-sparse"} and trained["env_step"].max() == 200

    study_cfg = compose_config(*SMOKE, f"paths.outputs={cfg.paths.outputs}")
    entries = {entry.id: (entry, request.task) for entry, request in study_requests(study_cfg)}
    cache = Cache(Path(study_cfg.paths.cache))
    found = study_sac_curves(cache, [entries["two_link-sparse"]], study_cfg.sac, cached_only=True)
    assert found.attrs[MISSING_ATTR] == []
    pd.testing.assert_frame_equal(found.reset_index(drop=True), trained.reset_index(drop=True))
    # another task was not trained
    other = study_sac_curves(cache, [entries["two_link-dense"]], study_cfg.sac, cached_only=True)
    assert other.attrs[MISSING_ATTR] == ["two_link-dense"]


def test_an_id_outside_the_study_is_refused_naming_the_allowed_ones(compose_config):
    with pytest.raises(ConfigError, match=r"sac.entry=two_link-dnese is not a task of study seven_tasks "
                                          r"\(allowed: one_link_1m0-dense, .*two_link-sparse\)"):
        sac_command.train_study_task(compose_config(*SMOKE), "two_link-dnese")


def test_the_study_refuses_sac_entry_before_any_work(compose_config):
    with pytest.raises(ConfigError, match=r"sac.entry=two_link-sparse is read by pipelines/sac.py"):
        read_plan(compose_config(*SMOKE, "sac.entry=two_link-sparse"))
    with pytest.raises(ConfigError, match=r"sac.entry must be a study task's id or null, got ''"):
        read_plan(compose_config(*SMOKE, "sac.entry=''"))


def test_a_task_sac_skips_is_skipped_as_the_study_skips_it(compose_config):
    curves = sac_command.run(compose_config("study=classic_control", "sac=smoke", "sac.entry=CartPole-v0"))
    assert curves.empty and "discrete" in curves.attrs["sac_skipped"]["CartPole-v0"]


def test_runs_trained_at_once_in_their_own_processes_are_the_runs_trained_one_by_one(compose_config, tmp_path, caplog):
    cfg = compose_config(*SMOKE)
    entries = {entry.id: (entry, request.task) for entry, request in study_requests(cfg)}
    tasks = [entries["one_link_1m0-sparse"]]  # two runs: SAC and SAC + HER
    node = {**cfg.sac, "workers": 1}
    one_by_one = study_sac_curves(Cache(tmp_path / "one"), tasks, node)
    with caplog.at_level("INFO", logger="taskcomplexity.stages.sac_stage"):
        at_once = study_sac_curves(Cache(tmp_path / "two"), tasks, {**node, "workers": 2})
    trained = [r.getMessage() for r in caplog.records if "computed in" in r.getMessage()]
    assert len(trained) == 2 and "2 at once" in caplog.text  # each run logged once, as its process ended
    columns = [c for c in one_by_one.columns if not c.startswith(WALL_CLOCK)]
    assert len(one_by_one) == len(at_once) > 0
    pd.testing.assert_frame_equal(at_once[columns].reset_index(drop=True), one_by_one[columns].reset_index(drop=True))
    assert at_once.attrs[MISSING_ATTR] == [] and set(at_once.attrs["sac_actors"]) == {t.id for t, _ in tasks}
