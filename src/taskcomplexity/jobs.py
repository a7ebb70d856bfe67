"""Which job computed an artefact: the scheduler, the job's id, its node, and the CPU and wall time its part cost.

A stage's work can be spread over processes and machines: RWG shards in a job array, a job requeued at its time
limit that resumes from the chunks the first attempt saved, a rerun after ``scancel``. Each process that computes
part of an artefact keeps a :class:`JobRecord` of its part; the stage writes the records into the artefact's
manifest (``jobs``), and the report's Methods say from them where the work ran and what each job cost. Records are
provenance only: no key and no number of an artefact depends on them.
"""

from __future__ import annotations

import dataclasses
import json
import os
import resource
import socket
import time
from dataclasses import dataclass
from pathlib import Path


def cpu_seconds() -> float:
    """CPU time of this process (every thread) and of its children that ended (a pool's workers, once shut)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def scheduler_job() -> tuple[str, str, int]:
    """(scheduler, job id, restarts) of this process: ``slurm`` with SLURM's id (``<array job>_<task>`` in an array)
    and ``SLURM_RESTART_COUNT``, or ``local`` with ``pid <n>``."""
    env = os.environ
    if "SLURM_JOB_ID" in env:
        job = f"{env['SLURM_ARRAY_JOB_ID']}_{env['SLURM_ARRAY_TASK_ID']}" if "SLURM_ARRAY_TASK_ID" in env \
            else env["SLURM_JOB_ID"]
        return "slurm", job, int(env.get("SLURM_RESTART_COUNT", "0") or 0)
    return "local", f"pid {os.getpid()}", 0


@dataclass
class JobRecord:
    """One process's part of an artefact.

    Attributes
    ----------
    scheduler : str
        ``slurm`` or ``local`` (a process started by hand or by a local launcher).
    job : str
        SLURM's job id (``<array job>_<task>`` for a task of an array) or ``pid <n>``.
    node : str
        The host name the process ran on.
    part : str
        What of the artefact it computed (``shard 2 of 4``, ``all``).
    restarts : int
        ``SLURM_RESTART_COUNT``: how often SLURM requeued the job before this attempt.
    units : int
        Work it computed itself (RWG: policies; SAC: runs), not counting work an earlier attempt saved.
    reused : int
        Work it found saved by an earlier attempt and did not recompute.
    cpu_seconds, wall_seconds : float
        CPU time (the process and its ended children) and wall time of its part.
    started : str
        When its part started (UTC, ISO 8601).
    """

    scheduler: str
    job: str
    node: str
    part: str
    restarts: int = 0
    units: int = 0
    reused: int = 0
    cpu_seconds: float = 0.0
    wall_seconds: float = 0.0
    started: str = ""


class JobMeter:
    """Measures this process's part of an artefact from its creation on; :meth:`record` gives the record so far."""

    def __init__(self, part: str, *, reused: int = 0) -> None:
        self.scheduler, self.job, self.restarts = scheduler_job()
        self.part, self.reused, self.units = part, reused, 0
        self._cpu, self._wall = cpu_seconds(), time.monotonic()
        self._started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())

    def record(self) -> JobRecord:
        return JobRecord(self.scheduler, self.job, socket.gethostname(), self.part, self.restarts, self.units,
                         self.reused, round(cpu_seconds() - self._cpu, 3), round(time.monotonic() - self._wall, 3),
                         self._started)

    def save(self, directory: Path) -> None:
        """Write the record so far into ``directory`` (atomically; one file per process and part), so that a job
        killed later still leaves the record of the work it saved."""
        name = f"job-{self.part.replace(' ', '-')}-{self.job.replace(' ', '-')}-{os.getpid()}.json"
        tmp = directory / f".{name}.tmp"
        tmp.write_text(json.dumps(dataclasses.asdict(self.record())))
        tmp.replace(directory / name)


def saved_records(directory: Path) -> list[dict]:
    """The records saved in ``directory`` (:meth:`JobMeter.save`), oldest first."""
    records = []
    for path in directory.glob("job-*.json"):
        try:
            records.append(json.loads(path.read_text()))
        except (OSError, ValueError):
            continue  # a record is provenance: an unreadable one is left out, never a reason to fail
    return sorted(records, key=lambda r: (r.get("started", ""), r.get("job", "")))
