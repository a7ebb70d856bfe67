"""A study checks every stage's settings before any work; the library raises, only entry points exit."""

from __future__ import annotations

from pathlib import Path

import pytest
from omegaconf import open_dict

import preloaded
from taskcomplexity.errors import ConfigError
from taskcomplexity.study.run import run_study


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("diagnostics.repeats=1", r"diagnostics\.repeats"),
        ("report.title=5", r"report\.title must be a string or null \(the study's own title\), got 5"),
        ("sac.actor_lr=-1", r"sac\.actor_lr must be a finite number > 0, got -1"),
        ("metrics.bins=1", r"metrics\.bins must be an integer >= 2"),
        # tables beyond this machine's memory: the estimate, not a NumPy MemoryError in the middle of the study
        ("metrics.bins=1e15", r"metrics\.bins = 1,000,000,000,000,000 needs about [\d,.]+ TB of memory, this "
                              r"machine has [\d.]+ GB \(lower it; metrics\.bins=auto gives B = "),
        ("metrics.resamples=1e12", r"metrics\.resamples × N = 1,000,000,000,000 × \d+ needs about [\d,.]+ TB of "
                                   r"memory, this machine has [\d.]+ GB \(lower metrics\.resamples\)"),
    ],
)
def test_a_bad_late_stage_setting_is_refused_before_any_artefact_is_written(compose_config, override, message):
    cfg = compose_config("experiment=smoke", override)
    with pytest.raises(ConfigError, match=message):  # a ConfigError for a notebook, not SystemExit
        run_study(cfg)
    assert not list((Path(cfg.paths.outputs) / "cache").rglob("*.parquet"))  # nothing computed


def test_a_study_task_without_a_sac_budget_is_refused_before_any_work(compose_config):
    cfg = compose_config("experiment=smoke", "sac.total_steps=null")
    with open_dict(cfg):
        cfg.study.tasks[2].sac_steps = None
    with pytest.raises(ConfigError, match=r"no SAC budget for task two_link-dense"):
        run_study(cfg)
    assert not list((Path(cfg.paths.outputs) / "cache").rglob("*.parquet"))


@pytest.mark.parametrize(("overrides", "message"), [
    (("rwg.policies=8",), r"metrics\.batches=5 needs at least 2 policies per batch, but N = 8 .*allowed "
                          r"metrics\.batches <= 4"),
    (("rwg.episodes=3",), r"k-NN estimate needs M > diagnostics\.knn_neighbors = 3 .* but M = 3"),
])
def test_sizes_the_estimators_cannot_use_are_refused_before_any_work(compose_config, overrides, message):
    cfg = compose_config("experiment=smoke", "sac.enabled=false", *overrides)
    with pytest.raises(ConfigError, match=message):
        run_study(cfg)
    assert not list((Path(cfg.paths.outputs) / "cache").rglob("*.parquet"))


def test_a_study_without_sac_budgets_refuses_a_typed_sac_enabled_in_one_line(tmp_path):
    import sys

    root = Path(__file__).resolve().parents[2]
    done = preloaded.run([sys.executable, str(root / "pipelines" / "study.py"), "study=classic_control",
                           "sac.enabled=true", f"paths.outputs={tmp_path}"], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "error: sac.enabled=true: study classic_control gives no SAC budget (sac_steps) to any task, so it has no "
        "SAC reference; set sac.total_steps to train SAC on it"]
    assert not list(tmp_path.rglob("*.parquet"))
