"""The CPUs this process may run on (its affinity mask where the system has one, else every CPU)."""

from __future__ import annotations

import os


def usable_cores() -> int:
    """How many CPUs this process may use (``os.sched_getaffinity`` where available: a cluster job's share)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
