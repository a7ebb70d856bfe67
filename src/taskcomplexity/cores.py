"""The CPUs this process may run on: its affinity mask where the system has one (else every CPU), and within a
SLURM job at most the CPUs the job was allocated."""

from __future__ import annotations

import os


def usable_cores() -> int:
    """How many CPUs this process may use.

    ``os.sched_getaffinity`` where available; inside a SLURM job also at most ``SLURM_CPUS_PER_TASK``, since a
    cluster that does not bind tasks to cores (``TaskPlugin=task/none``) shows every job the whole node, and
    a job that used them all would run on the cores of the jobs beside it.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    allocated = os.environ.get("SLURM_CPUS_PER_TASK", "")
    return min(cores, int(allocated)) if allocated.isdigit() and int(allocated) > 0 else cores
