"""The how-to recipes, followed on a scratch copy of the repository (``docs/how-to/*.md``, ``howto.py``).

:func:`scratch` copies what the tests and the entry points read — ``src`` (with numba's caches in its
``__pycache__`` folders, so the kernels are not compiled again), ``tests``, ``conf`` when the root has it,
``pipelines`` and ``pyproject.toml``; not ``.venv``, ``outputs`` or ``site`` — into ``tmp_path``. Each recipe
test applies its page's blocks to the copy, then runs, in a subprocess with the copy's ``src`` first on
``PYTHONPATH`` and the copy as working directory, the tests the change concerns and a smoke run of the new
thing.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from howto import Block, apply, copy_repository

import preloaded


@dataclass(frozen=True)
class Scratch:
    """A scratch copy of the repository at ``root``."""

    root: Path

    def follow(self, chosen: list[Block]) -> list[Path]:
        """Apply a page's blocks to the copy (:func:`howto.apply`)."""
        return apply(self.root, chosen)

    def run(self, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
        """``python <args>`` in the copy; fails the test with the output when it exits non-zero."""
        env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "PYTHONPATH"))}
        env["PYTHONPATH"] = str(self.root / "src")
        env["TASKCOMPLEXITY_OUTPUTS"] = str(self.root / "outputs")
        done = preloaded.run([sys.executable, *args], cwd=self.root, env=env, capture_output=True, text=True,
                             timeout=timeout)
        if done.returncode != 0:
            pytest.fail(f"`python {' '.join(args)}` in the scratch copy exited {done.returncode}:\n"
                        f"{done.stdout[-6000:]}\n{done.stderr[-6000:]}", pytrace=False)
        return done

    def command(self, env: dict[str, str], words: list[str], *more: str,
                timeout: float = 300) -> subprocess.CompletedProcess:
        """A command a page prints (:func:`howto.commands`), run in the copy: ``…/python`` is this interpreter,
        ``PYTHONPATH=src`` the copy's ``src``; ``more`` are appended to its words."""
        unknown = set(env) - {"PYTHONPATH"}
        assert not unknown and env.get("PYTHONPATH", "src") == "src", f"a command's environment: {env}"
        assert words[0].endswith("python"), f"a command runs python: {words}"
        return self.run(*words[1:], *more, timeout=timeout)

    def pytest(self, *paths: str, timeout: float = 300) -> subprocess.CompletedProcess:
        """The tests ``paths`` of the copy (its own conftest and pyproject), run as ``make test`` runs them: on a
        pytest-xdist worker, a file at a time (what a worker reports to the controller must cross that line). One
        worker, not one per core: the suite around this test already keeps every core busy, and each worker costs
        a start of torch and the package."""
        return self.run("-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "1", "--dist", "loadfile",
                        "-m", "not slow", *paths, timeout=timeout)


@pytest.fixture
def scratch(tmp_path) -> Scratch:
    """A scratch copy of the repository under ``tmp_path`` (see the module docstring)."""
    return Scratch(copy_repository(tmp_path / "repository"))
