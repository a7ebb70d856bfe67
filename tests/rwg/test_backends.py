"""The backends' registry (``taskcomplexity.rwg.backends``): every declaration resolves and is what it says, the choice
of a backend for a task and a family follows from the declarations, and no module outside the registry compares a
backend's name (so a new backend is its module and its declaration: docs/how-to/add-a-backend.md)."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path
from pkgutil import resolve_name

import pytest

from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.families import FAMILIES, INTERFACES, missing_calls
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.rwg import RWGSettings, run_rwg
from taskcomplexity.rwg.backends import (
    AUTO,
    BACKENDS,
    Runner,
    family_backends,
    refuse_workers,
    resolve_backend,
    sac_backends,
    task_backends,
)
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task

SOURCE = Path(__file__).resolve().parents[2] / "src" / "taskcomplexity"
REGISTRY = SOURCE / "rwg" / "backends.py"


@pytest.mark.parametrize("name", list(BACKENDS))
def test_each_declaration_resolves_to_what_it_declares(name):
    declared = BACKENDS[name]
    assert declared.name == name and name != AUTO
    runner = resolve_name(declared.runner)
    assert inspect.isclass(runner) and issubclass(runner, Runner) and runner.run is not Runner.run
    assert callable(resolve_name(declared.simulates))
    assert declared.calls in INTERFACES
    assert "float64" in declared.precisions
    for entry in (declared.check, declared.simulator, declared.sac_env, declared.sac_simulates):
        assert entry is None or callable(resolve_name(entry)), entry
    assert (declared.sac_env is None) == (declared.sac_simulates is None) or declared.sac_simulates is None
    assert declared.chunk_policies is None or declared.chunk_policies >= 1
    assert not (declared.steps_at_once and declared.chunk_policies), "a chunk is sized one way"


@pytest.mark.parametrize("name", list(BACKENDS))
def test_each_backend_runs_rwg_on_a_task_it_simulates_when_its_libraries_are_installed(name):
    """Three policies × two episodes on the first of a few tasks the backend simulates: finite returns, each
    episode at least one step, the policies in order."""
    candidates = ["CartPole-v1", "Pendulum-v1", "Hopper-v5", "vector_pendulum:VectorPendulum-v0"]
    def tasks():
        yield make_task("one_link_1m0", "dense")
        for env_id in candidates:
            try:
                yield GymTask(env_id)
            except ConfigError:  # its extra (MuJoCo) is not installed
                continue

    task = next((t for t in tasks() if name in task_backends(t)), None)
    if task is None:
        pytest.skip(f"no test task runs on {name} here (its extra is not installed)")
    chunk = run_rwg(task, NetworkSpec(), PriorSpec(), RWGSettings(policies=3, episodes=2, seed=2), name)
    assert chunk.returns.shape == (3, 2) and list(chunk.policy) == [0, 1, 2]
    assert (chunk.steps >= 1).all() and chunk.returns.dtype.kind == "f"


def _compared_names(path: Path, root: Path = SOURCE.parent) -> list[str]:
    """``file:line name`` of each comparison in ``path`` (==, !=, in, not in) of a backend (a name or attribute
    called ``…backend…``) with a backend's name as a literal (``task.kind == "gym"`` is another "gym")."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Compare):
            continue
        named = [n.id if isinstance(n, ast.Name) else n.attr for n in ast.walk(node)
                 if isinstance(n, ast.Name | ast.Attribute)]
        if not any("backend" in name.lower() for name in named):
            continue
        for operand in (node.left, *node.comparators):
            literals = operand.elts if isinstance(operand, ast.Tuple | ast.List | ast.Set) else [operand]
            for literal in literals:
                if isinstance(literal, ast.Constant) and literal.value in BACKENDS:
                    found.append(f"{path.relative_to(root)}:{node.lineno} {literal.value}")
    return found


def test_no_module_outside_the_registry_compares_a_backends_name():
    """What depends on a backend reads its declaration (``BACKENDS[name].<field>``), not its name."""
    compared = [hit for path in sorted(SOURCE.rglob("*.py")) if path != REGISTRY for hit in _compared_names(path)]
    assert compared == []


def test_the_name_check_finds_each_kind_of_comparison(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('def f(backend, task):\n    return (backend == "gym" or settings.backend in ("kernel", "x")\n'
                     '            or "envpool" != backend or backend not in ["auto"] or task.kind == "gym")\n',
                     encoding="utf-8")
    assert _compared_names(probe, tmp_path) == ["probe.py:2 gym", "probe.py:2 kernel", "probe.py:3 envpool"]


def test_a_familys_backends_follow_from_its_batch():
    assert family_backends(NetworkSpec) == tuple(BACKENDS)  # an MLP batch both steps and acts
    for spec in FAMILIES.values():
        batch = inspect.get_annotations(spec.sample, eval_str=True)["return"]
        assert family_backends(spec) == tuple(n for n, b in BACKENDS.items() if not missing_calls(batch, b.calls))


def test_auto_takes_the_first_specialised_backend_then_the_general_ones():
    specialised = [n for n, b in BACKENDS.items() if b.specialised]
    for task in (GymTask("CartPole-v1"), GymTask("Acrobot-v1")):
        names = task_backends(task)
        assert sum(n in specialised for n in names) <= 1 and "gym" in names
        assert not any(BACKENDS[n].specialised for n in names[1:])  # the specialised one, if any, first
        assert resolve_backend(task, AUTO, NetworkSpec()) == names[0]


def test_rwg_workers_is_refused_in_one_line_where_no_backend_runs_on_workers():
    refuse_workers(0, ["kernel"], "task Pendulum-v1")  # the default: one per core where it applies
    refuse_workers(2, ["kernel", "gym"], "study mine")  # applies to the gym task
    with pytest.raises(ConfigError) as refused:
        refuse_workers(2, ["kernel", "envpool"], "study mine")
    on_workers = " or ".join(n for n, b in BACKENDS.items() if b.worker_processes)
    assert str(refused.value) == (f"rwg.workers=2 sets the processes that step Python environments on backend "
                                  f"{on_workers}; study mine runs on kernel, envpool, in one process (allowed: 0)")


def test_sac_steps_its_environments_on_the_backends_that_declare_a_vector_env():
    assert sac_backends() == tuple(n for n, b in BACKENDS.items() if b.sac_env is not None)
    for name in sac_backends():
        assert resolve_name(BACKENDS[name].sac_simulates or BACKENDS[name].simulates)
