"""tests/preloaded.py: a command forked from the preloaded interpreter ends as it ends in a fresh one (status,
standard output, standard error) for the kinds of commands the tests run."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import preloaded

ROOT = Path(__file__).resolve().parents[1]

PROBE = textwrap.dedent("""
    import json, multiprocessing, os, sys, concurrent.futures
    def pid(_):
        return os.getppid()
    if __name__ == "__main__":
        with concurrent.futures.ProcessPoolExecutor(1) as pool:
            parent = pool.submit(pid, 0).result()
        print(json.dumps({"argv": sys.argv[1:], "path0": sys.path[0], "name": __name__,
                          "method": multiprocessing.get_start_method(), "parent": multiprocessing.parent_process(),
                          "process": multiprocessing.current_process().name, "pool parent is me": parent == os.getpid(),
                          "outputs": os.environ.get("TASKCOMPLEXITY_OUTPUTS"), "cwd": os.getcwd(),
                          "package first": sys.path.index(os.environ["PYTHONPATH"]) < 3}, default=str))
        print("to stderr", file=sys.stderr)
""")

SCRIPTS = {
    "probe": PROBE,
    "raises": "def deep():\n    raise ValueError('a genuine bug')\n\ndeep()\n",
    "exits 3": "import sys\nprint('bye')\nsys.exit(3)\n",
    "exits with a message": "import sys\nsys.exit('error: one line')\n",
    "KeyboardInterrupt": "raise KeyboardInterrupt\n",
    "atexit": "import atexit\natexit.register(print, 'at exit')\nprint('first')\n",
}


@pytest.mark.parametrize("name", SCRIPTS)
@pytest.mark.parametrize("form", ["script", "-c"])
def test_a_forked_command_ends_as_in_a_fresh_interpreter(tmp_path, name, form):
    script = tmp_path / "probe.py"
    script.write_text(SCRIPTS[name])
    args = [sys.executable, str(script), "a", "b"] if form == "script" else [sys.executable, "-c", SCRIPTS[name], "a"]
    env = {**os.environ, "TASKCOMPLEXITY_OUTPUTS": str(tmp_path / "out"), "PYTHONPATH": str(tmp_path)}
    assert preloaded._forkable(args, env)  # noqa: SLF001 -- the case this test is about
    forked = preloaded.run(args, cwd=tmp_path, env=env, timeout=120)
    fresh = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert (forked.returncode, forked.stdout, forked.stderr) == (fresh.returncode, fresh.stdout, fresh.stderr)


def test_a_module_run_with_dash_m_prints_what_it_prints_fresh(tmp_path):
    args = [sys.executable, "-m", "taskcomplexity.commands.study_tasks", "seven_tasks"]
    forked = preloaded.run(args, cwd=ROOT, timeout=120)
    fresh = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert (forked.returncode, forked.stdout, forked.stderr) == (fresh.returncode, fresh.stdout, fresh.stderr)
    assert forked.returncode == 0 and forked.stdout.strip()


@pytest.mark.parametrize(("args", "env"), [
    (["-c", "pass"], {"NUMBA_CPU_NAME": "haswell"}),  # read by numba when imported: a fresh interpreter
    (["-c", "pass"], {"OMP_NUM_THREADS": "1"}),
    (["-X", "importtime", "-c", "pass"], {}),  # an interpreter option
    (["pipelines"], {}),  # not a script
])
def test_what_the_preloaded_libraries_would_read_differently_starts_a_fresh_interpreter(args, env):
    assert not preloaded._forkable([sys.executable, *args], {**os.environ, **env})  # noqa: SLF001


def test_a_command_past_its_timeout_is_killed_and_raises_as_subprocess_does(tmp_path):
    with pytest.raises(subprocess.TimeoutExpired):
        preloaded.run([sys.executable, "-c", "import time; print('started', flush=True); time.sleep(60)"],
                      cwd=tmp_path, timeout=3)
