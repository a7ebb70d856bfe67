"""The RWG backends and the choice of one for a task and a policy family.

- ``batched``: the reaching arms on the numba kernel, every episode of a chunk at once
  (:mod:`taskcomplexity.rwg.batched_backend`);
- ``pybullet``: the reaching arms' PyBullet reference, one episode at a time
  (:mod:`taskcomplexity.rwg.pybullet_backend`);
- ``gym``: any task through a pool of its gymnasium envs (:mod:`taskcomplexity.rwg.gym_backend`);
- ``kernel``: gymnasium's classic-control tasks on batched numba kernels (:mod:`taskcomplexity.rwg.kernel_backend`);
- ``envpool``: gymnasium's MuJoCo tasks and DM Control's on EnvPool's C++ thread pool
  (:mod:`taskcomplexity.rwg.envpool_backend`);
- ``vector``: a task whose id registers a vector env (``vector_entry_point``) that seeds each environment, one
  ``step`` for a chunk's environments (:mod:`taskcomplexity.rwg.vector_backend`).

A task lists those it can run (``task.backends``, fastest exact one first), a policy family those whose calls
its batches answer (``network.backends``, :data:`taskcomplexity.policies.families.BACKEND_CALLS`). A run uses a
backend both list, and any other choice is refused before any work, in one line.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from taskcomplexity.errors import ConfigError

if TYPE_CHECKING:
    from taskcomplexity.policies.families import FamilySpec
    from taskcomplexity.tasks.base import Task

BACKENDS = ("batched", "pybullet", "gym", "kernel", "envpool", "vector")
"""Every RWG backend; a task lists those it supports in ``task.backends`` (fastest exact one first)."""
AUTO = "auto"
"""``backend=auto``: the task's first backend (that the policy family runs on)."""


def resolve_backend(task: Task, backend: str, network: FamilySpec | None = None) -> str:
    """The backend that runs ``task`` with ``network``'s family; refuse one that cannot.

    Parameters
    ----------
    task : Task
    backend : str
        ``auto`` (the task's fastest exact backend among those the family runs on) or one of :data:`BACKENDS`.
    network : FamilySpec, optional
        The policy family; None: any backend of the task.

    Raises
    ------
    ConfigError
        One line naming the backend, and, when the family is what refuses it, ``network.family``, its value
        and the backends it runs on.
    """
    runs = tuple(task.backends if network is None else (b for b in task.backends if b in network.backends))
    if network is not None and not runs:
        raise ConfigError(_refusal(task, backend, network, runs))
    if backend != AUTO and backend not in task.backends:
        raise ConfigError(f"backend={backend} is not available for task {task.task_id}"
                          + (f" with network.family={network.family}" if runs != tuple(task.backends) else "")
                          + f" (allowed: {', '.join([AUTO, *runs])})")
    if network is not None and backend not in (AUTO, *runs):
        raise ConfigError(_refusal(task, backend, network, runs))
    return runs[0] if backend == AUTO else backend


def _refusal(task: Task, backend: str, network: FamilySpec, runs: tuple[str, ...]) -> str:
    """The one-line refusal of a backend (or of every backend of ``task``) the family does not run on."""
    why = (f"network.family={network.family} cannot run on backend={backend} for task {task.task_id}: the family "
           f"runs on {', '.join(network.backends)}")
    if runs:
        return f"{why} (allowed: {', '.join([AUTO, *runs])})"
    return f"{why}, the task on {', '.join(task.backends)} (allowed: another network.family)"
