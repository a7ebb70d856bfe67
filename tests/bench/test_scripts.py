"""Every benchmark script imports: a name one of them takes from the package is still there (make bench runs them
only by hand, so a stale import would otherwise wait for the next benchmark run to show)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
EXTRAS = {"mujoco", "envpool", "metaworld", "dm_control", "imageio"}
"""Top-level modules of the optional extras (atlas, metaworld): a script needing one is skipped without it."""


@pytest.mark.parametrize("script", sorted(p.name for p in BENCH.glob("*.py")))
def test_the_script_imports(script, monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))  # the scripts import one another (floors, cpu_paths' helpers)
    monkeypatch.syspath_prepend(str(BENCH.parent / "tests"))
    spec = importlib.util.spec_from_file_location(f"bench_script_{Path(script).stem}", BENCH / script)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # a dataclass looks its module up while the script runs
    try:
        spec.loader.exec_module(module)
    except ModuleNotFoundError as err:
        if (err.name or "").split(".")[0] in EXTRAS:
            pytest.skip(f"{script} needs {err.name} (an optional extra)")
        raise
    finally:
        sys.modules.pop(spec.name, None)
