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


def check_free_space(root: Path) -> None:
    """Raise the disk-full ``OSError`` (naming ``root``) when its filesystem has almost no space left."""
    free = shutil.disk_usage(root).free
    if free < MIN_FREE_BYTES:
        raise OSError(errno.ENOSPC, f"No space left on device ({human_bytes(free)} free)", str(root))
