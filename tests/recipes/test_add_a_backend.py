"""The how-to "Add a backend" (docs/how-to/add-a-backend.md), followed on a scratch copy of the repository: its blocks
applied as printed (``tests/recipes/howto.py``), its two commands run (the new backend's returns equal the ``gym``
backend's), and the tests that go over every registered backend passed with the new one registered. So the page
cannot drift from the code: a line it inserts at that moved, or a file count that changed, fails here.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pandas as pd
import pytest
from howto import (
    apply,
    blocks,
    commands,
    copy_repository,
    environment,
    page,
    skip_if_followed,
    stated_counts,
    touched,
)

import preloaded

PAGE = "add-a-backend.md"
FILES = ["src/taskcomplexity/rwg/serial_backend.py", "src/taskcomplexity/rwg/backends.py",
         "src/taskcomplexity/rwg/__init__.py"]
"""The files the page touches, in its order."""


@pytest.fixture(scope="module")
def recipe(tmp_path_factory) -> Path:
    """A scratch copy of the repository with the page's blocks applied."""
    skip_if_followed(blocks(page(PAGE)))
    root = copy_repository(tmp_path_factory.mktemp("recipe"))
    apply(root, blocks(page(PAGE)))
    return root


def test_the_page_states_the_files_it_touches():
    assert touched(blocks(page(PAGE))) == FILES
    assert stated_counts(page(PAGE))[0] == len(FILES) == 3


def test_the_new_backend_gives_the_gym_backends_returns_as_printed(recipe):
    """The page's two commands: the same N × M returns on ``serial`` and on ``gym``, to the bit, under two keys."""
    runs = [words for _, words in commands(page(PAGE))]
    assert [next(w for w in words if w.startswith("backend=")) for words in runs] == ["backend=serial", "backend=gym"]
    frames = []
    for words in runs:
        backend = next(w for w in words if w.startswith("backend=")).partition("=")[2]
        outputs = recipe / "outputs" / backend
        done = preloaded.run([sys.executable, *words[1:], f"paths.outputs={outputs}"], cwd=recipe,
                             env=environment(recipe), capture_output=True, text=True, timeout=600)
        log = done.stdout + done.stderr
        assert done.returncode == 0, log[-3000:]
        assert f"rwg CartPole-v1 [{backend}]" in log, log[-3000:]
        (returns,) = (outputs / "cache" / "rwg").glob("*/returns.parquet")
        frames.append(pd.read_parquet(returns).sort_values(["policy", "episode"]).reset_index(drop=True))
    serial, gym = frames
    assert len(serial) == 6 * 3
    pd.testing.assert_frame_equal(serial, gym, check_exact=True)


def test_the_backend_tests_pass_with_the_new_backend_registered(recipe):
    """tests/rwg/test_backends.py goes over every declaration, tests/policies/test_policies.py runs every family on the
    new backend; the RWG stage's declaration covers its module (it reads the registry), the package docstring names
    it, and the copy stays lint-clean."""
    done = preloaded.run([sys.executable, "-m", "pytest", "-q", "-rA", "-p", "no:cacheprovider", "-p", "no:xdist",
                           "tests/rwg/test_backends.py", "tests/policies/test_policies.py",
                           "tests/stages/test_numerics.py::test_a_stages_declaration_covers_every_module_it_runs",
                           "tests/test_docstring_references.py::test_each_package_docstring_names_every_module_of_its_folder"],
                         cwd=recipe, env=environment(recipe), capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    passed = set(re.findall(r"^PASSED tests/policies/test_policies.py::(\w+)\[mlp-serial\]", done.stdout, re.M))
    assert {"test_a_familys_batch_answers_the_calls_of_each_backend_it_runs_on",
            "test_a_family_runs_rwg_on_each_backend_it_runs_on"} <= passed, done.stdout[-3000:]
    assert re.search(r"^PASSED tests/rwg/test_backends.py::\w+\[serial\]", done.stdout, re.M), done.stdout[-3000:]
    pytest.importorskip("ruff")
    lint = preloaded.run([sys.executable, "-m", "ruff", "check", "src"], cwd=recipe, capture_output=True, text=True,
                         timeout=120)
    assert lint.returncode == 0, lint.stdout[-3000:]
