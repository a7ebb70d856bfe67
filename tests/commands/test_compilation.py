"""numba's compilations announced per kernel set, and the warm-up of ``make install``
(taskcomplexity.commands.compilation)."""

from __future__ import annotations

import ast
import logging
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pytest

from taskcomplexity.commands.compilation import (
    KERNEL_SETS,
    TINY,
    WARM_UP_RUNS,
    announce_compilation,
    kernel_set,
)

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "taskcomplexity"
SETS = (("lab.alpha", "alpha"), ("lab.beta", "beta"))
"""Two kernel sets of made-up modules: each kernel below says which module it belongs to."""
DURATION = re.compile(r"\d+(\.\d+)?\s*(s|seconds|min)\b")


def _kernels(module: str):
    """Two njit functions of ``module`` that no process has compiled yet (new objects each call), one calling
    the other."""

    def inner(x):
        return x * 2.0

    inner.__module__ = module
    inner = numba.njit(inner)

    def outer(a):
        total = 0.0
        for v in a:
            total += inner(v)
        return total

    outer.__module__ = module
    return inner, numba.njit(outer)


def test_a_set_is_announced_when_it_starts_and_timed_when_it_ends(caplog):
    inner, outer = _kernels("lab.alpha.kernels")
    lines = []
    with caplog.at_level(logging.DEBUG, logger="taskcomplexity"):
        with announce_compilation(lines.append, sets=SETS, settle=600) as compiled:
            assert outer(np.arange(4.0)) == 12.0   # compiles outer, and inner inside it
            assert outer(np.arange(3.0)) == 6.0    # same types: no compilation
            assert inner(2) == 4                   # new argument types: a compilation of its own, same burst
            assert len(lines) == 1                 # the burst is under way: no end line yet
    assert len(lines) == 2
    announced, done = lines
    assert announced.startswith("compiling the alpha kernels") and "first use on this machine" in announced
    assert "numba caches them" in announced
    assert not DURATION.search(announced), "the announcement promises no duration"
    # inner compiled inside outer counts in outer's time: two outermost compilations, timed as one burst
    assert compiled.kernels == 2 and compiled.seconds > 0
    assert compiled.per_set == {"alpha": [2, compiled.seconds]}
    assert done == f"compiled the alpha kernels in {compiled.seconds:.1f} s"
    assert any(f"numba compiled 2 kernels in {compiled.seconds:.1f} s (alpha 2 in" in r.getMessage()
               for r in caplog.records)


def test_each_set_is_announced_and_timed_on_its_own():
    _, alpha = _kernels("lab.alpha.kernels")
    beta_inner, beta = _kernels("lab.beta")
    lines = []
    with announce_compilation(lines.append, sets=SETS, settle=600) as compiled:
        alpha(np.arange(2.0))
        beta(np.arange(2.0))     # another set starts: alpha's burst ends first
        alpha(np.arange(2))      # alpha again, with other argument types
    assert [line.split(" kernels")[0] for line in lines] == [
        "compiling the alpha", "compiled the alpha", "compiling the beta", "compiled the beta",
        "compiling more of the alpha", "compiled the alpha"]
    assert "numba caches them in" not in lines[2], "the cache's place is said once"
    seconds = [float(re.search(r"in ([\d.]+) s$", line).group(1)) for line in lines[1::2]]
    assert sum(seconds) == pytest.approx(compiled.seconds, abs=0.2)
    assert set(compiled.per_set) == {"alpha", "beta"} and compiled.per_set["alpha"][0] == 2


def test_a_burst_ends_when_no_compilation_follows():
    _, outer = _kernels("lab.beta")
    lines = []
    with announce_compilation(lines.append, sets=SETS, settle=0.05):
        outer(np.arange(2.0))
        deadline = time.monotonic() + 10
        while len(lines) < 2 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert len(lines) == 2 and lines[1].startswith("compiled the beta kernels in ")
    assert len(lines) == 2, "the end of the block says nothing more"


def test_nothing_said_when_nothing_compiles(caplog):
    _, outer = _kernels("lab.alpha")
    outer(np.arange(2.0))  # compiled before the block
    lines = []
    with caplog.at_level(logging.DEBUG, logger="taskcomplexity"):
        with announce_compilation(lines.append, sets=SETS) as compiled:
            outer(np.arange(5.0))
    assert lines == [] and compiled.kernels == 0 and compiled.summary() is None
    assert not any("numba compiled" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(("module", "expected"), [
    ("taskcomplexity.tasks.rollout_kernel", "reaching-arm"),
    ("taskcomplexity.tasks.classic.kernels", "classic-control"),
    ("taskcomplexity.tasks.classic", "classic-control"),
    ("taskcomplexity.metrics.log_mean_exp", "estimator"),
    ("taskcomplexity.policies.movement_primitives", "movement-primitive"),
    ("my_lab.drift", "my_lab"),
    ("taskcomplexity.tasksx", "taskcomplexity"),
])
def test_kernel_sets(module, expected):
    assert kernel_set(module) == expected


def _kernel_modules() -> dict[str, list[str]]:
    """Module → the numba kernels it defines whose decorator lacks ``cache=True`` ('' for each cached one)."""
    found: dict[str, list[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        module = ".".join(("taskcomplexity", *path.relative_to(PACKAGE).with_suffix("").parts))
        module = module.removesuffix(".__init__")
        for node in ast.walk(tree):
            if not isinstance(node, ast.FunctionDef):
                continue
            for decorator in node.decorator_list:
                call = decorator if isinstance(decorator, ast.Call) else None
                target = call.func if call else decorator
                name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
                if name in ("njit", "jit", "vectorize", "guvectorize", "cfunc"):
                    cached = call is not None and any(
                        k.arg == "cache" and isinstance(k.value, ast.Constant) and k.value.value is True
                        for k in call.keywords)
                    found.setdefault(module, []).append("" if cached else node.name)
    return found


def test_every_kernel_of_the_package_is_cached_and_in_a_named_set():
    modules = _kernel_modules()
    assert len(modules) >= 10, "the scan finds the package's kernels"
    named = {name for _, name in KERNEL_SETS}
    assert {m: kernel_set(m) for m in modules if kernel_set(m) not in named} == {}
    assert {m: [k for k in kernels if k] for m, kernels in modules.items() if any(kernels)} == {}
    # every named set has kernels (a set nothing belongs to is a stale name)
    assert {kernel_set(m) for m in modules} == named


def test_make_install_compiles_ahead_what_the_main_targets_run():
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    install = re.search(r"^install:.*\n((?:\t.*\n)+)", makefile, flags=re.MULTILINE)
    assert install and "-m taskcomplexity.commands.compilation" in install.group(1)
    warmed = {o for run, _ in WARM_UP_RUNS for o in run}
    for target in ("run", "quick", "classic"):
        recipe = re.search(rf"^{target}:.*\n\t(.*)\n", makefile, flags=re.MULTILINE).group(1)
        chosen = [o for o in recipe.split() if o.startswith(("experiment=", "study="))]
        assert chosen and set(chosen) <= warmed, (target, chosen)


def test_the_warm_up_runs_are_tiny_valid_configs(compose_config):
    # Every override names a key of the config, and the studies shrink to seconds of work once compiled (the
    # slow test below runs them).
    for run, _ in WARM_UP_RUNS:
        cfg = compose_config(*run, *TINY)
        # M = 8: the k-NN estimator's kernels run only with k = 3 below M / 2 (TINY's docstring)
        assert (cfg.rwg.policies, cfg.rwg.episodes, cfg.sac.enabled) == (10, 8, False), run
        assert cfg.metrics.bins <= 1000 and cfg.metrics.resamples <= 20, run


@pytest.mark.slow
def test_after_the_warm_up_the_main_runs_compile_nothing(tmp_path):
    # A fresh numba cache: the warm-up compiles every set; then make run's and make quick's chains at a small
    # size, and a classic-control task, compile nothing, through the paths the main runs take at their sizes: the
    # k-NN estimator's kernels (M = 8 > 2k) and the kernel backend's parallel step (64 × 64 = PARALLEL_FROM).
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
                   "TASKCOMPLEXITY_OUTPUTS": str(tmp_path / "outputs")}
    python = [sys.executable]
    warm = subprocess.run([*python, "-m", "taskcomplexity.commands.compilation"], cwd=ROOT, env=environment,
                          capture_output=True, text=True, timeout=1800)
    assert warm.returncode == 0, warm.stderr[-3000:]
    assert "compiling the reaching-arm kernels" in warm.stdout and "compiled ahead" in warm.stdout
    runs = [
        ["pipelines/study.py", "experiment=published", "rwg.policies=20", "rwg.episodes=8", "metrics.bins=1000",
         "metrics.resamples=20", "primitives.policies=10", "primitives.episodes=4"],
        ["pipelines/study.py", "experiment=quick", "rwg.policies=20", "rwg.episodes=8", "metrics.resamples=20"],
        ["pipelines/rwg.py", "task=acrobot", "rwg.policies=64", "rwg.episodes=64"],
    ]
    for run in runs:
        done = subprocess.run([*python, *run], cwd=ROOT, env=environment, capture_output=True, text=True,
                              timeout=1800)
        assert done.returncode == 0, done.stderr[-3000:]
        assert "compiling" not in done.stdout + done.stderr, run


def test_a_finished_warm_up_of_these_sources_for_this_cpu_is_not_run_again(tmp_path, monkeypatch, capsys):
    import json

    import numba

    import taskcomplexity.commands.compilation as compilation

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    (tmp_path / "kernel.nbi").write_bytes(b"")
    stamp = {"identity": compilation.warm_up_identity(), "index_files": 1}
    compilation.stamp_path().write_text(json.dumps(stamp))
    assert compilation.stamp_path().parent == tmp_path and compilation.warmed_up()

    def refused():
        raise AssertionError("a warm-up ran")

    monkeypatch.setattr(compilation, "warm_up", refused)
    compilation.main()
    assert "nothing to do" in capsys.readouterr().out
    # another CPU target, another numba or other sources: not warmed up; nor once an index file it counted is gone
    for key, value in (("cpu", "haswell"), ("numba", "0.0"), ("sources", "0" * 64)):
        compilation.stamp_path().write_text(json.dumps({**stamp, "identity": {**stamp["identity"], key: value}}))
        assert not compilation.warmed_up(), key
    compilation.stamp_path().write_text(json.dumps(stamp))
    (tmp_path / "kernel.nbi").unlink()
    assert not compilation.warmed_up()
