"""The how-to "Add a policy family" (docs/how-to/add-a-policy-family.md), followed on a scratch copy of the
repository: its blocks applied as printed (the how-to pages' convention, ``tests/recipes/howto.py``), its commands
run, the policy tests passed with the new family registered, and its refusal line printed by the real command.
So the page cannot drift from the code: a line it inserts at that moved, or a file count that changed, fails here.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pandas as pd
import pytest
from howto import (
    REPOSITORY,
    apply,
    blocks,
    copy_repository,
    environment,
    page,
    skip_if_followed,
    stated_counts,
    touched,
)

import preloaded

ROOT = REPOSITORY
PAGE = "add-a-policy-family.md"
FENCE = re.compile(r"^```(?P<language>\w+)[^\n]*\n(?P<text>.*?)^```$", re.S | re.M)
FILES = ["src/taskcomplexity/policies/constant.py", "src/taskcomplexity/conf/network/constant.yaml",
         "src/taskcomplexity/policies/families.py", "src/taskcomplexity/stages/rwg_stage.py",
         "src/taskcomplexity/policies/__init__.py"]
"""The files the page touches, in its order."""
RUNS = (("kernel", "Pendulum-v1"), ("gym", "CartPole-v1"))
"""The backend and the task of each of the page's commands."""


def fenced(language: str) -> list[str]:
    """The page's code blocks in ``language``."""
    return [m["text"] for m in FENCE.finditer(page(PAGE)) if m["language"] == language]


@pytest.fixture(scope="module")
def recipe(tmp_path_factory) -> Path:
    """A scratch copy of the repository (the sources with numba's caches, the pipelines, the tests it runs) with
    the page's blocks applied."""
    skip_if_followed(blocks(page(PAGE)))
    root = copy_repository(tmp_path_factory.mktemp("recipe"))
    apply(root, blocks(page(PAGE)))
    return root


def test_the_page_states_the_files_it_touches():
    assert touched(blocks(page(PAGE))) == FILES
    assert stated_counts(page(PAGE))[0] == len(FILES) == 5


def test_the_new_family_runs_rwg_on_the_kernel_and_gym_backends_as_printed(recipe):
    """The page's commands (N = 10, M = 4) write the family's returns, on the backend each names."""
    commands = [line.split("#")[0].split() for text in fenced("bash") for line in text.splitlines()
                if line.startswith(".venv/bin/python pipelines/rwg.py")]
    assert len(commands) == len(RUNS)
    for args, (backend, task) in zip(commands, RUNS, strict=True):
        outputs = recipe / "outputs" / backend
        done = preloaded.run([sys.executable, *args[1:], f"paths.outputs={outputs}"], cwd=recipe,
                             env=environment(recipe), capture_output=True, text=True, timeout=300)
        log = done.stdout + done.stderr
        assert done.returncode == 0, log[-3000:]
        assert f"rwg {task} [{backend}]" in log and f"computed returns {task} constant normal N=10 M=4" in log, log[-3000:]
        (returns,) = (outputs / "cache" / "rwg").glob("*/returns.parquet")
        frame = pd.read_parquet(returns)
        assert len(frame) == 10 * 4 and sorted(frame["policy"].unique()) == list(range(10))
        assert frame["return"].notna().all() and (frame["steps"] >= 1).all()


def test_the_policy_tests_pass_with_the_new_family_registered(recipe):
    """tests/policies/test_policies.py goes over every registered family: the new one answers the calls of each backend it
    runs on, is the same policy sampled alone or among others, and runs RWG on each of those backends. The RWG
    stage's declaration covers its module (tests/stages/test_numerics.py), and the copy stays lint-clean."""
    done = preloaded.run([sys.executable, "-m", "pytest", "-q", "-rA", "-p", "no:cacheprovider", "-p", "no:xdist",
                           "tests/policies/test_policies.py",
                           "tests/stages/test_numerics.py::test_a_stages_declaration_covers_every_module_it_runs",
                           "tests/test_docstring_references.py::test_each_package_docstring_names_every_module_of_its_folder"],
                         cwd=recipe, env=environment(recipe), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    passed = set(re.findall(r"^PASSED tests/policies/test_policies.py::(\w+)\[constant-(\w+)\]", done.stdout, re.M))
    for backend in ("batched", "pybullet", "gym", "kernel"):
        assert {("test_a_familys_batch_answers_the_calls_of_each_backend_it_runs_on", backend),
                ("test_a_family_runs_rwg_on_each_backend_it_runs_on", backend)} <= passed, done.stdout[-3000:]
    pytest.importorskip("ruff")
    lint = preloaded.run([sys.executable, "-m", "ruff", "check", "src"], cwd=recipe, capture_output=True, text=True,
                         timeout=120)
    assert lint.returncode == 0, lint.stdout[-3000:]


def test_a_family_a_backend_cannot_run_is_refused_in_one_line_as_the_page_prints_it(tmp_path):
    """``network=dmp backend=gym`` on an arm: exit 2, the page's one error line, nothing computed."""
    (printed,) = [text.strip() for text in fenced("text") if text.startswith("error: ")]
    done = preloaded.run([sys.executable, str(ROOT / "pipelines" / "rwg.py"), "arm=two_link", "network=dmp",
                           "backend=gym", f"paths.outputs={tmp_path}"], cwd=tmp_path, env=environment(ROOT),
                         capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr[-3000:]
    assert done.stderr.strip().splitlines() == [printed]
    assert not list((tmp_path / "cache").glob("rwg/*"))
