"""Nothing typed is ignored and every message is true: a study's own N, M against an
explicit ``rwg.policies``/``rwg.episodes``; a SAC refusal that leaves nothing in the cache; a full disk
named by its path; the occupancy stage's reason for a task it leaves out."""

from __future__ import annotations

import errno
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import preloaded
from taskcomplexity.rl.factories import make_actor_critic
from taskcomplexity.rl.snapshots import ActorSnapshots, actor_layers

ROOT = Path(__file__).resolve().parents[2]


def pipeline(name: str, args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``python pipelines/<name>.py <args>`` as a user runs it (no HYDRA_FULL_ERROR)."""
    environment = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    return preloaded.run([sys.executable, str(ROOT / "pipelines" / f"{name}.py"), *args], cwd=cwd,
                         env=environment, capture_output=True, text=True, timeout=300)


# -- a study's own N, M ------------------------------------------------------------------------------

def test_an_experiments_n_and_m_win_over_the_studys_own_and_the_log_says_so(compose_config, caplog):
    from taskcomplexity.study.plan import study_requests

    with caplog.at_level(logging.INFO, logger="taskcomplexity"):
        requests = [r for _, r in study_requests(compose_config("study=classic_control", "experiment=smoke"))]
    assert len(requests) == 5
    assert {(r.settings.policies, r.settings.episodes) for r in requests} == {(10, 4)}  # not 1000 × 1000
    assert ("rwg.policies=10 (set by the experiment) wins over study.policies=1000 of study classic_control, "
            "for every task") in caplog.text
    assert "rwg.episodes=4 (set by the experiment) wins over study.episodes=1000" in caplog.text


def test_without_an_explicit_n_and_m_the_studys_own_apply(compose_config, caplog):
    from taskcomplexity.study.plan import study_requests

    with caplog.at_level(logging.INFO, logger="taskcomplexity"):
        requests = [r for _, r in study_requests(compose_config("study=classic_control"))]
    assert {(r.settings.policies, r.settings.episodes) for r in requests} == {(1000, 1000)}
    assert "wins over" not in caplog.text
    # a study without its own N, M takes rwg's
    requests = [r for _, r in study_requests(compose_config("study=seven_tasks", "rwg.policies=12"))]
    assert {(r.settings.policies, r.settings.episodes) for r in requests} == {(12, 100)}


def test_a_typed_rwg_episodes_wins_even_at_the_rwg_groups_own_value(tmp_path):
    # rwg.episodes=100 is rwg/default.yaml's own value: only the command line tells it was asked for. The
    # diagnostics' k-NN settings make the plan fail before any work, with the M the study would run.
    done = pipeline("study", ["study=classic_control", "rwg.episodes=100", "diagnostics.knn_neighbors=5000",
                              "diagnostics.knn_episodes_per_policy=6000", f"paths.outputs={tmp_path}"], tmp_path)
    assert done.returncode == 2, done.stderr[-2000:]
    assert ("rwg.episodes=100 (typed on the command line) wins over study.episodes=1000 of study classic_control, "
            "for every task") in done.stdout
    assert "but M = 100 (rwg.episodes or study.episodes)" in done.stderr.strip().splitlines()[-1]
    assert not (tmp_path / "cache").exists()


def test_a_typed_study_n_beside_a_different_typed_rwg_n_is_refused_in_one_line(tmp_path):
    done = pipeline("study", ["study=classic_control", "rwg.policies=10", "study.policies=50",
                              f"paths.outputs={tmp_path}"], tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "error: rwg.policies=10 and study.policies=50 disagree: give one (study.policies sets every task of the "
        "study, rwg.policies wins over the study file)"]


# -- SAC's refusal ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("args", "message"), [
    (["task=cartpole", "sac.total_steps=100"],
     "error: SAC cannot run on task CartPole-v1: discrete actions (Discrete(2); SAC needs a Box)"),
    (["task=pendulum", "sac.total_steps=100", "sac.her=true"],
     "error: sac.her=true needs a goal-conditioned view, and task Pendulum-v1 has none (allowed: the reaching arms "
     "without an obstacle)"),
])
def test_a_task_sac_cannot_train_is_refused_before_the_cache_holds_anything(tmp_path, args, message):
    done = pipeline("sac", [*args, f"paths.outputs={tmp_path}"], tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [message]
    sac = tmp_path / "cache" / "sac"
    assert not sac.exists() or sorted(p.name for p in sac.iterdir()) == []  # no .partial-<key>/, no .<key>.lock


# -- a full disk --------------------------------------------------------------------------------------

def test_a_full_disk_names_the_outputs_directory_when_the_error_names_no_file(compose_config, tmp_path, monkeypatch,
                                                                              capsys):
    import taskcomplexity.stages.rwg_stage as rwg_stage
    from taskcomplexity.cli import EXIT_DISK_FULL
    from taskcomplexity.commands.rwg import run

    def full(path, chunk):  # what np.savez raises on a full disk: errno ENOSPC, no file name
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(rwg_stage, "_save_chunk", full)
    outputs = tmp_path / "out"
    cfg = compose_config("task=cartpole", "backend=gym", "rwg.policies=2", "rwg.episodes=2", f"paths.outputs={outputs}")
    with pytest.raises(SystemExit) as exit_:
        run(cfg)
    assert exit_.value.code == EXIT_DISK_FULL
    assert capsys.readouterr().err.strip().splitlines()[-1] == (  # after the progress bar's frames
        f"error: disk full while writing the outputs directory {outputs}; free some space and rerun the same "
        "command to resume")


# -- the occupancy stage's reasons --------------------------------------------------------------------

def _actors_file(task, path: Path) -> Path:
    """An (untrained) SAC actor's snapshots, saved as the SAC stage saves them."""
    actor, _ = make_actor_critic(task, hidden_sizes=(8, 8), seeds=(0,), goal_conditioned=False)
    with torch.no_grad():
        layers = [actor_layers(actor, task.action_size)]
    ActorSnapshots.stack(np.array([0]), (0,), layers).save(path)
    return path


def test_the_occupancy_stage_says_why_each_task_without_an_actor_is_left_out(compose_config, tmp_path, caplog):
    from taskcomplexity.stages.actor_stages import unavailable_actors
    from taskcomplexity.stages.occupancy_stage import OccupancySettings, study_occupancy
    from taskcomplexity.stages.sac_stage import study_sac_curves
    from taskcomplexity.study.plan import cache_from_config, study_requests

    cfg = compose_config("study=classic_control", "experiment=smoke")
    pairs = study_requests(cfg)
    cache = cache_from_config(cfg)
    curves = study_sac_curves(cache, [(entry, request.task) for entry, request in pairs], cfg.sac, cached_only=True)
    why = unavailable_actors(curves)
    assert why["CartPole-v0"] == why["MountainCar-v0"] == why["Acrobot-v1"] == "SAC skips tasks with discrete actions"
    # Pendulum has an actor (as if trained); MountainCarContinuous has no cached SAC curves
    requests = {entry.id: request for entry, request in pairs}
    actors = {"Pendulum-v1": ("0" * 16, str(_actors_file(requests["Pendulum-v1"].task, tmp_path / "actors.npz")))}
    settings = OccupancySettings(policies=4, episodes=1, pairs=20, resamples=10, batches=2)
    with caplog.at_level(logging.INFO, logger="taskcomplexity"):
        done = study_occupancy(cache, requests, actors, settings, unavailable=why)
    assert set(done) == {"Pendulum-v1"}
    lines = [r.getMessage() for r in caplog.records if "no SAC actor" in r.getMessage()]
    assert lines == [
        "occupancy    no SAC actor for CartPole-v0, MountainCar-v0, Acrobot-v1 (SAC skips tasks with discrete "
        "actions); left out",
        "occupancy    no SAC actor for MountainCarContinuous-v0 (SAC is not trained with sac.enabled=false, and the "
        "cache holds no SAC curves for it); left out",
    ]
    assert "older than actor snapshots" not in caplog.text
