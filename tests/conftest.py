"""Shared fixtures: compose the real Hydra config (shrunk where needed) into a temporary directory."""

from __future__ import annotations

import os

# As the commands set it (taskcomplexity.commands): OpenMP's threads (torch's, scikit-learn's) sleep while they wait
# instead of spinning, which takes a core from the other pytest-xdist worker. Read once, when a library loads
# OpenMP: set before any is imported.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import contextlib  # noqa: E402
import subprocess  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402
from hydra import compose, initialize_config_dir  # noqa: E402
from hydra.core.global_hydra import GlobalHydra  # noqa: E402
from omegaconf import open_dict  # noqa: E402

from taskcomplexity.cli import CONF_DIR  # noqa: E402


@pytest.fixture
def compose_config(tmp_path):
    """``compose_config(*overrides)`` → the composed config with ``paths.outputs`` in ``tmp_path``."""

    def _compose(*overrides: str):
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            cfg = compose("config", overrides=list(overrides))
        with open_dict(cfg):
            if not any(o.startswith("paths.outputs=") for o in overrides):
                cfg.paths.outputs = str(tmp_path / "outputs")
        return cfg

    yield _compose
    GlobalHydra.instance().clear()


@pytest.fixture(autouse=True)
def _environment_restored():
    """Each test leaves ``os.environ`` as it found it: an entry point called in the test's process sets variables
    for its own subprocesses (``PYTHONWARNINGS``, :func:`taskcomplexity.processes.quiet_tracker`), which would
    otherwise reach every later test of the worker, and make its commands differ from the fork server's
    environment (``tests/preloaded.py``)."""
    before = dict(os.environ)
    yield
    if os.environ != before:
        os.environ.clear()
        os.environ.update(before)


LONGEST_FIRST = ("tests/test_docs_commands.py", "tests/recipes/", "tests/stages/test_scale_out.py",
                 "tests/study/test_study_chain.py", "tests/commands/test_refusals.py", "tests/rwg/test_envpool_backend.py")
"""The files that take longest on a pytest-xdist worker (a file runs whole on one, ``--dist loadfile``), collected
first, so that ``make test`` does not end on one worker running one of them while the other waits. Only the order
of files changes (``--no-loadscope-reorder`` keeps it)."""


def pytest_collection_modifyitems(config, items):
    def rank(item) -> int:
        path = item.nodeid.split("::")[0]
        return next((i for i, start in enumerate(LONGEST_FIRST) if path.startswith(start)), len(LONGEST_FIRST))

    items.sort(key=rank)  # stable: the order within a file, and among the other files, is pytest's


def pytest_terminal_summary(terminalreporter):
    """The kernels this run computed with (numba's target, NumPy's dispatch, torch's capability, the BLAS), in the
    summary that ``-q`` keeps: CI runs the tests that pin numbers on two code paths where the CPU has two, and its
    log says which was which."""
    from cpu_paths import describe

    terminalreporter.write_line(f"CPU code paths: {describe()}")


@pytest.fixture
def tmpfs():
    """``with tmpfs(mount, size) as mount:`` a tmpfs of ``size`` (``"2m"``) mounted at ``mount`` for the span of the
    block (a small disk that fills); the test is skipped where this user cannot mount one."""

    @contextlib.contextmanager
    def mounted(mount: Path, size: str):
        mount.mkdir()
        made = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mount)],
                              capture_output=True)
        if made.returncode != 0:
            pytest.skip(f"cannot mount a filesystem here ({made.stderr.decode().strip()})")
        try:
            yield mount
        finally:
            subprocess.run(["umount", "-l", str(mount)], check=False)

    return mounted
