"""The RWG backends: one interface, one registry, and the choice of a backend for a task and a policy family.

A backend simulates the episodes of a batch of policies. Each is declared once, in :data:`BACKENDS`, by a
:class:`Backend` record: what it can simulate, what it calls on a batch, what it promises of its returns and how
its work is split; and it is implemented by a :class:`Runner` subclass that its ``runner`` entry point names, in a
module of its own, imported only when a run needs it (as gymnasium's registry names an env's entry point):

- ``batched``: the reaching arms on the numba kernel, every episode of a chunk at once
  (:mod:`taskcomplexity.rwg.batched_backend`);
- ``kernel``: gymnasium's classic-control tasks on batched numba kernels (:mod:`taskcomplexity.rwg.kernel_backend`);
- ``envpool``: gymnasium's MuJoCo tasks and DM Control's on EnvPool's C++ thread pool
  (:mod:`taskcomplexity.rwg.envpool_backend`);
- ``vector``: a task whose id registers a vector env (``vector_entry_point``) that seeds each environment, one
  ``step`` for a chunk's environments (:mod:`taskcomplexity.rwg.vector_backend`);
- ``pybullet``: the reaching arms' PyBullet reference, one episode at a time
  (:mod:`taskcomplexity.rwg.pybullet_backend`);
- ``gym``: any task through a pool of its gymnasium envs (:mod:`taskcomplexity.rwg.gym_backend`).

Everything that depends on a backend reads its record here: ``backend=auto`` and the refusals
(:func:`resolve_backend`), the backends of a task (:func:`task_backends`) and of a policy family
(:func:`family_backends`), the chunk sizes (:meth:`Backend.chunk_size`), the worker processes (``rwg.workers``), the
memory check, the cost pilots, the replay check of a researcher's env, the RWG key and SAC's environments. No module
outside this one compares a backend's name. ``docs/how-to/add-a-backend.md`` adds one.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pkgutil import resolve_name
from typing import TYPE_CHECKING

from taskcomplexity.errors import ConfigError

if TYPE_CHECKING:
    from taskcomplexity.policies.families import FamilyBatch, FamilySpec
    from taskcomplexity.rwg.chunking import ReturnChunk
    from taskcomplexity.rwg.settings import RWGSettings
    from taskcomplexity.tasks.base import Task

AUTO = "auto"
"""``backend=auto``: the first of the task's backends that the policy family runs on."""
ENVIRONMENTS_IN_FLIGHT = 256
"""Environments a backend that keeps a bounded number in flight steps together, by default (the ``vector`` backend's
pool, the ``envpool`` backend's policies per chunk)."""
PYTHON_ENVIRONMENTS_IN_FLIGHT = 64
"""The ``gym`` backend's pool, by default: environments stepped one after another in Python, each with its own
state, stay in the core's caches at 64 (a MuJoCo point mass costs a third less CPU per step than at 256, a NumPy
env the same; the wider forward pass saves less than the cache misses cost: ``bench/bench_gym.py``)."""


@dataclass(frozen=True)
class Plan:
    """What a backend is asked for a batch: the episodes of its policies, and how to compute them.

    Attributes
    ----------
    seed : int
        Run seed: episode e of policy n starts from the reset stream (seed, n, e).
    episodes : int
        M.
    common_initial_states : bool
        Episode e of every policy starts from the same state (reset by (seed, e) only).
    contacts : {'pybullet', 'model'}
        ``rwg.contacts``, where the backend has a contact model (:attr:`Backend.contact_model`).
    precision : {'float64', 'float32'}
        ``rwg.precision``, among the backend's :attr:`Backend.precisions`.
    progress : bool
        A bar over work inside the batch (the obstacle task's hand-overs to PyBullet).
    """

    seed: int
    episodes: int
    common_initial_states: bool = False
    contacts: str = "pybullet"
    precision: str = "float64"
    progress: bool = False

    @classmethod
    def of(cls, settings: RWGSettings, progress: bool = False) -> Plan:
        """The plan of a shard's chunks under ``rwg.*`` settings."""
        return cls(settings.seed, settings.episodes, settings.common_initial_states, settings.contacts,
                   settings.precision, progress)


class Runner:
    """A backend's simulator of one task: opened once for a run (in each worker process) and handed every batch.

    A subclass implements :meth:`run`, and :meth:`close` when it holds something between batches (the ``gym``
    backend keeps its pool of environments). Use it as a context manager.

    Parameters
    ----------
    task : Task
    """

    def __init__(self, task: Task):
        self.task = task

    def run(self, policies: FamilyBatch, plan: Plan) -> ReturnChunk:
        """Every episode of every policy of the batch.

        Parameters
        ----------
        policies : FamilyBatch
            P policies of a family that runs on the backend (its batch answers the backend's ``calls``); their
            ``indices`` n choose the reset streams (seed, n, e) of their episodes.
        plan : Plan

        Returns
        -------
        ReturnChunk
            Returns (P, M) in the task's reward units, episode lengths (P, M) in environment steps, success (P, M).
        """
        raise NotImplementedError

    def close(self) -> None:
        """Release what the runner holds (nothing, unless a subclass keeps something between batches)."""

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(frozen=True)
class Backend:
    """One RWG backend's declaration: what it simulates, what it needs and what it promises.

    Attributes
    ----------
    name : str
        ``backend=<name>``.
    runner : str
        ``"module:Class"`` of its :class:`Runner`, imported when a run opens it.
    simulates : str
        ``"module:function"``: whether it can simulate a task (``function(task) -> bool``; cheap, no simulation).
    specialised : bool
        A task's own fast simulator: a task runs on the first specialised backend (in :data:`BACKENDS`' order) that
        simulates it, and on every general one that does; ``auto`` takes the first of those.
    calls : {'stepped', 'acting'}
        What it calls on a batch (:data:`taskcomplexity.policies.families.INTERFACES`): a family runs on it when its
        batch answers those calls.
    exact : bool
        Its returns are those of the task's reference episodes (gymnasium's or PyBullet's env, reset by seed), to
        the tolerance its tests state; False: another sample of the same distribution (:attr:`simulator` keys it).
    steps_at_once : bool
        It steps a chunk's P × M episodes at once, each holding its working memory: chunks are sized by
        ``rwg.chunk_memory_mb`` (at most :data:`MAX_POLICIES_AT_ONCE`), the memory check counts them, and a cost
        pilot runs a few policies at the run's M.
    chunk_policies : int or None
        Policies per chunk when it is fixed (None: from the memory budget, or from the environments in flight).
    in_flight : int
        Environments one process steps together, where the env declares no number of its own
        (:meth:`environments_in_flight`).
    parallel_from : int or None
        Environments of a batch from which it steps them with a parallel kernel on every core (a smaller batch: a
        serial kernel on one); None: one kernel at any size. ``make install``'s warm-up compiles both.
    worker_processes : bool
        Its chunks run on ``rwg.workers`` processes (0: one per usable core), each stepping Python environments on
        one core. The others run in one process (the numba kernels and EnvPool on every core, PyBullet's
        reference on one), where ``rwg.workers`` is refused.
    check : str or None
        ``"module:function"`` of the replay check of a researcher's own env (``function(task, seed)``), made before
        any return is computed, for a backend that runs the env's own code.
    simulator : str or None
        ``"module:function"``: what simulates a task beyond the task's identity (``function() -> str``), hashed into
        the RWG key (EnvPool's version: its own MuJoCo build and reset generator).
    precisions : tuple of str
        The forward-pass arithmetics it computes in (``rwg.precision``).
    contact_model : bool
        ``rwg.contacts`` applies: the obstacle task's contacts can come from the batched contact model.
    sac_env : str or None
        ``"module:Class"`` of a gymnasium vector env that steps SAC's environments (``sac.backend=<name>``):
        ``Class(task, num_envs, goal_conditioned=…)``; None: SAC does not run on it.
    sac_simulates : str or None
        ``"module:function"``: the tasks whose SAC environments :attr:`sac_env` steps (others keep their own env).
    """

    name: str
    runner: str
    simulates: str
    specialised: bool
    calls: str
    exact: bool = True
    steps_at_once: bool = False
    chunk_policies: int | None = None
    worker_processes: bool = False
    check: str | None = None
    simulator: str | None = None
    precisions: tuple[str, ...] = ("float64",)
    contact_model: bool = False
    sac_env: str | None = None
    sac_simulates: str | None = None
    in_flight: int = ENVIRONMENTS_IN_FLIGHT
    parallel_from: int | None = None

    def open(self, task: Task) -> Runner:
        """The backend's runner for ``task`` (close it when done, or use it as a context manager)."""
        return resolve_name(self.runner)(task)

    def can_simulate(self, task: Task) -> bool:
        return bool(resolve_name(self.simulates)(task))

    def environments_in_flight(self, task: Task) -> int:
        """The environments this backend steps together for ``task``: the env class's ``environments_in_flight``
        when it declares one (an env that is slow to build and to step gains nothing from a wider forward pass, e.g.
        Meta-World's), else :attr:`in_flight`. Only the speed depends on it, never the returns."""
        return int(getattr(task, "environments_in_flight", None) or self.in_flight)

    def key_fields(self) -> dict:
        """What the backend adds to the RWG key beyond its name (its :attr:`simulator`)."""
        return {} if self.simulator is None else {"simulator": resolve_name(self.simulator)()}

    def chunk_size(self, task: Task, network: FamilySpec, settings: RWGSettings) -> int:
        """Policies per chunk: ``rwg.chunk_policies``, else what the backend runs well together."""
        if settings.chunk_policies:
            return settings.chunk_policies
        if self.chunk_policies is not None:
            return self.chunk_policies
        if self.steps_at_once:  # as many as rwg.chunk_memory_mb holds (float64 working memory)
            per_env = 8 * network.working_floats(task.observation_size, task.action_size, task.max_steps)
            envs = settings.chunk_memory_mb * 2**20 // per_env
            return max(1, min(envs // settings.episodes, MAX_POLICIES_AT_ONCE))
        in_flight = self.environments_in_flight(task)  # each policy's episodes W at a time, the pool full
        return max(1, in_flight // min(settings.episodes, in_flight))


MAX_POLICIES_AT_ONCE = 2048
"""The most policies of a chunk on a backend that steps a chunk's episodes at once."""

_RWG = "taskcomplexity.rwg"

BACKENDS: dict[str, Backend] = {b.name: b for b in (
    Backend("batched", f"{_RWG}.batched_backend:BatchedRunner", f"{_RWG}.backends:reaching_arm", specialised=True,
            calls="stepped", steps_at_once=True, precisions=("float64", "float32"), contact_model=True,
            sac_env="taskcomplexity.tasks.batched_vector:BatchedReachingVector",
            sac_simulates=f"{_RWG}.backends:contact_free_arm"),
    Backend("kernel", f"{_RWG}.kernel_backend:KernelRunner", f"{_RWG}.backends:classic_kernel", specialised=True,
            calls="acting", steps_at_once=True, parallel_from=4096),
    Backend("envpool", f"{_RWG}.envpool_backend:EnvPoolRunner", f"{_RWG}.backends:on_envpool", specialised=True,
            calls="acting", exact=False, chunk_policies=ENVIRONMENTS_IN_FLIGHT,
            simulator=f"{_RWG}.envpool_backend:simulator"),
    Backend("vector", f"{_RWG}.vector_backend:VectorRunner", f"{_RWG}.backends:seeds_each_environment",
            specialised=True, calls="acting", worker_processes=True, check=f"{_RWG}.env_checks:check_vector_env"),
    Backend("pybullet", f"{_RWG}.pybullet_backend:PyBulletRunner", f"{_RWG}.backends:reaching_arm",
            specialised=False, calls="stepped", chunk_policies=16),
    Backend("gym", f"{_RWG}.gym_backend:GymRunner", f"{_RWG}.backends:any_task", specialised=False, calls="acting",
            in_flight=PYTHON_ENVIRONMENTS_IN_FLIGHT,
            worker_processes=True, check=f"{_RWG}.env_checks:check_env"),
)}
"""Every RWG backend by name, in the order ``auto`` prefers them: the one place a backend is declared."""


# -- what each backend simulates (cheap: no environment is stepped) ---------------------------------------------------
def reaching_arm(task: Task) -> bool:
    """The paper's reaching arms (:class:`taskcomplexity.tasks.spec.TaskSpec`)."""
    from taskcomplexity.tasks.spec import TaskSpec

    return isinstance(task, TaskSpec)


def contact_free_arm(task: Task) -> bool:
    """A reaching arm without the obstacle (its contacts need PyBullet's solver)."""
    return reaching_arm(task) and task.arm.obstacle is None


def classic_kernel(task: Task) -> bool:
    """A gymnasium id, with its constructor arguments, that has a batched classic-control kernel."""
    from taskcomplexity.tasks.classic import kernel_for

    return not reaching_arm(task) and kernel_for(task.env_id, getattr(task, "kwargs", {})) is not None


def on_envpool(task: Task) -> bool:
    """A gymnasium MuJoCo id or a DM Control one (through Shimmy) that EnvPool reimplements, with no arguments."""
    from taskcomplexity.tasks.envpool_ids import envpool_id

    return not reaching_arm(task) and envpool_id(task) is not None


def seeds_each_environment(task: Task) -> bool:
    """A gymnasium id whose vector env (``vector_entry_point``) seeds each of its environments from its own seed."""
    from taskcomplexity.tasks.vectorised import seeds_each

    return not reaching_arm(task) and seeds_each(task)


def any_task(task: Task) -> bool:
    """Every task: each has a gymnasium env (``task.make_env()``)."""
    return True


# -- the choice of a backend ------------------------------------------------------------------------------------------
def backend(name: str) -> Backend:
    """The declaration of the backend ``name`` (resolved: not ``auto``)."""
    return BACKENDS[name]


def task_backends(task: Task) -> tuple[str, ...]:
    """The backends that can simulate ``task``, the first the fastest: the first specialised one that simulates
    it, then every general one that does."""
    special = next((b.name for b in BACKENDS.values() if b.specialised and b.can_simulate(task)), None)
    general = [b.name for b in BACKENDS.values() if not b.specialised and b.can_simulate(task)]
    return tuple([special] if special else []) + tuple(general)


@functools.cache
def _family_backends(spec: type) -> tuple[str, ...]:
    from typing import get_type_hints

    from taskcomplexity.policies.families import missing_calls

    batch = get_type_hints(spec.sample).get("return")
    if not isinstance(batch, type):
        raise TypeError(f"{spec.__module__}.{spec.__qualname__}.sample must be annotated with the class of the batch "
                        f"it returns (the backends a family runs on follow from that class's calls), got {batch!r}")
    return tuple(b.name for b in BACKENDS.values() if not missing_calls(batch, b.calls))


def family_backends(network: FamilySpec | type) -> tuple[str, ...]:
    """The backends a policy family runs on: those whose calls its batch answers (the class its ``sample``
    returns, :func:`taskcomplexity.policies.families.missing_calls`)."""
    return _family_backends(network if isinstance(network, type) else type(network))


def resolve_backend(task: Task, name: str, network: FamilySpec | None = None) -> str:
    """The backend that runs ``task`` with ``network``'s family; refuse one that cannot.

    Parameters
    ----------
    task : Task
    name : str
        ``auto`` (the task's fastest backend among those the family runs on) or one of :data:`BACKENDS`.
    network : FamilySpec, optional
        The policy family; None: any backend of the task.

    Raises
    ------
    ConfigError
        One line naming the backend, and, when the family is what refuses it, ``network.family``, its value
        and the backends it runs on.
    """
    simulates = task_backends(task)
    runs = simulates if network is None else tuple(b for b in simulates if b in family_backends(network))
    if network is not None and not runs:
        raise ConfigError(_refusal(task, name, network, runs))
    if name != AUTO and name not in simulates:
        raise ConfigError(f"backend={name} is not available for task {task.task_id}"
                          + (f" with network.family={network.family}" if runs != simulates else "")
                          + f" (allowed: {', '.join([AUTO, *runs])})")
    if network is not None and name not in (AUTO, *runs):
        raise ConfigError(_refusal(task, name, network, runs))
    return runs[0] if name == AUTO else name


def _refusal(task: Task, name: str, network: FamilySpec, runs: tuple[str, ...]) -> str:
    """The one-line refusal of a backend (or of every backend of ``task``) the family does not run on."""
    why = (f"network.family={network.family} cannot run on backend={name} for task {task.task_id}: the family "
           f"runs on {', '.join(family_backends(network))}")
    if runs:
        return f"{why} (allowed: {', '.join([AUTO, *runs])})"
    return f"{why}, the task on {', '.join(task_backends(task))} (allowed: another network.family)"


def refuse_workers(workers: int, backends: list[str], where: str) -> None:
    """Refuse ``rwg.workers`` set where none of ``backends`` (the resolved backends of a run's tasks) runs its chunks
    on worker processes: it would change nothing."""
    if workers and not any(BACKENDS[b].worker_processes for b in backends):
        on_workers = [b.name for b in BACKENDS.values() if b.worker_processes]
        used = list(dict.fromkeys(backends))
        raise ConfigError(f"rwg.workers={workers} sets the processes that step Python environments on backend "
                          f"{' or '.join(on_workers)}; {where} runs on {', '.join(used)}, in one "
                          f"process (allowed: 0)")


def sac_backends() -> tuple[str, ...]:
    """The backends that can step SAC's environments (``sac.backend``) in place of each task's own env."""
    return tuple(b.name for b in BACKENDS.values() if b.sac_env is not None)


def sac_env(task: Task, name: str) -> Backend | None:
    """The backend that steps ``task``'s SAC environments under ``sac.backend=<name>``: that backend where it steps
    SAC's environments of the task, None where the task keeps its own env."""
    chosen = BACKENDS.get(name)
    if chosen is None or chosen.sac_env is None or not resolve_name(chosen.sac_simulates or chosen.simulates)(task):
        return None
    return chosen

