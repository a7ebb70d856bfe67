"""Random streams that make RWG a pure function of (task, network, prior, N, M, seed).

Policy n's weights come from a NumPy generator seeded by ``SeedSequence(seed, spawn_key=(WEIGHTS, n))``;
episode e of policy n starts from four uniforms of a counter-based hash of (seed, n, e). Neither
depends on how the N × M work is split into chunks or shards, nor on the simulator backend, so any
sharding yields the same return matrix bit for bit and any θₙ can be rebuilt later.
"""

from __future__ import annotations

import hashlib

import numpy as np

WEIGHTS = 0x57  # stream labels
EPISODES = 0x45
RESETS = 0x52

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on uint64 arrays (wrapping arithmetic)."""
    with np.errstate(over="ignore"):
        x = x + _GOLDEN
        x = (x ^ (x >> np.uint64(30))) * _MIX1
        x = (x ^ (x >> np.uint64(27))) * _MIX2
        return x ^ (x >> np.uint64(31))


def stream_key(seed: int, label: int) -> np.uint64:
    """A 64-bit key for one named stream of a run seed."""
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    state = np.random.SeedSequence([int(seed), int(label)]).generate_state(2, dtype=np.uint64)
    return np.uint64(state[0] ^ state[1])


def episode_uniforms(seed: int, policies: np.ndarray, episodes: np.ndarray, draws: int = 4) -> np.ndarray:
    """U[0, 1) variates for the reset of episode e of policy n.

    Parameters
    ----------
    seed : int
        Run seed.
    policies, episodes : int arrays, broadcastable to a common shape S
        Policy and episode indices.
    draws : int
        Variates per episode.

    Returns
    -------
    ndarray, shape S + (draws,), float64 in [0, 1) with 53 random bits each.
    """
    key = stream_key(seed, EPISODES)
    n, e = np.broadcast_arrays(np.asarray(policies, dtype=np.uint64), np.asarray(episodes, dtype=np.uint64))
    h = _splitmix64(_splitmix64(key ^ n) ^ (e * _MIX1))
    k = np.arange(draws, dtype=np.uint64)
    bits = _splitmix64(h[..., None] ^ (k * _MIX2))
    return (bits >> np.uint64(11)).astype(np.float64) * (1.0 / (1 << 53))


def episode_reset_seeds(seed: int, policies: np.ndarray, episodes: np.ndarray) -> np.ndarray:
    """The ``env.reset(seed=…)`` seed of episode e of policy n, for tasks that reset themselves.

    A counter-based hash of (seed, n, e) on its own stream, so it depends on nothing else (chunk,
    shard, backend, the order episodes run in).

    Parameters
    ----------
    seed : int
        Run seed.
    policies, episodes : int arrays, broadcastable to a common shape S

    Returns
    -------
    ndarray, shape S, int64 in [0, 2³¹): gymnasium accepts any non-negative int.
    """
    key = stream_key(seed, RESETS)
    n, e = np.broadcast_arrays(np.asarray(policies, dtype=np.uint64), np.asarray(episodes, dtype=np.uint64))
    bits = _splitmix64(_splitmix64(key ^ n) ^ (e * _MIX1))
    return (bits >> np.uint64(33)).astype(np.int64)


def policy_generator(seed: int, policy: int) -> np.random.Generator:
    """The generator of policy n's weights."""
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(WEIGHTS, int(policy))))


def derive_seed(*keys: int | str) -> int:
    """A 32-bit seed determined by ``keys`` (e.g. ``derive_seed(seed, "eval", episode)``): SAC's streams.

    Different key tuples give statistically independent streams (NumPy ``SeedSequence``); strings are
    hashed with SHA-256, so the result does not depend on Python's hash randomisation.

    Parameters
    ----------
    *keys : int >= 0 or str
    """
    entropy = []
    for key in keys:
        if isinstance(key, str):
            entropy.append(int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "little"))
        elif isinstance(key, (int, np.integer)) and not isinstance(key, bool) and key >= 0:
            entropy.append(int(key))
        else:
            raise ValueError(f"keys must be non-negative integers or strings, got {key!r}")
    return int(np.random.SeedSequence(entropy).generate_state(1, np.uint32)[0])
