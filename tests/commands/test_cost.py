"""``pipelines/cost.py``: a study's RWG cost from two pilots per task, extrapolated to its N × M."""

from __future__ import annotations

import math

import pytest

from taskcomplexity.commands.cost import TaskCost, _hours, estimate
from taskcomplexity.errors import ConfigError


def test_the_estimate_is_n_times_m_episodes_plus_the_chunks_fixed_part():
    cost = TaskCost("t", "gym", policies=1000, episodes=1000, limit=1000, mean_steps=500.0, episode_cpu=0.02,
                    chunk_cpu=3.0, chunks=250)
    assert cost.cpu_seconds == pytest.approx(1000 * 1000 * 0.02 + 250 * 3.0)


def test_every_task_of_the_study_is_priced_on_its_backend_and_the_table_adds_up(compose_config, monkeypatch):
    import taskcomplexity.commands.cost as cost

    monkeypatch.setattr(cost, "job_start_cpu", lambda entry_id, typed: 5.0)
    cfg = compose_config("study=classic_control", "study.policies=400", "study.episodes=50", "rwg.shards=4")
    lines = []
    costs = estimate(cfg, echo=lines.append)
    assert [c.task for c in costs] == ["CartPole-v0", "Pendulum-v1", "MountainCar-v0", "MountainCarContinuous-v0",
                                       "Acrobot-v1"]
    for c in costs:
        assert (c.backend, c.policies, c.episodes) == ("kernel", 400, 50)
        assert 1 <= c.mean_steps <= c.limit and c.chunks >= 1 and c.episode_cpu >= 0 and c.chunk_cpu >= 0
    assert costs[1].mean_steps == 200  # Pendulum never ends an episode before its limit
    assert lines[0].startswith("RWG cost of study classic_control at N = 400 × M = 50, from two pilots per task")
    assert [line.split()[2:4] for line in lines[3:8]] == [["2×50,", "6×50"]] * 5  # each task's pilots, as they ran
    total = sum(c.cpu_seconds for c in costs)
    assert any(line.startswith(f"total: {total / 3600:.2f} CPU-hours") for line in lines)
    assert lines[-2] == (f"as jobs: 5 tasks × rwg.shards=4 = 20 jobs, each starting a fresh process (5.0 CPU-s on "
                         f"kernel, measured by starting one): {(total + 20 * 5.0) / 3600:.2f} CPU-hours in all")
    longest = max(costs, key=lambda c: c.cpu_seconds)
    assert lines[-1] == f"the longest job: a shard of {longest.task}, {_hours(longest.cpu_seconds / 4 + 5.0)} of CPU"
    assert not math.isnan(total)


def test_a_bad_budget_is_refused_before_any_pilot(compose_config):
    with pytest.raises(ConfigError, match=r"^study\.policies must be an integer >= 2 or null, got 1$"):
        estimate(compose_config("study=classic_control", "study.policies=1"), echo=print)


def test_a_shard_is_set_against_the_cluster_launchers_time_limit(compose_config, monkeypatch):
    import taskcomplexity.commands.cost as cost
    from taskcomplexity.study.plan import study_requests

    monkeypatch.setattr(cost, "job_start_cpu", lambda entry_id, typed: 1.0)
    cfg = compose_config("study=classic_control", "study.policies=64", "study.episodes=8", "rwg.shards=2")
    # The tasks priced once, then set against each limit (a second pilot measures other CPU-s on a busy machine).
    # A job needs longest / 2 + 1 CPU-s, on 2 cores: a limit between 0.5 s (its start-up's wall time) and that
    # half is beyond it but met by more shards; below 0.5 s no number of shards fits.
    costs = estimate(cfg, echo=lambda line: None)
    longest = max(c.cpu_seconds for c in costs)
    between = (0.5 + (longest / 2 + 1.0) / 2) / 2
    for limit in (1e6, between, 0.4):  # seconds of the launcher's time limit, on 2 cores per job
        lines = []
        cost.echo_jobs(costs, study_requests(cfg), 2, (limit, 2), lines.append)
        if limit > 1e3:
            assert lines[-1].endswith(f"on a job's 2 cores against the launcher's limit of {_hours(limit)}: within it")
        elif limit > 0.5:
            assert lines[-1].endswith(f"beyond it, use rwg.shards >= {math.ceil(longest / (2 * limit - 1.0))}")
        else:
            assert lines[-1].endswith("beyond it, raise hydra.launcher.timeout_min")
    # estimate reads the launcher's limit and prints the same line
    monkeypatch.setattr(cost, "_launcher_limit", lambda cfg: (1e6, 2))
    lines = []
    estimate(cfg, echo=lines.append)
    assert lines[-1].endswith(f"on a job's 2 cores against the launcher's limit of {_hours(1e6)}: within it")


def test_a_jobs_start_up_is_measured_by_starting_one():
    from taskcomplexity.commands.cost import job_start_cpu

    assert 0.5 < job_start_cpu("CartPole-v0", ["study=classic_control", "study.policies=1000", "rwg.shards=8"]) < 120


@pytest.mark.parametrize(("backend", "episodes", "pilots"), [
    ("gym", 100, ((16, 2), (16, 6))), ("gym", 4, ((16, 2), (16, 4))), ("gym", 2, ((16, 2), (16, 2))),
    ("envpool", 4, ((10, 2), (10, 4))), ("kernel", 4, ((2, 4), (6, 4)))])
def test_no_pilot_runs_more_episodes_than_the_run_it_prices(backend, episodes, pilots):
    from types import SimpleNamespace

    from taskcomplexity.commands.cost import pilot_sizes

    policies = 10 if backend == "envpool" else 1000
    request = SimpleNamespace(backend=backend, settings=SimpleNamespace(policies=policies, episodes=episodes),
                              task=SimpleNamespace(max_steps=200))
    assert pilot_sizes(request) == pilots
