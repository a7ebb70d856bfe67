"""Scale-out and robustness: launchers, concurrency, corruption, bad input. Jobs split over processes or machines
must leave the artefacts one run would, and a damaged or foreign artefact is never served."""

from __future__ import annotations

import io
import json
import multiprocessing
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import preloaded
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.cache import Cache, file_digest
from taskcomplexity.stages.metrics_stage import MetricsSettings, run_metrics_stage
from taskcomplexity.stages.rwg_stage import RETURNS, RWGRequest, load_returns, run_rwg_stage
from taskcomplexity.tasks.spec import make_task

ROOT = Path(__file__).resolve().parents[2]


def options(group: str) -> str:
    """The options of a config group as a refusal lists them: its YAML files' names, sorted."""
    return ", ".join(sorted(p.stem for p in (ROOT / "src" / "taskcomplexity" / "conf" / group).glob("*.yaml")))
RWG = str(ROOT / "pipelines" / "rwg.py")
METRICS = str(ROOT / "pipelines" / "metrics.py")


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return preloaded.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, timeout=600)


def request(**settings) -> RWGRequest:
    base = {"policies": 12, "episodes": 3, "seed": 1}
    return RWGRequest(make_task("one_link_1m65", "sparse"), NetworkSpec(), PriorSpec(), RWGSettings(**{**base, **settings}))


def snapshot(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()} if root.exists() else {}


def test_multirun_through_the_joblib_launcher(tmp_path):
    result = run(RWG, "-m", "hydra/launcher=local_parallel", "arm=one_link_1m0,two_link", "experiment=smoke",
                 f"paths.outputs={tmp_path}", cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "Joblib" in result.stdout + result.stderr
    assert len(list((tmp_path / "cache" / "rwg").glob("*/returns.parquet"))) == 2


def test_sharded_multirun_through_submitit_local_equals_a_single_job(tmp_path):
    sharded = run(RWG, "-m", "hydra/launcher=local_submitit", "arm=one_link_1m65", "rwg.shards=3",
                  "rwg.shard=range(3)", "experiment=smoke", f"paths.outputs={tmp_path / 'sharded'}", cwd=tmp_path)
    assert sharded.returncode == 0, sharded.stderr[-2000:]
    assert "Submitit 'local'" in sharded.stdout + sharded.stderr
    single = run(RWG, "arm=one_link_1m65", "experiment=smoke", f"paths.outputs={tmp_path / 'single'}", cwd=tmp_path)
    assert single.returncode == 0, single.stderr[-2000:]
    [a] = (tmp_path / "sharded" / "cache" / "rwg").glob("*/returns.parquet")
    [b] = (tmp_path / "single" / "cache" / "rwg").glob("*/returns.parquet")
    assert a.parent.name == b.parent.name  # same key
    pd.testing.assert_frame_equal(pd.read_parquet(a), pd.read_parquet(b))


def _compute(root: str, barrier) -> str:
    barrier.wait()
    artefact, _ = run_rwg_stage(Cache(root), request())
    return artefact.key


def test_two_processes_computing_the_same_key_leave_one_valid_artefact(tmp_path):
    ctx = multiprocessing.get_context("spawn")
    barrier = ctx.Manager().Barrier(2)
    with ctx.Pool(2) as pool:
        keys = pool.starmap(_compute, [(str(tmp_path), barrier)] * 2)
    assert keys[0] == keys[1]
    entries = [p for p in (tmp_path / "rwg").iterdir() if not p.name.startswith(".")]
    assert [p.name for p in entries] == [keys[0]]
    assert not list((tmp_path / "rwg").glob(".tmp-*"))
    cache = Cache(tmp_path)
    assert cache.lookup("rwg", keys[0]) is not None
    np.testing.assert_array_equal(load_returns(cache.lookup("rwg", keys[0])), load_returns(run_rwg_stage(Cache(tmp_path / "x"), request())[0]))


def test_a_truncated_parquet_is_detected_and_recomputed(tmp_path, caplog):
    cache = Cache(tmp_path)
    artefact, _ = run_rwg_stage(cache, request())
    good = pd.read_parquet(artefact.file(RETURNS))
    data = artefact.file(RETURNS).read_bytes()
    artefact.file(RETURNS).write_bytes(data[: len(data) // 2])
    with caplog.at_level("WARNING"):
        again, hit = run_rwg_stage(cache, request())
    assert not hit
    assert "corrupt rwg artefact" in caplog.text and "returns.parquet" in caplog.text
    pd.testing.assert_frame_equal(pd.read_parquet(again.file(RETURNS)), good)


def test_a_same_size_bit_flip_is_caught_by_the_content_hash_and_recomputed(tmp_path, caplog):
    cache = Cache(tmp_path)
    artefact, _ = run_rwg_stage(cache, request())
    good = pd.read_parquet(artefact.file(RETURNS))
    data = bytearray(artefact.file(RETURNS).read_bytes())
    data[len(data) // 3] ^= 0x01  # inside a data page: the size and the footer stay valid
    artefact.file(RETURNS).write_bytes(bytes(data))
    with caplog.at_level("WARNING"):
        again, hit = run_rwg_stage(cache, request())
    assert not hit and "SHA-256 mismatch" in caplog.text
    pd.testing.assert_frame_equal(pd.read_parquet(again.file(RETURNS)), good)


def test_a_foreign_artefact_under_another_key_or_an_empty_file_list_is_never_served(tmp_path):
    cache = Cache(tmp_path)
    mine, _ = run_rwg_stage(cache, request())
    other = request(seed=2)
    shutil.copytree(mine.path, cache.path("rwg", other.key))  # someone copies an artefact under another key
    assert cache.lookup("rwg", other.key) is None and not cache.path("rwg", other.key).exists()
    served, hit = run_rwg_stage(cache, other)
    assert not hit and not np.array_equal(load_returns(served), load_returns(mine))
    manifest = mine.manifest
    manifest["files"] = {}
    (mine.path / "manifest.json").write_text(json.dumps(manifest))
    assert cache.lookup("rwg", mine.key) is None


def test_temporary_directories_of_dead_processes_are_removed_by_the_next_writer(tmp_path):
    cache = Cache(tmp_path)
    key = request().key
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    orphan = tmp_path / "rwg" / f".tmp-{key}-{int(dead.stdout)}-deadbeef"
    orphan.mkdir(parents=True)
    alive = tmp_path / "rwg" / f".tmp-{key}-{os.getpid()}-cafecafe"
    alive.mkdir()
    run_rwg_stage(cache, request())
    assert not orphan.exists() and alive.exists()


def test_a_damaged_manifest_is_detected_and_recomputed(tmp_path):
    cache = Cache(tmp_path)
    artefact, _ = run_rwg_stage(cache, request())
    (artefact.path / "manifest.json").write_text("{not json")
    _, hit = run_rwg_stage(cache, request())
    assert not hit and cache.lookup("rwg", artefact.key) is not None


def test_a_new_stage_numerics_version_invalidates_old_keys(monkeypatch):
    import dataclasses

    import taskcomplexity.stages.rwg_stage as stage

    old = request().key
    monkeypatch.setattr(stage, "NUMERICS", dataclasses.replace(stage.NUMERICS, version=stage.NUMERICS.version + 1))
    assert request().key != old


def test_returns_with_nan_are_refused_by_the_metrics_stage_naming_policy_and_episode(tmp_path):
    cache = Cache(tmp_path)
    artefact, _ = run_rwg_stage(cache, request())
    frame = pd.read_parquet(artefact.file(RETURNS))
    frame.loc[(frame.policy == 4) & (frame.episode == 2), "return"] = np.nan
    frame.to_parquet(artefact.file(RETURNS), index=False)
    manifest = artefact.manifest
    manifest["files"][RETURNS] = {"bytes": artefact.file(RETURNS).stat().st_size,
                                  "sha256": file_digest(artefact.file(RETURNS))}
    (artefact.path / "manifest.json").write_text(__import__("json").dumps(manifest))
    before = snapshot(tmp_path)
    with pytest.raises(ValueError, match="policy 4, episode 2"):
        run_metrics_stage(cache, artefact, MetricsSettings(bins=100, resamples=5))
    assert not list((tmp_path / "metrics").glob("[!.]*"))  # nothing half-written under a key
    assert {k: v for k, v in snapshot(tmp_path).items() if not k.startswith("metrics")} == before


@pytest.fixture(scope="module")
def seeded_outputs(tmp_path_factory):
    """An outputs directory whose cache already holds an artefact."""
    outputs = tmp_path_factory.mktemp("seeded") / "outputs"
    seeded = run(RWG, "experiment=smoke", f"paths.outputs={outputs}", cwd=outputs.parent)
    assert seeded.returncode == 0, seeded.stderr[-2000:]
    return outputs


@pytest.mark.parametrize(
    ("script", "override", "message"),
    [
        (RWG, "arm=three_link", f"error: arm=three_link is not a known option (allowed: {options('arm')})"),
        (RWG, "prior=cauchy", f"error: prior=cauchy is not a known option (allowed: {options('prior')})"),
        (RWG, "rwg.policies=1", "error: rwg.policies must be an integer >= 2 (N), got 1"),
        (RWG, "rwg.episodes=1", "error: rwg.episodes must be an integer >= 2 (M), got 1"),
        (RWG, "arm.links.0.length=-0.5", "error: arm.links[0].length must be a finite number > 0, got -0.5"),
        (RWG, "arm.torque_scale=[-30.0]", "error: arm.torque_scale[0] must be a finite number > 0, got -30.0"),
        (RWG, "rwg.shard=5", "error: rwg.shard must be in [0, 0] (rwg.shards=1), got 5"),
        (RWG, "rwg.entry=nosuch", "error: rwg.entry=nosuch is not a task of study seven_tasks (allowed: "
                                  "one_link_1m0-dense, one_link_1m65-dense, two_link-dense, two_link_obstacle-dense, "
                                  "one_link_1m0-sparse, one_link_1m65-sparse, two_link-sparse)"),
        (METRICS, "rwg.entry=two_link-sparse", "error: rwg.entry=two_link-sparse is read by pipelines/rwg.py only (one "
                                               "study task's RWG, a job of a sweep over the ids)"),
        (METRICS, "metrics.bins=1", "error: metrics.bins must be an integer >= 2 (B) or auto (N·M / 50, or the study's pinned B at its "
                                          "published N and M), got 1"),
        (METRICS, "metrics.temperature_range=[2.0,1.0]", "error: metrics.temperature_range must be [low, high] with 0 < low < high, got [2.0, 1.0]"),
        (METRICS, "metrics.temperature_range=[0.0,1.0]", "error: metrics.temperature_range must be [low, high] with 0 < low < high, got [0.0, 1.0]"),
    ],
)
def test_bad_input_stops_with_one_line_exit_2_and_an_untouched_cache(seeded_outputs, tmp_path, script, override, message):
    outputs = seeded_outputs
    before = snapshot(outputs / "cache")
    result = run(script, "experiment=smoke", override, f"paths.outputs={outputs}", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines()[-1] == message
    assert snapshot(outputs / "cache") == before


def test_an_output_directory_that_cannot_be_written_is_named(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if os.access(locked, os.W_OK):
            pytest.skip("running as a user who can write anywhere (root)")
        result = run(RWG, "experiment=smoke", f"paths.outputs={locked / 'out'}", cwd=tmp_path)
        assert result.returncode == 2
        assert result.stderr.strip().splitlines()[-1].startswith(f"error: paths.outputs: cannot write to {locked / 'out'}")
    finally:
        locked.chmod(0o700)


def test_an_output_path_that_is_a_file_is_named(tmp_path):
    blocker = tmp_path / "not_a_directory"
    blocker.write_text("")
    result = run(RWG, "experiment=smoke", f"paths.outputs={blocker}", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines()[-1].startswith(f"error: paths.outputs: cannot write to {blocker}")


def test_cache_listing_shows_artefacts_with_sizes(tmp_path):
    run_rwg_stage(Cache(tmp_path / "cache"), request())
    result = run("-m", "taskcomplexity.stages.cache", "list", str(tmp_path / "cache"), cwd=tmp_path)
    assert result.returncode == 0
    assert "rwg" in result.stdout and "KB" in result.stdout and "1 artefacts" in result.stdout


def _run_forced(root: str, barrier, force: bool) -> bytes:
    barrier.wait()
    big = RWGRequest(make_task("two_link", "dense"), NetworkSpec(), PriorSpec(),
                     RWGSettings(policies=60, episodes=4, seed=3, chunk_policies=4), backend="pybullet")
    artefact, _ = run_rwg_stage(Cache(root), big, force=force)
    return artefact.file(RETURNS).read_bytes()


def test_force_beside_a_running_job_on_the_same_key_crashes_neither(tmp_path):
    ctx = multiprocessing.get_context("spawn")
    barrier = ctx.Manager().Barrier(2)
    with ctx.Pool(2) as pool:
        normal, forced = pool.starmap(_run_forced, [(str(tmp_path), barrier, False), (str(tmp_path), barrier, True)])
    assert pd.read_parquet(io.BytesIO(normal)).equals(pd.read_parquet(io.BytesIO(forced)))
    assert not list((tmp_path / "rwg").glob(".partial-*-force-*")) and not list((tmp_path / "rwg").glob(".tmp-*"))
