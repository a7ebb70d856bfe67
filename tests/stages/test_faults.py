"""Faults end in one line and a state the next run resumes from: Ctrl-C and a full disk."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.cache import Cache
from taskcomplexity.stages.rwg_stage import RWGRequest, load_returns, run_rwg_stage
from taskcomplexity.tasks.gym_task import GymTask

ROOT = Path(__file__).resolve().parents[2]
RWG = str(ROOT / "pipelines" / "rwg.py")


def saved_chunks(outputs) -> list:
    """The RWG chunks a run has saved, not those being written (``chunk-…<pid>.tmp.npz``, renamed into place once
    whole): on a busy machine a test that acted on a chunk in writing could find nothing to resume."""
    return [c for c in outputs.glob("cache/rwg/.partial-*/chunk-*.npz") if ".tmp." not in c.name]


def test_ctrl_c_is_one_line_exit_130_and_the_rerun_resumes_to_the_same_returns(tmp_path):
    outputs = tmp_path / "outputs"
    args = [sys.executable, RWG, "task=cartpole", "backend=gym", "rwg.policies=40", "rwg.episodes=4", "rwg.chunk_policies=2",
            f"paths.outputs={outputs}"]
    # Ctrl-C as a terminal delivers it: a job started in the background by a non-interactive shell
    # (a CI runner, `cmd &`) inherits SIGINT ignored, and Python then never raises KeyboardInterrupt
    job = subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while time.time() < deadline and len(saved_chunks(outputs)) < 2:
        time.sleep(0.05)
    assert job.poll() is None, "the run finished before it could be interrupted"
    job.send_signal(signal.SIGINT)
    _, stderr = job.communicate(timeout=120)
    assert job.returncode == 130
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr
    assert stderr.rstrip().splitlines()[-1] == "interrupted; rerun the same command to resume"
    rerun = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0 and "resuming" in rerun.stdout + rerun.stderr
    request = RWGRequest(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(policies=40, episodes=4),
                         backend="gym")
    cached = Cache(outputs / "cache").lookup("rwg", request.key)
    fresh, _ = run_rwg_stage(Cache(tmp_path / "fresh"), request)
    np.testing.assert_array_equal(load_returns(cached), load_returns(fresh))


@pytest.fixture
def small_disk(tmp_path, tmpfs):
    """A 2 MB filesystem (tmpfs)."""
    with tmpfs(tmp_path / "disk", "2m") as mount:
        yield mount


def test_a_full_disk_is_one_line_naming_the_path_and_the_rerun_resumes(small_disk, tmp_path):
    outputs = small_disk / "outputs"
    args = [sys.executable, RWG, "task=cartpole", "backend=gym", "rwg.policies=40", "rwg.episodes=4",
            "rwg.chunk_policies=2", f"paths.outputs={outputs}"]
    # Ctrl-C as a terminal delivers it: a job started in the background by a non-interactive shell
    # (a CI runner, `cmd &`) inherits SIGINT ignored, and Python then never raises KeyboardInterrupt
    job = subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while time.time() < deadline and not saved_chunks(outputs):
        time.sleep(0.02)
    filler = small_disk / "filler"  # the disk fills up while the run is under way
    with open(filler, "wb", buffering=0) as handle:
        try:
            while True:
                handle.write(b"\0" * 4096)
        except OSError:
            pass
    _, stderr = job.communicate(timeout=300)
    assert job.returncode == 3, stderr[-2000:]
    assert "Traceback" not in stderr
    last = stderr.rstrip().splitlines()[-1]
    assert last.startswith("error: disk full while writing ") and "rerun the same command to resume" in last
    filler.unlink()
    rerun = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert "resuming" in rerun.stdout + rerun.stderr
    request = RWGRequest(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(policies=40, episodes=4),
                         backend="gym")
    fresh, _ = run_rwg_stage(Cache(tmp_path / "fresh"), request)
    np.testing.assert_array_equal(load_returns(Cache(outputs / "cache").lookup("rwg", request.key)), load_returns(fresh))


def test_a_plan_beyond_the_machine_is_refused_up_front_with_its_estimate(small_disk, tmp_path):
    huge = subprocess.run([sys.executable, RWG, "rwg.policies=1e12", f"paths.outputs={tmp_path / 'out'}"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert huge.returncode == 2
    assert huge.stderr.strip().splitlines() == [huge.stderr.strip().splitlines()[-1]]
    assert re.fullmatch(r"error: rwg\.policies × rwg\.episodes = 1,000,000,000,000 × 100 needs about [\d,.]+ TB of "
                        r"memory, this machine has [\d.]+ GB \(lower N or M\)", huge.stderr.strip())
    outputs = small_disk / "outputs"  # 2 MB: 400 × 200 episodes need about 3.8 MB
    big = subprocess.run([sys.executable, RWG, "rwg.policies=400", "rwg.episodes=200", f"paths.outputs={outputs}"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert big.returncode == 2  # sizes in the unit that shows them, not "0.00 GB"
    assert re.fullmatch(rf"error: rwg\.policies × rwg\.episodes = 400 × 200 needs about 3\.7 MB of disk under "
                        rf"{outputs / 'cache'}, [\d.]+ (KB|MB) are free", big.stderr.strip()), big.stderr
    assert not list((outputs / "cache").rglob("*.npz")) and not list((outputs / "cache").rglob("*.parquet"))


def _cartpole(outputs: Path, *extra: str) -> list[str]:
    return [sys.executable, RWG, "task=cartpole", "backend=gym", "rwg.policies=40", "rwg.episodes=4",
            "rwg.chunk_policies=2", f"paths.outputs={outputs}", *extra]


CARTPOLE = RWGRequest(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(policies=40, episodes=4),
                      backend="gym")


def test_sigterm_is_one_line_exit_143_and_the_rerun_resumes_to_the_same_returns(tmp_path):
    outputs = tmp_path / "outputs"
    job = subprocess.Popen(_cartpole(outputs), cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)
    deadline = time.time() + 120
    while time.time() < deadline and len(saved_chunks(outputs)) < 2:
        time.sleep(0.05)
    assert job.poll() is None, "the run finished before it could be terminated"
    job.terminate()  # SIGTERM: `kill`, a cluster's time limit
    _, stderr = job.communicate(timeout=120)
    assert job.returncode == 143
    assert "Traceback" not in stderr
    assert stderr.rstrip().splitlines()[-1] == "terminated (SIGTERM); rerun the same command to resume"
    rerun = subprocess.run(_cartpole(outputs), cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0 and "resuming" in rerun.stdout + rerun.stderr
    fresh, _ = run_rwg_stage(Cache(tmp_path / "fresh"), CARTPOLE)
    np.testing.assert_array_equal(load_returns(Cache(outputs / "cache").lookup("rwg", CARTPOLE.key)),
                                  load_returns(fresh))


def test_a_disk_full_before_the_start_is_the_disk_full_line_naming_the_outputs(small_disk, tmp_path):
    with open(small_disk / "filler", "wb", buffering=0) as handle:
        try:
            while True:
                handle.write(b"\0" * 4096)
        except OSError:
            pass
    outputs = small_disk / "outputs"
    done = subprocess.run(_cartpole(outputs), cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 3, done.stderr[-2000:]
    assert done.stderr.strip().splitlines() == [
        f"error: disk full while writing {outputs}; free some space and rerun the same command to resume"]


def test_a_run_waiting_for_another_runs_lock_says_what_it_waits_for(tmp_path):
    from filelock import FileLock

    outputs = tmp_path / "outputs"
    (outputs / "cache" / "rwg").mkdir(parents=True)
    lock = FileLock(str(outputs / "cache" / "rwg" / f".{CARTPOLE.key}.lock"))
    with lock:  # another run is writing this artefact
        job = subprocess.Popen(_cartpole(outputs), cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True)
        deadline = time.time() + 120
        while time.time() < deadline and not list(outputs.glob("cache/rwg/.partial-*/shard-*.npz")):
            time.sleep(0.05)
        time.sleep(1.0)
        assert job.poll() is None, "the run did not wait for the lock"
    output, _ = job.communicate(timeout=300)
    assert job.returncode == 0, output[-2000:]
    assert f"waiting for another run that is computing rwg {CARTPOLE.key}" in output
    assert f"rwg {CARTPOLE.key}: the other run is done after" in output


@pytest.fixture
def read_only_cache(tmp_path, tmpfs):
    """A cache holding the CartPole returns, on a filesystem remounted read-only (a shared cache)."""
    with tmpfs(tmp_path / "shared", "64m") as mount:
        run_rwg_stage(Cache(mount / "cache"), CARTPOLE)
        subprocess.run(["mount", "-o", "remount,ro", str(mount)], check=True)
        yield mount / "cache"


def test_a_read_only_cache_serves_what_it_holds_and_refuses_the_rest_in_one_line(read_only_cache, tmp_path):
    hit = subprocess.run(_cartpole(tmp_path / "mine", f"paths.cache={read_only_cache}"), cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert hit.returncode == 0, hit.stderr[-2000:]
    assert "cache hit: rwg" in hit.stdout + hit.stderr
    other = RWGRequest(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(),
                       RWGSettings(policies=40, episodes=4, seed=1), backend="gym")
    miss = subprocess.run(_cartpole(tmp_path / "mine", f"paths.cache={read_only_cache}", "rwg.seed=1"), cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert miss.returncode == 2
    assert miss.stderr.strip().splitlines() == [
        f"error: paths.cache {read_only_cache} is read-only and holds no rwg artefact {other.key}: point "
        "paths.cache at a writable directory to compute it"]
