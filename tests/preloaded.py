"""Python commands for the tests, forked from an interpreter that has imported the heavy libraries once.

A test that runs ``python pipelines/rwg.py …`` in a fresh interpreter pays about three CPU-seconds before the
command does anything: importing torch, NumPy, SciPy, pandas, numba and Hydra. :func:`run` is
:func:`subprocess.run` (output captured as text) for such commands, served by multiprocessing's fork server
with those libraries preloaded (:data:`PRELOAD`): each command runs in a process forked from it, with the
command's arguments, working directory, environment, ``sys.path`` (the script's folder or the working directory,
then ``PYTHONPATH``, then the interpreter's own) and fresh standard streams, and ends as the interpreter would:
its threads joined, its ``atexit`` handlers run, a ``SystemExit`` code or an uncaught exception's traceback (from
the command's own frames) and status 1. The package itself is never preloaded: every command imports it afresh,
from whichever ``src`` its ``PYTHONPATH`` names.

A command starts in a fresh interpreter instead (plain :func:`subprocess.run`) when the fork would not be the
interpreter it asks for:

- it is not ``python <script> …``, ``python -m <module> …`` or ``python -c <code> …`` with this interpreter;
- its environment differs from the fork server's in anything the preloaded libraries read when imported (every
  variable except those of :data:`PER_COMMAND`: numba's target, NumPy's dispatch and torch's capability among them);
- it is given ``input``, or ``TASKCOMPLEXITY_TESTS_FORK=0`` is set (every command in a fresh interpreter: what to
  set when a difference between the two is suspected).

What a fork does not reproduce is the interpreter's own start and end: its start-up time, the modules a command
imports (the preloaded ones are there already), the objects finalized as it exits, the signals' dispositions it
inherits. The tests of those (``tests/commands/test_startup.py``, ``tests/test_post_import.py``,
``tests/test_processes.py``, ``tests/stages/test_faults.py``) start their commands with :mod:`subprocess`.
"""

from __future__ import annotations

import atexit
import itertools
import json
import multiprocessing
import os
import runpy
import signal
import subprocess
import sys
import tempfile
import threading
import types
from pathlib import Path

PRELOAD = ["numpy", "torch", "scipy.stats", "pandas", "pyarrow.parquet", "hydra", "omegaconf", "gymnasium",
           "numba", "tqdm", "matplotlib", "seaborn", "sklearn.neighbors", "sklearn.feature_selection"]
"""What the fork server imports once: the libraries that most commands import and that take most of their start
(seaborn and scikit-learn: 0.8 CPU-s of a study's start once the others are in). Not TorchRL (1.8 CPU-s more):
importing it sets multiprocessing's start method for the whole process, which a command that does not import it
must not inherit."""

PER_COMMAND = ("TASKCOMPLEXITY_", "PYTHONPATH", "PYTEST_", "HYDRA_FULL_ERROR", "SLURM_", "COLUMNS", "LINES")
"""Environment variables (names or prefixes) a command may set to its own values and still be forked: none of
the preloaded libraries reads them when imported."""

_served: dict[str, object] = {}
"""The fork server's context, the environment it started with, and the interpreter's own ``sys.path``."""


def run(args: list[str], *, cwd: str | Path | None = None, env: dict[str, str] | None = None,
        timeout: float | None = None, check: bool = False, input: str | None = None, capture_output: bool = True,
        text: bool = True) -> subprocess.CompletedProcess:
    """``subprocess.run(args, cwd=cwd, env=env, timeout=timeout, check=check, input=input, capture_output=True,
    text=True)``, forked from the preloaded interpreter where that is the same interpreter (module docstring). The
    output is always captured, as text."""
    assert capture_output and text, "preloaded.run captures the output as text"
    env = dict(os.environ if env is None else env)
    cwd = str(cwd if cwd is not None else os.getcwd())
    if input is not None or not _forkable(args, env):
        return subprocess.run(args, cwd=cwd, env=env, timeout=timeout, check=check, input=input,
                              capture_output=True, text=True)
    context = _server()
    with tempfile.TemporaryDirectory(prefix="taskcomplexity-fork-") as streams:
        out, err = Path(streams, "stdout"), Path(streams, "stderr")
        process = context.Process(target=_command, args=(list(args[1:]), cwd, env, str(out), str(err),
                                                         _served["path"]))
        process.start()
        process.join(timeout)
        if process.is_alive():
            process.kill()
            process.join()
            raise subprocess.TimeoutExpired(args, timeout, output=_read(out), stderr=_read(err))
        done = subprocess.CompletedProcess(args, process.exitcode, _read(out), _read(err))
    if check:
        done.check_returncode()
    return done


def _forkable(args: list[str], env: dict[str, str]) -> bool:
    if os.environ.get("TASKCOMPLEXITY_TESTS_FORK") == "0" or env.get("TASKCOMPLEXITY_TESTS_FORK") == "0":
        return False
    if len(args) < 2 or os.path.realpath(args[0]) != os.path.realpath(sys.executable):
        return False
    if args[1] in ("-m", "-c"):
        if len(args) < 3:
            return False
    elif args[1].startswith("-") or not str(args[1]).endswith(".py"):
        return False
    started = _served.get("env", os.environ)

    def fixed(environment):
        return {k: v for k, v in environment.items() if not k.startswith(PER_COMMAND)}

    return fixed(env) == fixed(started)


def _server():
    """multiprocessing's fork server for this process, started on first use with :data:`PRELOAD` imported."""
    if "context" not in _served:
        plain = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        probe = subprocess.run([sys.executable, "-c", "import json, sys; print(json.dumps(sys.path[1:]))"],
                               env=plain, capture_output=True, text=True, check=True)
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(PRELOAD)
        _served.update(context=context, env=dict(os.environ), path=json.loads(probe.stdout))
    return _served["context"]


def _read(path: Path) -> str:
    return path.read_text(encoding="utf-8", errors="replace") if path.exists() else ""


def _command(args: list[str], cwd: str, env: dict[str, str], out: str, err: str, path: list[str]) -> None:
    """In the forked process: become ``python <args>`` in ``cwd`` with ``env``, run it, and end as it would."""
    _become_a_main_process()
    os.environ.clear()
    os.environ.update(env)
    os.chdir(cwd)
    for fd, name in ((1, out), (2, err)):
        stream = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(stream, fd)
        os.close(stream)
    first = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    code, interrupted = 0, False
    try:
        if args[0] == "-m":
            sys.argv = ["-m", *args[2:]]
            sys.path[:] = [cwd, *first, *path]
            runpy.run_module(args[1], run_name="__main__", alter_sys=True)
        elif args[0] == "-c":
            sys.argv = ["-c", *args[2:]]
            sys.path[:] = ["", *first, *path]
            main = types.ModuleType("__main__")
            sys.modules["__main__"] = main
            exec(compile(args[1], "<string>", "exec"), main.__dict__)
        else:
            sys.argv = list(args)
            sys.path[:] = [os.path.dirname(os.path.abspath(args[0])), *first, *path]
            runpy.run_path(args[0], run_name="__main__")
    except SystemExit as stop:
        if stop.code is None or isinstance(stop.code, int):
            code = stop.code or 0
        else:
            print(stop.code, file=sys.stderr)
            code = 1
    except BaseException as error:  # noqa: BLE001 -- the interpreter's last resort: its traceback, status 1
        error = error.with_traceback(_own_frames(error.__traceback__))  # the value's own is the one printed
        sys.excepthook(type(error), error, error.__traceback__)
        code, interrupted = 1, isinstance(error, KeyboardInterrupt)
    threading._shutdown()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    if interrupted:  # ended by the signal, as the interpreter ends on an uncaught KeyboardInterrupt
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    os._exit(code)


def _become_a_main_process() -> None:
    """multiprocessing's state as a fresh interpreter has it: its default start method, no parent, no children,
    no resource tracker or fork server yet (the command starts its own, reading its own environment, as it would)."""
    from multiprocessing import context, forkserver, process, resource_tracker

    context._default_context._actual_context = None
    process._parent_process = None
    main = process._current_process  # what _MainProcess() is in a fresh interpreter (the class is not kept)
    main._identity, main._name, main._parent_pid, main._popen, main._closed = (), "MainProcess", None, None, False
    main._config = {"authkey": process.AuthenticationString(os.urandom(32)), "semprefix": "/mp"}
    process._children = set()
    process._process_counter = itertools.count(1)
    tracker = resource_tracker._resource_tracker
    tracker._fd = tracker._pid = None
    server = forkserver._forkserver
    server._forkserver_address = server._forkserver_alive_fd = server._forkserver_pid = None
    server._inherited_fds = None
    server._preload_modules = ["__main__"]


def _own_frames(tb: types.TracebackType | None) -> types.TracebackType | None:
    """The traceback from the command's first frame: without this module's and runpy's."""
    skipped = {__file__, runpy.__file__, "<frozen runpy>"}
    while tb is not None and tb.tb_frame.f_code.co_filename in skipped:
        tb = tb.tb_next
    return tb
