"""What a run needs of this machine, refused up front when it is more than the machine has."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from taskcomplexity.errors import ConfigError

MIN_FREE_BYTES = 1 << 20
"""Below this much free space a run could not even write its config and log: refused up front."""
MEMORY_SHARE = 0.8
"""The share of the machine's memory a run may plan to use (the rest is the system's and the libraries')."""


def physical_memory() -> int:
    """This machine's memory in bytes."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def human_bytes(n: float) -> str:
    """A size in the largest binary unit that keeps it at least 1: ``512 B``, ``3.8 MB``, ``1.2 GB``."""
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1024:
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:,.1f} TB"


def refuse_beyond_memory(need: float, what: str, advice: str) -> None:
    """Raise :class:`ConfigError` when ``need`` bytes exceed :data:`MEMORY_SHARE` of the machine's memory.

    ``what`` names the settings that need it (``"metrics.bins = 1,000,000"``), ``advice`` what to lower.
    """
    total = physical_memory()
    if need > MEMORY_SHARE * total:
        raise ConfigError(f"{what} needs about {human_bytes(need)} of memory, this machine has "
                          f"{human_bytes(total)} ({advice})")


def refuse_beyond_disk(need: float, what: str, root: Path) -> None:
    """Raise :class:`ConfigError` when ``need`` bytes exceed the free space of ``root``'s filesystem (``root`` is
    made if missing). ``what`` names the settings that need it."""
    root.mkdir(parents=True, exist_ok=True)
    free = shutil.disk_usage(root).free
    if need > free:
        raise ConfigError(f"{what} needs about {human_bytes(need)} of disk under {root}, {human_bytes(free)} are free")


SAC_FLOAT_BYTES = 4
"""SAC's networks, optimiser states and replay buffers are float32."""


def mlp_parameters(inputs: int, hidden: tuple[int, ...], outputs: int) -> int:
    """Weights and biases of a fully connected network ``inputs → hidden… → outputs``."""
    sizes = (inputs, *hidden, outputs)
    return sum((a + 1) * b for a, b in zip(sizes, sizes[1:], strict=False))


def sac_needs(observation_size: int, action_size: int, hidden_sizes: tuple[int, ...], *, seeds: int,
              transitions: int, snapshots: int) -> tuple[int, int]:
    """(memory, disk) in bytes of one SAC run, estimated before anything is allocated.

    Per seed: the actor (observation → 2 × action) and two critics (observation + action → 1), each trained with a
    gradient and Adam's two moments, and the critics' two targets; a replay buffer of ``transitions`` transitions
    (two observations, the action, the reward and three flags each). Memory holds all of it; a checkpoint holds
    all but the gradients, and is written beside the previous one (twice its size on disk at the peak), and the
    actor is kept at ``snapshots`` steps.
    """
    actor = mlp_parameters(observation_size, hidden_sizes, 2 * action_size)
    critic = mlp_parameters(observation_size + action_size, hidden_sizes, 1)
    trained = actor + 2 * critic
    buffer = transitions * (2 * observation_size + action_size + 4)
    memory = seeds * SAC_FLOAT_BYTES * (4 * trained + 2 * critic + buffer)
    checkpoint = seeds * SAC_FLOAT_BYTES * (3 * trained + 2 * critic + buffer)
    disk = 2 * checkpoint + seeds * SAC_FLOAT_BYTES * snapshots * actor
    return memory, disk


def check_free_space(root: Path) -> None:
    """Raise the disk-full ``OSError`` (naming ``root``) when its filesystem has almost no space left."""
    free = shutil.disk_usage(root).free
    if free < MIN_FREE_BYTES:
        raise OSError(errno.ENOSPC, f"No space left on device ({human_bytes(free)} free)", str(root))
