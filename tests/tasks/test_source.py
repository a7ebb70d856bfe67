"""The env source digest in a task's identity covers the researcher's own modules it imports
(:mod:`taskcomplexity.tasks.source`)."""

from __future__ import annotations

import hashlib
import importlib
import sys
import textwrap
from pathlib import Path

import pytest

from taskcomplexity.tasks import source
from taskcomplexity.tasks.source import own_imports, source_digest

FILES = {
    "__init__.py": "",
    "point.py": """
        import numpy as np
        import lab_envs.dynamics as dynamics
        from . import rewards
        from .constants import GAIN

        class Point:
            gain = GAIN
    """,
    "constants.py": "GAIN = 2.0\n",
    "dynamics.py": "from .shared.units import METRE\nDT = 0.05 * METRE\n",
    "rewards.py": "def reward(x):\n    return -abs(x)\n",
    "shared/__init__.py": "",
    "shared/units.py": "METRE = 1.0\n",
    "unrelated.py": "NOT_IMPORTED = 1\n",
}


@pytest.fixture
def package(tmp_path, monkeypatch):
    """A researcher's env package on the path: point.py imports three helpers, one of them through another."""
    root = tmp_path / "lab_envs"
    for name, text in FILES.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(textwrap.dedent(text))
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    yield root
    for name in [n for n in sys.modules if n == "lab_envs" or n.startswith("lab_envs.")]:
        del sys.modules[name]  # find_spec imports the parent packages: the next test's package is another directory


def test_the_digest_follows_the_imports_of_the_researchers_own_modules_only(package):
    assert set(own_imports("lab_envs.point", package / "point.py")) == {
        "lab_envs", "lab_envs.constants", "lab_envs.dynamics", "lab_envs.rewards", "lab_envs.shared",
        "lab_envs.shared.units"}  # numpy is installed, not the researcher's; unrelated.py is not imported


@pytest.mark.parametrize("edited", ["constants.py", "shared/units.py", "rewards.py", "point.py"])
def test_an_edit_to_the_env_or_any_module_it_imports_is_a_new_digest(package, edited):
    before = source_digest("lab_envs.point")
    (package / edited).write_text((package / edited).read_text() + "\nCHANGED = True\n")
    assert source_digest("lab_envs.point") != before


def test_an_edit_elsewhere_in_the_package_keeps_the_digest(package):
    before = source_digest("lab_envs.point")
    (package / "unrelated.py").write_text("NOT_IMPORTED = 2\n")
    assert source_digest("lab_envs.point") == before


def test_an_installed_env_or_one_of_ours_keeps_the_digest_of_its_one_file(monkeypatch):
    def unread(module, path):
        raise AssertionError(f"{path} read for its imports")

    monkeypatch.setattr(source, "_imports", unread)   # an installed file's imports are not even read
    for module in ("gymnasium.envs.classic_control.pendulum", "taskcomplexity.tasks.manipulation"):
        origin = Path(importlib.util.find_spec(module).origin)
        assert source_digest(module) == hashlib.sha256(origin.read_bytes()).hexdigest()[:16], module


def test_an_env_file_without_own_imports_keeps_the_digest_of_its_one_file(tmp_path, monkeypatch):
    (tmp_path / "single_env.py").write_text("import math\nclass Env:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    assert source_digest("single_env") == hashlib.sha256((tmp_path / "single_env.py").read_bytes()).hexdigest()[:16]
    assert source_digest("no_such_module_anywhere") == ""


def test_an_installed_package_it_imports_is_not_imported_to_compute_the_digest(package):
    """Following ``from gymnasium.utils.save_video import …`` would import gymnasium's package (which raises without
    moviepy): an installed package's modules are not followed, so nothing of it runs."""
    (package / "rewards.py").write_text("from gymnasium.utils.save_video import save_video\n"
                                        "import gymnasium.wrappers.vector\n")
    before = set(sys.modules)
    assert "lab_envs.rewards" in own_imports("lab_envs.point", package / "point.py")
    assert not {m for m in set(sys.modules) - before if m.startswith("gymnasium")}


def test_a_package_in_another_site_packages_on_the_path_is_installed_not_own_code(package, tmp_path, monkeypatch):
    """Another environment's packages on the path (a venv's system site packages, a ``.pth`` line, as in
    tests/test_install.py) are installed: not followed, their digest the one file, however much they import."""
    installed = tmp_path / "elsewhere" / "lib" / "python3" / "site-packages" / "lab_installed"
    installed.mkdir(parents=True)
    (installed / "__init__.py").write_text("from . import helper\n")
    (installed / "helper.py").write_text("import lab_installed\n")
    (package / "rewards.py").write_text("import lab_installed.helper\n")
    monkeypatch.syspath_prepend(str(installed.parent))
    importlib.invalidate_caches()
    source._installed_roots.cache_clear()
    try:
        assert own_imports("lab_envs.point", package / "point.py").keys().isdisjoint({"lab_installed",
                                                                                      "lab_installed.helper"})
        assert source_digest("lab_installed.helper") == hashlib.sha256(
            (installed / "helper.py").read_bytes()).hexdigest()[:16]
    finally:
        source._installed_roots.cache_clear()
        source._own_package.cache_clear()
        sys.modules.pop("lab_installed", None)
