"""Random Weight Guessing (Algorithm 1): N random policies × M episodes → the return matrix S.

S[n, e] is the undiscounted return of policy θₙ in episode e. Policy n's weights and episode e's
initial state come from streams keyed by (seed, n) and (seed, n, e) (:mod:`taskcomplexity.seeding`),
so S is a pure function of (task, network, prior, N, M, seed, backend): the same for any chunking or sharding,
and the same on every backend whose returns are exact (:attr:`Backend.exact`, up to its tests' stated tolerance);
EnvPool's are another sample of the same distribution, under a key of their own.

The package re-exports the names of its modules:

- :mod:`.settings`: :class:`RWGSettings`, the ``rwg.*`` settings;
- :mod:`.backends`: the backends' interface (:class:`Runner`, :class:`Plan`), their registry (:data:`BACKENDS`
  of :class:`Backend` declarations) and :func:`resolve_backend`, the choice of one for a task and a policy family;
- :mod:`.chunking`: :class:`ReturnChunk` and the split of a shard into chunks;
- :mod:`.run`: :func:`run_rwg` over a shard; :mod:`.batch`: :func:`simulate_chunk` for a chunk, :func:`run_batch`
  for a batch (the one call every backend answers);
- the backends' runners: :mod:`.batched_backend` and :mod:`.pybullet_backend` (the reaching arms, from the reset
  states of :mod:`.arm_resets`), :mod:`.gym_backend` (any gymnasium task), :mod:`.kernel_backend` (classic
  control), :mod:`.envpool_backend` (MuJoCo and DM Control on EnvPool), :mod:`.vector_backend` (a researcher's
  vector env);
- :mod:`.workers`: the chunks of a backend that steps Python environments on a pool of processes (``rwg.workers``);
- :mod:`.env_checks`: the checks a gymnasium env passes before its returns are cached (reproducible resets,
  observation shapes, finite rewards);
- :mod:`.contact_calibration`: the contact model's one-sweep rates, measured again on PyBullet
  (``make calibrate-contacts``);
- :mod:`.given_policies`: the return matrix of given policies (e.g. around SAC's actor) on the same backends;
- :mod:`.occupancy`: the state–action occupancy of sampled policies (the occupancy distance's input).
"""

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what the package re-exports, for type checkers and readers; imported on first use (__getattr__)
    from taskcomplexity.rwg.arm_resets import initial_states
    from taskcomplexity.rwg.backends import AUTO, BACKENDS, Backend, Plan, Runner, resolve_backend
    from taskcomplexity.rwg.batch import run_batch, simulate_chunk
    from taskcomplexity.rwg.batched_backend import simulate_batched
    from taskcomplexity.rwg.chunking import ReturnChunk, chunk_size, chunks
    from taskcomplexity.rwg.pybullet_backend import simulate_pybullet
    from taskcomplexity.rwg.run import run_rwg
    from taskcomplexity.rwg.settings import CONTACTS, RWGSettings

_EXPORTS = {
    "initial_states": "arm_resets", "AUTO": "backends", "BACKENDS": "backends", "Backend": "backends",
    "Plan": "backends", "Runner": "backends", "resolve_backend": "backends",
    "simulate_batched": "batched_backend", "_simulate_batched": "batched_backend", "ReturnChunk": "chunking",
    "chunk_size": "chunking", "chunks": "chunking", "simulate_pybullet": "pybullet_backend",
    "_simulate_pybullet": "pybullet_backend", "run_batch": "batch", "run_rwg": "run", "simulate_chunk": "batch",
    "CONTACTS": "settings", "RWGSettings": "settings",
}
"""Each name the package re-exports → its module, imported on first use (PEP 562): the settings are read without the
backends' libraries (torch, numba, PyBullet). ``_simulate_batched`` and ``_simulate_pybullet`` are the names the
benchmarks import (bench/bench_rwg.py)."""


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name.lstrip("_"))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})


__all__ = [
    "AUTO", "BACKENDS", "CONTACTS", "Backend", "Plan", "RWGSettings", "ReturnChunk", "Runner", "chunk_size", "chunks",
    "initial_states",
    "resolve_backend", "run_batch", "run_rwg", "simulate_batched", "simulate_chunk", "simulate_pybullet",
]
