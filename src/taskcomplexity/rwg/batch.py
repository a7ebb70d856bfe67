"""One batch of policies on one backend: :func:`run_batch`, the one call every backend answers, and a chunk of a
shard's policies sampled from their family and run (:func:`simulate_chunk`).

:mod:`taskcomplexity.rwg.run` runs a shard's chunks through :func:`simulate_chunk`, in this process or on worker
processes (:mod:`taskcomplexity.rwg.workers`), which import it from here: neither imports the other.
"""

from __future__ import annotations

import contextlib

import numpy as np

from taskcomplexity.policies.families import INTERFACES, FamilyBatch, FamilySpec, missing_calls, sample_family
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.rwg.backends import BACKENDS, Plan, Runner, resolve_backend
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.tasks.base import Task


def run_batch(task: Task, policies: FamilyBatch, backend: str, plan: Plan,
              runner: Runner | None = None) -> ReturnChunk:
    """Every episode of every policy of ``policies`` on ``backend`` (resolved: not ``auto``).

    Parameters
    ----------
    task : Task
    policies : FamilyBatch
        P policies; their ``indices`` n choose the reset streams (seed, n, e) of their episodes. They answer the
        backend's calls (:attr:`taskcomplexity.rwg.backends.Backend.calls`).
    backend : str
        One of :data:`taskcomplexity.rwg.backends.BACKENDS`.
    plan : Plan
        The episodes (seed, M, common initial states) and how to compute them.
    runner : Runner, optional
        The backend's runner for ``task``, opened by the caller to serve many batches (made here, and closed, when
        None).

    Returns
    -------
    ReturnChunk
        Returns (P, M), in the task's reward units, steps and success.
    """
    declared = BACKENDS[backend]
    missing = missing_calls(policies, declared.calls)
    if missing:  # a family's batch that lacks the backend's calls: refused before the episodes
        interface = INTERFACES[declared.calls]
        raise TypeError(f"backend={backend} cannot run a {type(policies).__name__}: it lacks {', '.join(missing)} "
                        f"(the backend's calls: {interface.__module__}.{interface.__name__})")
    with contextlib.nullcontext(runner) if runner is not None else declared.open(task) as opened:
        return opened.run(policies, plan)


def simulate_chunk(
    task: Task,
    network: FamilySpec,
    prior: PriorSpec,
    settings: RWGSettings,
    start: int,
    stop: int,
    backend: str = "auto",
    *,
    progress: bool = False,
    runner: Runner | None = None,
) -> ReturnChunk:
    """Run every episode of policies ``start … stop−1`` (``progress``: a bar inside the batch, e.g. over the
    obstacle task's hand-overs to PyBullet). ``runner`` is the backend's runner, shared by a run's chunks (made
    here, and closed, when None)."""
    backend = resolve_backend(task, backend, network)
    policies = sample_family(task, network, prior, settings.seed, np.arange(start, stop))
    return run_batch(task, policies, backend, Plan.of(settings, progress), runner)
