"""taskcomplexity: how hard is this task, and can we trust the metric that says so?

Importing the package registers the reaching task of every arm preset (``conf/arm/``) with each reward
it allows with gymnasium, e.g. ``gymnasium.make("taskcomplexity/TwoLink-Sparse-v0")``: at once when gymnasium is
imported already, else as soon as it is (:mod:`taskcomplexity.post_import`). Importing the package imports neither
gymnasium nor any other heavy library: each module loads its libraries when it needs them.

Data flows one way: config → task → returns → metrics → verdict → report; SAC's curves join at the verdict.

Modules
-------
cli
    The command line's glue: what is typed, checked before Hydra parses it; exit codes.
commands
    The entry points: one Hydra app per stage, plus ``study`` for the whole chain.
config
    From Hydra/OmegaConf configuration to the library's plain dataclasses.
cores
    The CPUs this process may run on (how many workers "one per core" is; within a SLURM job, its allocation).
errors
    Exceptions the library raises; entry points turn them into one readable line and a non-zero exit.
extras
    The optional extras and the pip command that installs one (the end of the line refusing a task without it).
jobs
    Which job computed an artefact (scheduler, job id, node, CPU): the manifests' ``jobs`` records.
metrics
    The estimators on a return matrix (statistics, PIC, POIC, bootstrap, Welch, diagnostics) and their registry.
policies
    The random policy families (MLPs and movement primitives) and their weight priors.
post_import
    Post-import hooks: a function called once a module is imported, without importing it.
processes
    Worker processes that end with their run: started, quieted and stopped in one place.
progress
    Progress bars: one per stage of a study, which the work inside the stage advances.
report
    The report of a study, read from artefacts only.
rl
    Soft Actor-Critic (+ HER) with TorchRL: the empirical difficulty of a task.
rwg
    Random Weight Guessing (Algorithm 1): N random policies × M episodes → the return matrix.
seeding
    The random streams that make RWG a pure function of (task, network, prior, N, M, seed).
stages
    One declared record per stage, the cache keys and the content-addressed cache.
study
    A study run from its configuration: its plan, its chain of stages, then its report.
study_data
    A study as data: its tasks, their known relations, orders, reference scores and budgets.
tasks
    The Task seam, the reaching arms, classic-control kernels and any gymnasium id.
verdict
    The study's known relations × the registry's metrics → outcomes, with the information check.
"""

from typing import TYPE_CHECKING

from taskcomplexity.post_import import when_imported

if TYPE_CHECKING:
    from taskcomplexity.tasks.registration import gym_ids
    from taskcomplexity.tasks.spec import make_task, preset_tasks, task_from_id

__version__ = "0.1.0"

_EXPORTS = {"gym_ids": "tasks.registration", "make_task": "tasks.spec", "preset_tasks": "tasks.spec",
            "task_from_id": "tasks.spec"}
"""The names the package exports → their modules, imported on first use (PEP 562)."""


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def _register(gymnasium) -> None:
    from taskcomplexity.tasks.registration import register_tasks

    register_tasks()


when_imported("gymnasium", _register)

__all__ = ["__version__", "gym_ids", "make_task", "preset_tasks", "task_from_id"]
