"""Seeds derived from a run's seed, so that every random stream of a run is owned and reproducible."""

from __future__ import annotations

import hashlib

import numpy as np


def derive_seed(*keys: int | str) -> int:
    """A 32-bit seed determined by ``keys`` (e.g. ``derive_seed(seed, "eval", episode)``).

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
