"""The SLURM launcher's job side (``hydra/launcher=cluster``) without a scheduler: what a job does around its work."""

from __future__ import annotations

import os
import signal

import pytest
from hydra_plugins.hydra_submitit_launcher.submitit_launcher import SlurmLauncher

from hydra_plugins.taskcomplexity_cluster import ClusterLauncher


@pytest.fixture
def usr2():
    """SIGUSR2 (SLURM's time-limit signal to submitit's jobs) as the test found it, restored after."""
    before = signal.getsignal(signal.SIGUSR2)
    signal.signal(signal.SIGUSR2, signal.SIG_DFL)
    yield
    signal.signal(signal.SIGUSR2, before)


@pytest.mark.parametrize("ends", ["returns", "exits"])
def test_a_time_limit_signal_after_the_jobs_work_neither_kills_nor_requeues_it(usr2, monkeypatch, ends):
    # The signal can come once the work is done (while submitit writes the result, or while Python shuts down):
    # the job then ends as it would have, instead of dying of the signal (SLURM: FAILED) or being requeued.
    def work(self, *args):
        assert signal.getsignal(signal.SIGUSR2) is signal.SIG_DFL   # during the work, the signal is not ignored
        if ends == "exits":
            raise SystemExit(-1)   # submitit's exit after it requeued the job
        return "result"

    monkeypatch.setattr(SlurmLauncher, "__call__", work)
    launcher = object.__new__(ClusterLauncher)
    if ends == "exits":
        with pytest.raises(SystemExit):
            launcher(["a=1"], "dir", 0, "job", {})
    else:
        assert launcher(["a=1"], "dir", 0, "job", {}) == "result"
    assert signal.getsignal(signal.SIGUSR2) is signal.SIG_IGN
    os.kill(os.getpid(), signal.SIGUSR2)   # ignored: the test process lives on
