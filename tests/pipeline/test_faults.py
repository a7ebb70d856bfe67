"""Faults end in one line and a state the next run resumes from: Ctrl-C and a full disk."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from taskcomplexity.pipeline.cache import Cache
from taskcomplexity.pipeline.rwg_stage import RWGRequest, load_returns, run_rwg_stage
from taskcomplexity.policies import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

ROOT = Path(__file__).resolve().parents[2]
RWG = str(ROOT / "pipelines" / "rwg.py")


def test_ctrl_c_is_one_line_exit_130_and_the_rerun_resumes_to_the_same_returns(tmp_path):
    outputs = tmp_path / "outputs"
    args = [sys.executable, RWG, "task=cartpole", "backend=gym", "rwg.policies=40", "rwg.episodes=4", "rwg.chunk_policies=2",
            f"paths.outputs={outputs}"]
    job = subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and len(list(outputs.glob("cache/rwg/.partial-*/chunk-*.npz"))) < 2:
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
def small_disk(tmp_path):
    """A 2 MB filesystem (tmpfs), nearly filled; skipped where this user cannot mount one."""
    mount = tmp_path / "disk"
    mount.mkdir()
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)], capture_output=True)
    if made.returncode != 0:
        pytest.skip(f"cannot mount a small filesystem here ({made.stderr.decode().strip()})")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=False)


def test_a_full_disk_is_one_line_naming_the_path_and_the_rerun_resumes(small_disk, tmp_path):
    filler = small_disk / "filler"
    filler.write_bytes(b"\0" * (1800 * 1024))
    outputs = small_disk / "outputs"
    args = [sys.executable, RWG, "arm=one_link_1m0", "rwg.policies=400", "rwg.episodes=50", "rwg.chunk_policies=100",
            f"paths.outputs={outputs}"]
    full = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert full.returncode == 3
    assert "Traceback" not in full.stderr
    last = full.stderr.rstrip().splitlines()[-1]
    assert last.startswith("error: disk full while writing ") and "rerun the same command to resume" in last
    filler.unlink()
    rerun = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    request = RWGRequest(make_task("one_link_1m0", "dense"), NetworkSpec(), PriorSpec(),
                         RWGSettings(policies=400, episodes=50))
    fresh, _ = run_rwg_stage(Cache(tmp_path / "fresh"), request)
    np.testing.assert_array_equal(load_returns(Cache(outputs / "cache").lookup("rwg", request.key)), load_returns(fresh))
    assert os.path.getsize(outputs / "cache" / "rwg" / request.key / "returns.parquet") > 0
