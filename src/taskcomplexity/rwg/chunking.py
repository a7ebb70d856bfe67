"""How a shard's policies are split into chunks, and the returns of a chunk.

A chunk is a range of policies whose episodes run together (one sampled batch); it is also the unit an
interrupted run resumes from. The returns do not depend on the split: policy n's weights and episode e's
initial state come from streams keyed by (seed, n) and (seed, n, e).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from taskcomplexity.rwg.backends import BACKENDS

if TYPE_CHECKING:
    from taskcomplexity.policies.families import FamilySpec
    from taskcomplexity.rwg.settings import RWGSettings
    from taskcomplexity.tasks.base import Task


@dataclass
class ReturnChunk:
    """Results of a range of policies.

    Attributes
    ----------
    policy : ndarray (P,) int
        Policy indices n.
    returns : ndarray (P, M) float64
        Undiscounted episode returns.
    steps : ndarray (P, M) int
        Episode lengths (environment steps).
    success : ndarray (P, M) bool
        Whether the episode reached d < threshold.
    handoffs : int
        Episodes finished on the PyBullet reference after reaching the block (batched backend,
        ``contacts='pybullet'``).
    contacts : int
        Episodes in which the modelled block acted on the arm (batched backend, ``contacts='model'``).
    """

    policy: np.ndarray
    returns: np.ndarray
    steps: np.ndarray
    success: np.ndarray
    handoffs: int = 0
    contacts: int = 0

    @staticmethod
    def concatenate(chunks: list[ReturnChunk]) -> ReturnChunk:
        chunks = sorted(chunks, key=lambda c: int(c.policy[0]))
        return ReturnChunk(
            policy=np.concatenate([c.policy for c in chunks]),
            returns=np.concatenate([c.returns for c in chunks]),
            steps=np.concatenate([c.steps for c in chunks]),
            success=np.concatenate([c.success for c in chunks]),
            handoffs=sum(c.handoffs for c in chunks),
            contacts=sum(c.contacts for c in chunks),
        )


def chunk_size(task: Task, network: FamilySpec, settings: RWGSettings, backend: str) -> int:
    """Policies per chunk on ``backend`` (resolved): ``rwg.chunk_policies``, else what the backend runs well
    together (:meth:`taskcomplexity.rwg.backends.Backend.chunk_size`)."""
    return BACKENDS[backend].chunk_size(task, network, settings)


def chunks(task: Task, network: FamilySpec, settings: RWGSettings, backend: str) -> list[tuple[int, int]]:
    """The [start, stop) policy ranges of this shard's chunks."""
    start, stop = settings.shard_range()
    size = chunk_size(task, network, settings, backend)
    return [(a, min(a + size, stop)) for a in range(start, stop, size)]
