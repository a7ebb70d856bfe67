"""The local cluster's own commands, as the scale-out tutorial (``scale-out.md``) prints them: ``make cluster-up`` is
idempotent, and ``make cluster-down`` leaves no daemon it started running (a test that stops the cluster starts it
again, so the cluster tests after it find it up)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

pytestmark = pytest.mark.cluster

ROOT = Path(__file__).resolve().parents[2]
STATE = ROOT / "outputs" / "cluster"


def make(target: str) -> subprocess.CompletedProcess:
    return subprocess.run(["make", target], cwd=ROOT, capture_output=True, text=True, timeout=600)


def pids() -> dict[str, int]:
    """The daemons' PID files under the cluster's state directory: name → PID."""
    return {p.stem: int(p.read_text().strip()) for p in (STATE / "run").glob("*.pid") if p.read_text().strip()}


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}").exists() and "zombie" not in Path(f"/proc/{pid}/status").read_text().lower()


def test_cluster_up_twice_starts_nothing_the_second_time():
    first = make("cluster-up")
    assert first.returncode == 0, first.stderr
    before = pids()
    assert set(before) == {"munged", "mariadbd", "slurmdbd", "slurmctld", "slurmd"}
    again = make("cluster-up")
    assert again.returncode == 0 and "running already" in again.stdout
    assert pids() == before


def test_cluster_down_leaves_no_daemon_running_and_up_starts_it_again():
    assert make("cluster-up").returncode == 0
    started = pids()
    down = make("cluster-down")
    assert down.returncode == 0, down.stderr
    assert all(f"{name}({pid})" in down.stdout for name, pid in started.items())
    assert [name for name, pid in started.items() if alive(pid)] == []
    assert subprocess.run(["pgrep", "-f", "slurmstepd"], capture_output=True).returncode == 1   # no job step left
    assert not Path("/etc/slurm/slurm.conf").is_symlink() or Path("/etc/slurm/slurm.conf").resolve() != \
        (STATE / "etc" / "slurm.conf").resolve()
    assert "not running" in make("cluster-down").stdout
    up = make("cluster-up")
    assert up.returncode == 0, up.stderr
    assert "partition 'local'" in up.stdout
    assert subprocess.run(["sinfo", "-h", "-p", "local", "-o", "%T"], capture_output=True, text=True,
                          env={**os.environ, "SLURM_CONF": str(STATE / "etc" / "slurm.conf")}).stdout.strip() == "idle"
