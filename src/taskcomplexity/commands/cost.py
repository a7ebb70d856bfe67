"""What a study's RWG stage will cost, estimated before any work from a pilot of each task on this machine.

    python pipelines/cost.py experiment=atlas                                         # make atlas's budget
    python pipelines/cost.py experiment=atlas study.policies=1000 study.episodes=1000  # Furuta et al.'s protocol
    make atlas-cost ARGS='study.policies=1000 study.episodes=1000 rwg.shards=100'

Per task of the composed study (the same overrides as the run it prices), on the backend the run would take, two
pilots of its first policies, each in one chunk (:func:`pilot_sizes`): on a backend whose chunks hold a fixed number
of policies (``envpool``: one environment each) a chunk's, on the others (``gym``, ``vector``) ``PILOT_POLICIES``
policies (fewer for episodes longer than 200 steps), run ``PILOT_EPISODES[0]`` and then ``PILOT_EPISODES[1]``
episodes, never more than the run's M (a run is not priced by pilots longer than itself); on a backend that steps a
chunk's P × M episodes as one batch (``kernel``, ``batched``), 2 and then 6 policies run the run's M (the table
gives each task's pilots). A chunk's CPU time is a fixed
part (making its environments, sampling its policies) plus a part per episode, so the two pilots give both: CPU-s
per episode = the difference of their CPU over the difference of their episodes, and the fixed part = the first
pilot's CPU less its episodes' share. The estimate is then N × M × CPU-s per episode + the run's chunks × the fixed
part; episode lengths vary between policies, so the pilots' policies stand for the N (the table gives their mean
episode length beside the limit T). Nothing is cached: the pilots' returns are thrown away; the RWG stage's own
cache is not read either (a cached task costs nothing to rerun).

The wall time assumes every usable core of this machine busy. Sent as jobs (``rwg.shards=K`` > 1, or with
``hydra/launcher=cluster``), every task is K jobs of a 1/K share each, and each job also starts a fresh process
(interpreter, imports, the task's environment and checks) before its first episode: that start-up is measured by
starting one such process per backend of the study (:func:`job_start_cpu`: ``pipelines/rwg.py rwg.entry=<id>`` at
N = M = 2) and added once per job. The longest job is compared with the cluster launcher's time limit
(``hydra.launcher.timeout_min``, on ``cpus_per_task`` cores) when ``hydra/launcher=cluster`` is given.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import resource
import time
from typing import Any

from omegaconf import DictConfig

from taskcomplexity.cli import one_line_errors
from taskcomplexity.commands import entry_point
from taskcomplexity.cores import usable_cores
from taskcomplexity.jobs import cpu_seconds
from taskcomplexity.report.format import plural

log = logging.getLogger("cost")

PILOT_POLICIES = 16
"""Policies of each pilot (the run's policies 0 … 15 of its seed); on EnvPool a whole chunk's (its batch)."""
PILOT_STEPS = 3200
"""On the gym backend, a pilot's policies × the episode limit T at most (with at least ``MIN_PILOT_POLICIES``): long,
slow episodes (Meta-World's 500 steps at 0.3-0.8 ms a step) are priced on fewer policies, so that pricing 50 such
tasks takes minutes, not the better part of an hour; tasks of up to 200 steps keep ``PILOT_POLICIES``."""
MIN_PILOT_POLICIES = 4
PILOT_EPISODES = (2, 6)
"""Episodes per policy of the two pilots: the difference prices an episode, the first the chunk's fixed part."""


@dataclasses.dataclass(frozen=True)
class TaskCost:
    """The estimate for one task.

    Attributes
    ----------
    task, backend : str
    policies, episodes, limit : int
        N, M and the episode limit T of the run priced.
    mean_steps : float
        Mean episode length of the pilots' episodes (environment steps).
    episode_cpu, chunk_cpu : float
        CPU-s per episode and per chunk (fixed part), from the pilots.
    chunks : int
        The run's chunks.
    pilots : tuple of two (policies, episodes)
        The sizes of the two pilots that priced it (:func:`pilot_sizes`).
    """

    task: str
    backend: str
    policies: int
    episodes: int
    limit: int
    mean_steps: float
    episode_cpu: float
    chunk_cpu: float
    chunks: int
    pilots: tuple[tuple[int, int], tuple[int, int]] = ((0, 0), (0, 0))

    @property
    def cpu_seconds(self) -> float:
        return self.policies * self.episodes * self.episode_cpu + self.chunks * self.chunk_cpu

    def job_cpu_seconds(self, shards: int, start: float) -> float:
        """CPU-s of the task sent as ``shards`` jobs, each starting a fresh process that costs ``start`` CPU-s."""
        return self.cpu_seconds + shards * start


def job_start_cpu(entry_id: str, typed: list[str]) -> float:
    """CPU-s a job of study task ``entry_id`` spends in a fresh process: ``pipelines/rwg.py rwg.entry=<id>`` with the
    typed overrides ``typed`` (the budget's and the sharding's left out) at N = M = 2, into a temporary cache; its
    two policies' four episodes are a negligible part."""
    import subprocess
    import sys
    import tempfile

    left_out = ("rwg.policies", "rwg.episodes", "rwg.shards", "rwg.shard", "study.policies", "study.episodes",
                "paths.outputs", "paths.cache", "force")
    kept = [o for o in typed if o.partition("=")[0].lstrip("+~") not in left_out]
    with tempfile.TemporaryDirectory(prefix="taskcomplexity-job-start-") as outputs:
        command = [sys.executable, "-m", "taskcomplexity.commands.rwg", *kept, f"rwg.entry={entry_id}",
                   "rwg.policies=2", "rwg.episodes=2", f"paths.outputs={outputs}", "hydra.run.dir=" + outputs]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        done = subprocess.run(command, capture_output=True, text=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines()
        raise RuntimeError(f"starting a job of {entry_id} failed: {lines[-1] if lines else done.returncode}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def pilot_sizes(request) -> tuple[tuple[int, int], tuple[int, int]]:
    """(policies, episodes) of the two pilots of ``request``: on a backend that steps a chunk's P × M episodes at
    once, 2 and up to 6 policies at the run's M (a chunk's cost is its batch's); on one whose chunks hold a fixed
    number of policies, a chunk's, else ``PILOT_POLICIES`` (fewer for episodes longer than 200 steps:
    :data:`PILOT_STEPS`), at ``PILOT_EPISODES`` but never more than the run's M (at M = 2 the two pilots are alike,
    and the second prices the episode alone)."""
    from taskcomplexity.rwg.backends import BACKENDS

    settings = request.settings
    backend = BACKENDS[request.backend]
    if backend.steps_at_once:
        return (2, settings.episodes), (min(PILOT_EPISODES[1], settings.policies), settings.episodes)
    if backend.chunk_policies is not None:
        policies = min(settings.policies, backend.chunk_policies)
    else:
        steps = max(1, int(request.task.max_steps or 1))
        policies = min(settings.policies, PILOT_POLICIES, max(MIN_PILOT_POLICIES, PILOT_STEPS // steps))
    first, second = (min(episodes, settings.episodes) for episodes in PILOT_EPISODES)
    return (policies, first), (policies, second)


def price(request, task_id: str | None = None) -> TaskCost:
    """Run the two pilots of ``request``'s task (after an untimed one that loads what a process loads once: kernels,
    modules) and extrapolate to its N × M; ``task_id``: the task's id in its study (default: the task's own)."""
    from taskcomplexity.rwg import chunks, run_rwg

    settings = request.settings
    timed, pilots = [], pilot_sizes(request)
    for policies, episodes in ((2, 2), *pilots):
        pilot = dataclasses.replace(settings, policies=policies, episodes=episodes, shard=0, shards=1,
                                    chunk_policies=policies, workers=1)
        started = cpu_seconds()
        chunk = run_rwg(request.task, request.network, request.prior, pilot, request.backend)
        timed.append((cpu_seconds() - started, chunk.steps))
    (first, short), (second, long) = timed[1:]
    if long.size > short.size:
        episode_cpu = max(second - first, 0.0) / (long.size - short.size)
        chunk_cpu = max(first - episode_cpu * short.size, 0.0)
    else:  # both pilots alike (N = 2 on a batched backend, M = 2 on the others): the second prices the episode
        episode_cpu, chunk_cpu = second / long.size, 0.0
    whole = dataclasses.replace(settings, shard=0, shards=1)
    return TaskCost(task_id or request.task.task_id, request.backend, settings.policies, settings.episodes,
                    int(request.task.max_steps), float(long.mean()), episode_cpu, chunk_cpu,
                    len(chunks(request.task, request.network, whole, request.backend)), pilots)


def _hours(seconds: float) -> str:
    return f"{seconds / 3600:.2f} h" if seconds >= 360 else f"{seconds / 60:.1f} min"


def _launcher_limit(cfg: DictConfig) -> tuple[float, int] | None:
    """(time limit in seconds, cores) of a cluster launcher given on the command line, else None."""
    try:
        from hydra.core.hydra_config import HydraConfig

        launcher = HydraConfig.get().launcher
    except (ImportError, ValueError):
        return None
    minutes, cores = launcher.get("timeout_min"), launcher.get("cpus_per_task")
    return (60.0 * minutes, int(cores or 1)) if minutes else None


def estimate(cfg: DictConfig, *, echo=print) -> list[TaskCost]:
    """Price every task of the composed study and print the table, the total and the shard advice."""
    from taskcomplexity.study.plan import refuse_entry, study_requests

    refuse_entry(cfg)
    entries = study_requests(cfg)
    cores = usable_cores()
    costs = []
    for entry, request in entries:
        started = time.perf_counter()
        costs.append(price(request, entry.id))
        log.info("priced %s on %s in %.1f s", entry.id, request.backend, time.perf_counter() - started)
    shards = int(cfg.rwg.shards)
    n, m = entries[0][1].settings.policies, entries[0][1].settings.episodes
    echo(f"RWG cost of study {cfg.study.name} at N = {n:,} × M = {m:,}, from two pilots per task on this machine "
         f"({cores} usable cores), their policies × episodes in the column pilots:")
    head = (f"{'task':<26}{'backend':>9}{'pilots':>14}{'steps/episode':>15}{'T':>6}{'CPU-ms/episode':>16}"
            f"{'CPU-s/chunk':>13}{'chunks':>8}{'CPU':>12}")
    echo(head)
    echo("-" * len(head))
    for c in costs:
        pilots = ", ".join(f"{policies}×{episodes}" for policies, episodes in c.pilots)
        echo(f"{c.task:<26}{c.backend:>9}{pilots:>14}{c.mean_steps:>15.1f}{c.limit:>6}{c.episode_cpu * 1e3:>16.2f}"
             f"{c.chunk_cpu:>13.2f}{c.chunks:>8}{_hours(c.cpu_seconds):>12}")
    total = sum(c.cpu_seconds for c in costs)
    echo(f"total: {total / 3600:.2f} CPU-hours; {_hours(total / cores)} of wall time on this machine's {cores} cores "
         "(every core busy)")
    limit = _launcher_limit(cfg)
    if shards > 1 or limit is not None:
        echo_jobs(costs, entries, shards, limit, echo)
    return costs


def echo_jobs(costs: list[TaskCost], entries, shards: int, limit: tuple[float, int] | None, echo) -> dict[str, float]:
    """Print what the run costs sent as jobs (every task in ``shards`` jobs, each starting a fresh process) and how the
    longest job stands against the launcher's ``limit``; return the start-up CPU-s measured per backend."""
    from taskcomplexity.cli import user_overrides

    starts: dict[str, float] = {}
    for (entry, _), cost in zip(entries, costs, strict=True):
        if cost.backend not in starts:
            starts[cost.backend] = job_start_cpu(entry.id, user_overrides())
            log.info("a job of %s on %s starts in %.1f CPU-s", entry.id, cost.backend, starts[cost.backend])
    jobs = len(costs) * shards
    in_jobs = sum(c.job_cpu_seconds(shards, starts[c.backend]) for c in costs)
    measured = ", ".join(f"{cpu:.1f} CPU-s on {backend}" for backend, cpu in starts.items())
    echo(f"as jobs: {len(costs)} tasks × rwg.shards={shards} = {jobs} jobs, each starting a fresh process ({measured}, "
         f"measured by starting one): {in_jobs / 3600:.2f} CPU-hours in all")
    longest = max(costs, key=lambda c: c.cpu_seconds / shards + starts[c.backend])
    share = longest.cpu_seconds / shards + starts[longest.backend]
    line = f"the longest job: a shard of {longest.task}, {_hours(share)} of CPU"
    if limit is not None:
        seconds, job_cores = limit
        wall = share / job_cores
        needed = math.ceil(longest.cpu_seconds / (job_cores * seconds - starts[longest.backend])) \
            if job_cores * seconds > starts[longest.backend] else None
        advice = f"use rwg.shards >= {needed}" if needed else "raise hydra.launcher.timeout_min"
        line += (f", {_hours(wall)} on a job's {plural(job_cores, 'core')} against the launcher's limit of "
                 f"{_hours(seconds)}" + (": within it" if wall <= seconds else f": beyond it, {advice}"))
    echo(line)
    return starts


@one_line_errors
def run(cfg: DictConfig) -> Any:
    """Print the estimate of the composed study's RWG stage (no artefact is written)."""
    return estimate(cfg)


main = entry_point(run)


if __name__ == "__main__":
    main()
