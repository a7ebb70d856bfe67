"""RWG's episodes for policies that are given, not drawn from a prior (e.g. perturbed SAC actors).

:func:`~taskcomplexity.rwg.batch.simulate_chunk` draws policies ``start … stop−1`` from (network, prior);
:func:`run_policies` runs a given :class:`~taskcomplexity.policies.mlp.PolicyBatch` through the same dispatch
(:func:`~taskcomplexity.rwg.batch.run_batch`), with the same reset states for (seed, policy index n, episode e).
"""

from __future__ import annotations

from threadpoolctl import threadpool_limits

from taskcomplexity.policies.mlp import PolicyBatch
from taskcomplexity.rwg.backends import Plan, resolve_backend
from taskcomplexity.rwg.batch import run_batch
from taskcomplexity.rwg.chunking import ReturnChunk
from taskcomplexity.tasks.base import Task


def run_policies(task: Task, policies: PolicyBatch, *, seed: int, episodes: int, backend: str = "auto",
                 common_initial_states: bool = False, contacts: str = "pybullet") -> ReturnChunk:
    """Every episode of every policy of ``policies`` (returns (P, M), steps, success).

    Parameters
    ----------
    task : Task
    policies : PolicyBatch
        Their ``indices`` choose the reset streams (seed, n, e) of their episodes.
    seed : int
        Run seed of the reset states.
    episodes : int
        M.
    backend : str
        As ``backend=`` of RWG (``auto``: the task's fastest exact backend).
    common_initial_states : bool
        Episode e of every policy starts from the same state.
    contacts : {'pybullet', 'model'}
        The obstacle task's contact handling on the batched backend.
    """
    backend = resolve_backend(task, backend)
    with threadpool_limits(limits=1, user_api="blas"):  # as run_rwg: BLAS threads would spin against the workers
        return run_batch(task, policies, backend, Plan(seed, episodes, common_initial_states, contacts))
