"""The settings of one RWG run (``rwg.*``): N, M, the seed, how the work is split and what the batched backend
does with the obstacle task's contacts."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskcomplexity.config import setting
from taskcomplexity.errors import ConfigError

CONTACTS = ("pybullet", "model")
"""The values of ``rwg.contacts``: the contact modes of the batched backend's kernels
(:data:`taskcomplexity.tasks.dynamics.CONTACT_MODES`, named here so that reading the settings loads no kernel)."""
PRECISIONS = ("float64", "float32")
"""The values of ``rwg.precision``: the forward pass's arithmetics of the batched backend's kernel
(:data:`taskcomplexity.tasks.rollout_kernel.PRECISIONS`)."""


@dataclass(frozen=True)
class RWGSettings:
    """Settings of one RWG run.

    Attributes
    ----------
    policies, episodes : int
        N and M (both >= 2).
    seed : int
        Run seed (>= 0).
    chunk_policies : int
        Policies simulated together; 0 chooses from ``chunk_memory_mb``.
    chunk_memory_mb : int
        Working-memory budget of one chunk on the batched backend, MB.
    shard, shards : int
        This job simulates policy range ``shard`` of ``shards`` equal ranges.
    workers : int
        Processes stepping the environments of a backend whose chunks run on workers (``gym``, ``vector``:
        :attr:`taskcomplexity.rwg.backends.Backend.worker_processes`), each a chunk at a time (0: one per usable core;
        at most one per chunk). The other backends run in one process, where a value other than 0 is refused.
    contacts : {'pybullet', 'model'}
        The obstacle task's forearm–block contacts on the batched backend: ``pybullet`` finishes each
        episode that reaches the block on the PyBullet reference (exact, PyBullet's speed);
        ``model`` integrates them with the batched contact model (:mod:`taskcomplexity.tasks.contact`:
        PyBullet's distribution of outcomes, at the batched backend's speed).
    common_initial_states : bool
        Episode e of every policy starts from the same state (reset by (seed, e) only: the original
        PIC/POIC protocol's common random numbers); false: by (seed, n, e).
    precision : {'float64', 'float32'}
        The arithmetic of the policies' forward pass on the batched backend (MLP families; the physics is always
        float64). ``float32`` runs it about 1.5× faster, and the returns move by the rounding of the actions
        (:func:`taskcomplexity.tasks.rollout_kernel.rollout`); it has its own keys. The obstacle task keeps
        float64 (its contacts are chaotic: :class:`taskcomplexity.stages.rwg_stage.RWGRequest`).
    entry : str or None
        A study task's id: ``pipelines/rwg.py`` runs that task of the selected study as the study composes it (its
        key is the one the study looks up); a sweep over the ids sends a study's RWG out as jobs. None: the task
        the config composes.
    """

    policies: int = 1000
    episodes: int = 100
    seed: int = 0
    chunk_policies: int = setting(0, result=False)  # how the work is split never changes the returns
    chunk_memory_mb: int = setting(512, result=False)
    shard: int = setting(0, result=False)
    shards: int = setting(1, result=False)
    workers: int = setting(0, result=False)
    contacts: str = "pybullet"
    common_initial_states: bool = False
    precision: str = "float64"
    entry: str | None = setting(None, result=False)

    def validate(self) -> None:
        if self.policies < 2:
            raise ConfigError(f"rwg.policies must be an integer >= 2 (N), got {self.policies}")
        if self.episodes < 2:
            raise ConfigError(f"rwg.episodes must be an integer >= 2 (M), got {self.episodes}")
        if self.seed < 0:
            raise ConfigError(f"rwg.seed must be a non-negative integer, got {self.seed}")
        if self.chunk_policies < 0:
            raise ConfigError(f"rwg.chunk_policies must be >= 0 (0 = automatic), got {self.chunk_policies}")
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) or self.workers < 0:
            raise ConfigError(f"rwg.workers must be an integer >= 0 (0 = one per core), got {self.workers!r}")
        if self.chunk_memory_mb < 1:
            raise ConfigError(f"rwg.chunk_memory_mb must be >= 1, got {self.chunk_memory_mb}")
        if self.contacts not in CONTACTS:
            raise ConfigError(f"rwg.contacts must be one of {list(CONTACTS)}, got {self.contacts!r}")
        if self.precision not in PRECISIONS:
            raise ConfigError(f"rwg.precision must be one of {list(PRECISIONS)}, got {self.precision!r}")
        if self.entry is not None and (not isinstance(self.entry, str) or not self.entry):
            raise ConfigError(f"rwg.entry must be a study task's id or null, got {self.entry!r}")
        if not 1 <= self.shards <= self.policies:
            raise ConfigError(f"rwg.shards must be in [1, rwg.policies={self.policies}], got {self.shards}")
        if not 0 <= self.shard < self.shards:
            raise ConfigError(
                f"rwg.shard must be in [0, {self.shards - 1}] (rwg.shards={self.shards}), got {self.shard}"
            )

    def shard_range(self, shard: int | None = None) -> tuple[int, int]:
        """Policy index range [start, stop) of a shard (this one by default)."""
        shard = self.shard if shard is None else shard
        bounds = np.linspace(0, self.policies, self.shards + 1).round().astype(int)
        return int(bounds[shard]), int(bounds[shard + 1])
