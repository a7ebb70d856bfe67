"""Worker processes end with their run (:mod:`taskcomplexity.processes`): a parent killed with ``kill -9`` takes its
workers with it, Ctrl-C and ``SIGTERM`` stop a run's workers at once with one line, a worker that dies is one line
naming what is saved."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from taskcomplexity.errors import WorkerLost
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.tasks.gym_task import GymTask

ROOT = Path(__file__).resolve().parents[1]

RUN = textwrap.dedent("""
    import os, sys, time
    import numpy as np
    from taskcomplexity.cli import one_line_errors
    from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
    from taskcomplexity.rwg import workers
    from taskcomplexity.rwg.settings import RWGSettings
    from taskcomplexity.tasks.gym_task import GymTask

    def slow(task, network, prior, settings, backend, start, stop):  # a chunk of a minute: the run is interrupted
        with open(os.path.join(sys.argv[1], f"worker-{os.getpid()}"), "w"):
            pass
        time.sleep(60)

    workers._chunk = slow  # the forked workers inherit it

    @one_line_errors
    def main():
        workers.run_on_workers(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(), "gym",
                               [(0, 1), (1, 2), (2, 3)], 2, lambda key, chunk: None)

    main()
""")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    status = Path(f"/proc/{pid}/status")
    return not (status.is_file() and "\nState:\tZ" in status.read_text())  # a zombie has ended


def _start(tmp_path, *, ignore_sigint: bool = False) -> tuple[subprocess.Popen, list[int]]:
    """The run of :data:`RUN` in a process of its own, once both its workers hold a chunk: (process, worker pids).
    ``ignore_sigint``: start it as a script's ``cmd &`` does, with SIGINT ignored."""
    script = tmp_path / "run.py"
    script.write_text(RUN)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    process = subprocess.Popen([sys.executable, str(script), str(tmp_path)], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True,
                               preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ignore_sigint
                               else None)
    deadline = time.monotonic() + 60
    while len(pids := [int(p.name.split("-")[1]) for p in tmp_path.glob("worker-*")]) < 2:
        assert time.monotonic() < deadline and process.poll() is None, process.communicate()
        time.sleep(0.1)
    return process, pids


def _gone(pids: list[int], within: float = 10.0) -> bool:
    deadline = time.monotonic() + within
    while any(_alive(p) for p in pids):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


def test_the_workers_die_with_a_parent_killed_by_sigkill(tmp_path):
    process, workers = _start(tmp_path)
    process.kill()
    process.wait(timeout=10)
    assert _gone(workers), "a worker outlived its parent's kill -9"


@pytest.mark.parametrize(("stop", "status", "line"), [
    (signal.SIGINT, 130, "interrupted; rerun the same command to resume"),
    (signal.SIGTERM, 143, "terminated (SIGTERM); rerun the same command to resume"),
])
def test_sigint_and_sigterm_stop_the_run_and_its_workers_at_once_in_one_line(tmp_path, stop, status, line):
    process, workers = _start(tmp_path, ignore_sigint=True)  # kill -INT reaches a run started with `cmd &` too
    started = time.monotonic()
    process.send_signal(stop)
    _, err = process.communicate(timeout=30)
    assert time.monotonic() - started < 15  # not the minute its chunks take
    assert process.returncode == status and err.strip() == line, err
    assert _gone(workers)


def _dies_second(task, network, prior, settings, backend, start, stop):
    """A worker's chunk: chunk 0 returns at once, chunk 1 kills its worker (as the OOM killer does)."""
    if start == 1:
        time.sleep(0.5)
        os.kill(os.getpid(), signal.SIGKILL)
    if start > 1:
        time.sleep(5)
    return ReturnChunk(np.arange(start, stop), np.zeros((stop - start, 2)), np.ones((stop - start, 2), dtype=np.int64),
                       np.zeros((stop - start, 2), dtype=bool))


def test_a_worker_that_dies_is_one_error_naming_what_is_saved(monkeypatch):
    from taskcomplexity.rwg import workers

    monkeypatch.setattr(workers, "_chunk", _dies_second)  # the forked workers inherit it
    done = {}
    with pytest.raises(WorkerLost, match=r"^an RWG worker process of CartPole-v1 died \(killed, or out of memory\) "
                       r"with 3 of 4 chunks unfinished; the 1 finished are saved: rerun the same command to resume$"):
        workers.run_on_workers(GymTask("CartPole-v1"), NetworkSpec(), PriorSpec(), RWGSettings(), "gym",
                               [(0, 1), (1, 2), (2, 3), (3, 4)], 2, done.__setitem__)
    assert list(done) == [(0, 1)]


def test_a_worker_whose_parent_is_gone_before_it_starts_exits(tmp_path):
    """The parent-death signal is armed after the worker starts: a parent already gone is caught by its pid."""
    script = textwrap.dedent("""
        import multiprocessing, os, sys, time

        def work(path):
            time.sleep(1.0)  # the parent is gone by now
            from taskcomplexity.processes import start_worker
            start_worker()
            open(path, "w").write("survived")

        if __name__ == "__main__":
            worker = multiprocessing.get_context("fork").Process(target=work, args=(sys.argv[1],))
            worker.start()
            print(worker.pid, flush=True)
            os._exit(0)
    """)
    survived = tmp_path / "survived"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    done = subprocess.run([sys.executable, "-c", script, str(survived)], env=env, capture_output=True, text=True,
                          timeout=30)
    child = int(done.stdout)
    assert _gone([child]) and not survived.exists()


def test_an_interrupt_inside_a_finaliser_still_ends_the_run_in_one_line(tmp_path):
    """Ctrl-C that lands in an object's ``__del__`` (pybullet's client, closing an env) would be printed as
    "Exception ignored in …" and lost; the entry point delivers it again."""
    script = textwrap.dedent("""
        import time
        from taskcomplexity.cli import one_line_errors

        class Client:
            def __del__(self):
                raise KeyboardInterrupt  # as if Ctrl-C arrived while the finaliser ran

        @one_line_errors
        def main():
            Client()
            time.sleep(30)

        main()
    """)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=60)
    assert time.monotonic() - started < 20
    assert done.returncode == 130 and done.stderr.strip() == "interrupted; rerun the same command to resume", \
        done.stderr
