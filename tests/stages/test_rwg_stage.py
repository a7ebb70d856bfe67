"""The RWG stage: seeding, chunking, sharding, the cache and the entry points. A return matrix is the same
however it is computed (in chunks, in shards, resumed), so that every stage downstream can trust its key."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import preloaded
from taskcomplexity.commands import metrics as metrics_command
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, policy_parameters
from taskcomplexity.rwg import BACKENDS, RWGSettings
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.rwg_stage import RETURNS, RWGRequest, load_returns, run_rwg_stage
from taskcomplexity.study.plan import rwg_request_from_config
from taskcomplexity.tasks.spec import make_task

ROOT = Path(__file__).resolve().parents[2]


def request(**settings) -> RWGRequest:
    base = {"policies": 9, "episodes": 4, "seed": 3}
    return RWGRequest(make_task("one_link_1m65", "dense"), NetworkSpec(), PriorSpec(), RWGSettings(**{**base, **settings}))


def test_same_seed_gives_an_identical_parquet(tmp_path):
    a, _ = run_rwg_stage(Cache(tmp_path / "a"), request())
    b, _ = run_rwg_stage(Cache(tmp_path / "b"), request())
    pd.testing.assert_frame_equal(pd.read_parquet(a.file(RETURNS)), pd.read_parquet(b.file(RETURNS)))
    c, _ = run_rwg_stage(Cache(tmp_path / "c"), request(seed=4))
    assert not np.array_equal(load_returns(a), load_returns(c))


def test_returns_parquet_is_tidy(tmp_path):
    artefact, _ = run_rwg_stage(Cache(tmp_path), request())
    frame = pd.read_parquet(artefact.file(RETURNS))
    assert list(frame.columns) == ["policy", "episode", "return", "steps", "success"]
    assert len(frame) == 9 * 4
    assert frame["steps"].between(1, 50).all()
    manifest = artefact.manifest
    assert manifest["policies"] == 9 and manifest["episodes"] == 4 and manifest["seed"] == 3
    assert manifest["config"]["task"]["arm"]["name"] == "one_link_1m65"
    assert "torch" in manifest["versions"]


def test_chunked_and_unchunked_runs_give_identical_returns(tmp_path):
    one, _ = run_rwg_stage(Cache(tmp_path / "one"), request(chunk_policies=1))
    all_, _ = run_rwg_stage(Cache(tmp_path / "all"), request(chunk_policies=100))
    assert one.key == all_.key
    np.testing.assert_array_equal(load_returns(one), load_returns(all_))


def test_a_second_identical_run_is_a_cache_hit(tmp_path):
    cache = Cache(tmp_path)
    first, hit1 = run_rwg_stage(cache, request())
    mtime = first.file(RETURNS).stat().st_mtime_ns
    second, hit2 = run_rwg_stage(cache, request())
    assert (hit1, hit2) == (False, True)
    assert second.file(RETURNS).stat().st_mtime_ns == mtime


def test_sharded_runs_merge_into_the_single_job_artefact(tmp_path):
    single, _ = run_rwg_stage(Cache(tmp_path / "single"), request())
    cache = Cache(tmp_path / "sharded")
    outcomes = [run_rwg_stage(cache, request(shards=3, shard=i), compute_missing=False) for i in (2, 0, 1)]
    assert outcomes[0][0] is None and outcomes[1][0] is None  # waiting for the other shards
    merged = outcomes[2][0]
    assert merged.key == single.key
    pd.testing.assert_frame_equal(pd.read_parquet(merged.file(RETURNS)), pd.read_parquet(single.file(RETURNS)))


def test_policy_weights_can_be_rebuilt_from_seed_and_index():
    a = policy_parameters(NetworkSpec(), PriorSpec(), 9, 1, seed=3, policy=7)
    b = policy_parameters(NetworkSpec(), PriorSpec(), 9, 1, seed=3, policy=7)
    c = policy_parameters(NetworkSpec(), PriorSpec(), 9, 1, seed=3, policy=8)
    assert all(np.array_equal(x[0], y[0]) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[0][0], c[0][0])
    assert [w.shape for w, _ in a] == [(32, 9), (32, 32), (1, 32)]


class Killed(Exception):
    """Stands in for a job killed between chunks."""


def test_interrupted_run_resumes_from_completed_chunks(tmp_path, monkeypatch):
    from taskcomplexity.rwg import run

    reference, _ = run_rwg_stage(Cache(tmp_path / "ref"), request(chunk_policies=2))
    cache = Cache(tmp_path / "run")
    real = run.simulate_chunk
    calls = []
    kill_at = [3]

    def flaky(*args, **kwargs):
        calls.append(args[4])
        if len(calls) == kill_at[0]:
            raise Killed("the job was killed")
        return real(*args, **kwargs)

    monkeypatch.setattr(run, "simulate_chunk", flaky)  # where run_rwg looks it up
    with pytest.raises(Killed):
        run_rwg_stage(cache, request(chunk_policies=2))
    assert cache.lookup("rwg", reference.key) is None  # no half artefact under the key
    calls.clear()
    kill_at[0] = 0
    resumed, _ = run_rwg_stage(cache, request(chunk_policies=2))
    assert calls == [4, 6, 8]  # chunks starting at policies 0 and 2 were reused
    np.testing.assert_array_equal(load_returns(resumed), load_returns(reference))


def test_smoke_study_through_both_stages_on_the_pybullet_backend(compose_config, tmp_path):
    cfg = compose_config("experiment=smoke", "backend=pybullet")
    results = metrics_command.run(cfg)
    assert [r.task_id for r in results] == [
        "one_link_1m0-dense", "one_link_1m65-dense", "two_link-dense", "two_link_obstacle-dense",
        "one_link_1m0-sparse", "one_link_1m65-sparse", "two_link-sparse"]  # study order
    assert not (Path(cfg.paths.outputs) / "tables").exists()  # the study's tables are the report's
    for result in results:
        assert result.request.backend == "pybullet"
        frame = result.table("metrics.parquet")
        assert 0 <= frame["pic"].iloc[0] <= np.log(10) + 1e-12


def test_multirun_sweep_writes_one_artefact_per_task_and_then_only_hits_the_cache(tmp_path):
    command = [
        sys.executable, str(ROOT / "pipelines" / "rwg.py"), "-m",
        "arm=one_link_1m0,two_link", "reward=dense,sparse", "experiment=smoke", f"paths.outputs={tmp_path}",
    ]
    first = preloaded.run(command, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    assert len(list((tmp_path / "cache" / "rwg").glob("*/returns.parquet"))) == 4
    second = preloaded.run(command, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert second.returncode == 0
    log = second.stdout + second.stderr
    assert log.count("cache hit") >= 4 and "computed" not in log


def test_a_job_of_a_sweep_over_rwg_entry_composes_its_own_task_into_the_studys_key(compose_config, monkeypatch):
    # make atlas-cluster's jobs (rwg.entry=<id>): each computes the request the study makes for its task, under the
    # key the study then finds, and composes that task alone, not the study's every task
    from taskcomplexity.commands.rwg import entry_request
    from taskcomplexity.study import compose
    from taskcomplexity.study.plan import study_requests

    cfg = compose_config("experiment=smoke")
    study = {entry.id: request for entry, request in study_requests(cfg)}
    composed, entry_config = [], compose.entry_config
    monkeypatch.setattr(compose, "entry_config", lambda base, entry, *args: composed.append(entry.id)
                        or entry_config(base, entry, *args))
    for task_id, request in study.items():
        composed.clear()
        assert entry_request(cfg, task_id).key == request.key
        assert composed == [task_id]
    assert len(study) == 7


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("rwg.policies=1", "rwg.policies must be an integer >= 2 (N), got 1"),
        ("rwg.episodes=1", "rwg.episodes must be an integer >= 2 (M), got 1"),
        ("rwg.shard=3", "rwg.shard must be in [0, 0] (rwg.shards=1), got 3"),
        ("backend=gpu", f"backend must be one of {['auto', *BACKENDS]}, got 'gpu'"),
    ],
)
def test_bad_rwg_settings_are_refused_before_anything_runs(compose_config, override, message):
    from taskcomplexity.errors import ConfigError

    cfg = compose_config("experiment=smoke", override)
    with pytest.raises(ConfigError) as err:
        rwg_request_from_config(cfg).settings.validate()
    assert str(err.value) == message
