"""Every stage declares the modules that compute its numbers, and the declarations cover what the stages run.

A stage's reach is the ``taskcomplexity`` modules its module imports at any depth (imports inside functions
too), not walking into the other stage modules: those stages' numbers reach it through their keys, held in
its own. The backends' registry (``rwg.backends``) names its backends' modules as entry points, imported when a run
opens one: a stage that declares the one call every backend answers (``rwg.batch``: the RWG stage and those that run
its episodes) reaches them too; another (SAC, which reads the registry for ``sac.backend``) its declarations only. Every module of the reach is declared by the stage, declared by a stage it reads by key, or listed
below as glue that computes no number. A module that enters a stage's reach must be placed: in the stage's
declaration (its numbers need a version bump when they change) or in ``GLUE``.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import importlib.util
from pathlib import Path

import pytest

import taskcomplexity
from taskcomplexity.stages.keys import PACKAGE, Numerics
from taskcomplexity.study.chain import CHAIN

STAGES_DIR = Path(taskcomplexity.__file__).parent / "stages"
STAGES = sorted(p.stem.removesuffix("_stage") for p in STAGES_DIR.glob("*_stage.py"))

GLUE = frozenset({
    "taskcomplexity", "tasks", "metrics", "rl", "verdict", "policies",  # packages that re-export
    "config", "cores", "errors", "extras", "jobs", "processes", "post_import", "progress", "policies.families", "study_data", "tasks.quiet", "tasks.registration",
    "rwg.workers",  # where the gym backend's chunks run: each chunk's returns are those of one process
    "rwg.env_checks", "metrics._validation", "rl.checkpoint", "rl.collectors", "rl.curves", "stages.cache", "stages.keys", "stages.resources",
    "stages.stage_log", "stages.actor_stages",
    "stages", "stages.stage", "stages.declared", "stages.task_artefacts",  # the stages' records and their loops
})
"""Modules in a stage's reach that compute none of its numbers: configuration and validation, logging and
progress, the cache and the up-front resource checks, the jobs' provenance records, the machine's cores and the worker processes, checkpoint files, the gymnasium registration and the post-import hook that runs it, the pip command of an optional extra, the studies' data, the stages' records
(the verdict reads which stages it judges from them)."""

INPUTS = {stage.name: stage.inputs for stage in CHAIN}
"""The stages whose keys (or, for the verdict's SAC input, whose content hash) a stage's key holds: each stage's
record declares them (:attr:`taskcomplexity.stages.stage.Stage.inputs`)."""


def _numerics(stage: str) -> Numerics:
    return importlib.import_module(f"{PACKAGE}.stages.{stage}_stage").NUMERICS


def _source(module: str) -> Path:
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.origin and spec.origin.endswith(".py"), module
    return Path(spec.origin)


def _imports(node: ast.AST, module: str, path: Path) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for _ in range(node.level - 1):
            package = package.rpartition(".")[0]
        base = f"{package}.{node.module}" if node.module else package
    else:
        base = node.module or ""
    # ``from package import module`` names a module; ``from module import name`` a name in it
    return [base, *(f"{base}.{alias.name}" for alias in node.names)]


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


REGISTRY = f"{PACKAGE}.rwg.backends"


def _entry_modules() -> list[str]:
    """The modules the backends' registry names as entry points of RWG's episodes ("module:object"; SAC's vector envs
    are SAC's, declared by it)."""
    from taskcomplexity.rwg.backends import BACKENDS

    entries = [getattr(b, f.name) for b in BACKENDS.values() for f in dataclasses.fields(b)
               if not f.name.startswith("sac_")]
    return [e.partition(":")[0] for e in entries if isinstance(e, str) and ":" in e]


def reach(stage: str) -> set[str]:
    """The package modules (without the package prefix) that ``stage``'s module imports, at any depth,
    not walking into the other stage modules."""
    start = f"{PACKAGE}.stages.{stage}_stage"
    runs_backends = "rwg.batch" in _numerics(stage).modules
    seen, todo = set(), [start]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        if name.endswith("_stage") and name != start:
            continue
        if name == REGISTRY:
            if not runs_backends:
                continue
            todo.extend(_entry_modules())
        path = _source(name)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            for imported in _imports(node, name, path):
                if imported.split(".")[0] == PACKAGE and imported not in seen and _is_module(imported):
                    todo.append(imported)
    return {n.removeprefix(f"{PACKAGE}.") if n != PACKAGE else n for n in seen
            if not (n.endswith("_stage") and n != start)}


def test_every_stage_module_declares_its_numerics_and_every_declared_module_exists():
    assert set(STAGES) == set(INPUTS), "a stage module without a RECORD, or a record without a module"
    for stage in STAGES:
        numerics = _numerics(stage)
        assert isinstance(numerics, Numerics), stage
        assert f"stages.{stage}_stage" in numerics.modules, f"{stage}: its own module computes its artefact"
        assert {s.name: s for s in CHAIN}[stage].numerics is numerics, f"{stage}: its record holds its module's numerics"
        for module in numerics.qualified():
            importlib.import_module(module)  # raises for a module that moved or is gone


@pytest.mark.parametrize("stage", STAGES)
def test_a_stages_declaration_covers_every_module_it_runs(stage):
    allowed = set(_numerics(stage).modules) | GLUE
    for source in INPUTS[stage]:
        allowed |= set(_numerics(source).modules)
    undeclared = sorted(reach(stage) - allowed)
    assert not undeclared, (f"stage {stage} runs {undeclared}, declared by no stage it reads and not glue: add "
                            f"them to NUMERICS in stages/{stage}_stage.py or to GLUE in {Path(__file__).name}")


def test_the_walk_sees_imports_inside_functions_and_stops_at_other_stages():
    rwg = reach("rwg")
    # the physics kernel is imported by a function of the RWG runner, three imports away
    assert {"tasks.dynamics", "tasks.step_kernel", "policies.mlp", "seeding", "rwg.gym_backend"} <= rwg
    assert not any(m.startswith(("report", "rl")) for m in rwg)
    assert "rl.train" in reach("sac") and "rwg.backends" in reach("sac") and "rwg.gym_backend" not in reach("sac")
    from taskcomplexity.rwg.backends import BACKENDS  # sac.backend=batched: the kernel's vector env, declared by SAC

    assert {b.sac_env.partition(":")[0].removeprefix(f"{PACKAGE}.") for b in BACKENDS.values() if b.sac_env} \
        <= set(_numerics("sac").modules)
    assert not any(m.startswith(("report", "metrics")) for m in reach("sac"))
    metrics = reach("metrics")  # it reads the returns through the RWG stage's module, not the physics
    assert "metrics.pic" in metrics and "tasks.dynamics" not in metrics


def test_glue_is_no_stages_numerics_and_exists():
    for module in GLUE:
        assert _is_module(module if module == PACKAGE else f"{PACKAGE}.{module}"), module
        assert not [s for s in STAGES if module in _numerics(s).modules], f"{module} is declared and glue"


def _compiled(path: Path) -> bool:
    """Whether a module defines a numba-compiled function (``@njit``, ``@numba.njit(...)``, ``@jit``)."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        for decorator in getattr(node, "decorator_list", ()):
            target = decorator.func if isinstance(decorator, ast.Call) else decorator
            name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
            if name in ("njit", "jit", "vectorize", "guvectorize"):
                return True
    return False


def test_every_numba_kernel_and_metric_estimator_is_declared_by_a_stage():
    root = Path(taskcomplexity.__file__).parent
    declared = set().union(*(_numerics(s).modules for s in STAGES))
    kernels = {".".join(p.relative_to(root).with_suffix("").parts) for p in root.rglob("*.py") if _compiled(p)}
    assert {"tasks.step_kernel", "tasks.rollout_kernel", "tasks.dynamics", "metrics.histogram"} <= kernels
    assert not kernels - declared, f"numba kernels no stage declares: {sorted(kernels - declared)}"
    estimators = {f"metrics.{p.stem}" for p in (root / "metrics").glob("[!_]*.py")}
    assert not estimators - declared, f"metric modules no stage declares: {sorted(estimators - declared)}"


def test_the_metrics_estimators_are_read_from_the_registry():
    """The metrics stage declares the module of every registry metric's function and the estimator modules they
    import (``ESTIMATORS``), so a metric in a module of its own needs no second list."""
    from taskcomplexity.metrics import policy_tables
    from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Metric
    from taskcomplexity.stages.metrics_stage import ESTIMATORS, estimator_modules

    assert estimator_modules(DEFAULT_REGISTRY) == ESTIMATORS == tuple(sorted(ESTIMATORS))
    functions = {f.__module__ for m in DEFAULT_REGISTRY for f in (m.compute, m.draws) if f is not None}
    assert {name.removeprefix(f"{PACKAGE}.") for name in functions} <= set(ESTIMATORS)
    # the Sample the functions read and the estimators it imports; not the private input checks
    assert {"metrics.sample", "metrics.evaluate", "metrics.pic", "metrics.poic", "metrics.histogram",
            "metrics.log_mean_exp", "metrics.knn"} <= set(ESTIMATORS)
    assert not [m for m in ESTIMATORS if m.rpartition(".")[2].startswith("_")]
    # a metric whose function lives in a module of its own brings that module, and what it imports
    own = Metric("toy", "toy", "toy", "", True, "x", "metrics", compute=policy_tables.policy_sample_tables)
    assert "metrics.policy_tables" not in ESTIMATORS
    assert set(estimator_modules(DEFAULT_REGISTRY.with_metrics(own))) == {*ESTIMATORS, "metrics.policy_tables"}
