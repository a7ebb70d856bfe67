"""The SAC stage: (task, SAC settings, variant, seed group) → ``curves.parquet`` in the cache.

A run's checkpoints live in the key's scratch directory, so an interrupted run resumes from its last
checkpoint (exactly: see ``taskcomplexity.rl``); the curve is written atomically when it finishes.
The seeds of a task train together, and a seed's curve depends on its group, so the key hashes the
whole seed group. The budget is part of the settings hashed: ``sac.total_steps`` once resolved
(``sac.total_steps`` itself, else the study entry's ``sac_steps``). Keys changed once when the
budgets moved from ``sac.budgets`` to the study file: the old keys hashed the whole seven-task
``budgets`` table (so a change to one task's budget re-keyed every task); a key now hashes its own
task's budget only.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import shutil
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from taskcomplexity.config import build, result_identity
from taskcomplexity.cores import usable_cores
from taskcomplexity.errors import ConfigError, WorkerLost
from taskcomplexity.jobs import JobMeter
from taskcomplexity.processes import start_worker, stop_pool
from taskcomplexity.rl.curves import ACTORS_FILE
from taskcomplexity.rl.settings import (
    OWN_ENV,
    SACSettings,
    backend_identity,
    device_identity,
    env_backend,
    sac_skip_reason,
    with_budget,
)
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.resources import mlp_parameters, refuse_beyond_disk, refuse_beyond_memory, sac_needs
from taskcomplexity.stages.stage import SEEDS, Judged, Stage, StudyWork
from taskcomplexity.stages.stage_log import outcome

if TYPE_CHECKING:
    import pandas as pd

log = logging.getLogger(__name__)

STAGE = "sac"
NUMERICS = Numerics(version=1, modules=(
    "rl.settings", "rl.train", "rl.factories", "rl.layers", "rl.objective", "rl.her", "rl.evaluation", "rl.snapshots",
    "policies.mlp", "policies.tanh", "policies.tanh_kernel",
    "seeding", "tasks.base", "tasks.spec", "tasks.mechanics", "tasks.rewards", "tasks.reward_kinds", "tasks.urdf",
    "tasks.pybullet_env", "tasks.goal_env", "tasks.gym_task", "tasks.batched_vector", "tasks.batched",
    "tasks.step_kernel", "tasks.dynamics", "tasks.rollout_kernel", "tasks.contact", "tasks.manipulation",
    "rwg.backends",  # which vector env steps the environments (sac.backend)
    "stages.sac_stage",
))
CURVES = "curves.parquet"
# Settings that do not change the curve, left out of the key.
JOBS_ATTR = "sac_jobs"
"""``curves.attrs[JOBS_ATTR]``: {study task id: the job records of its runs' artefacts} (:mod:`taskcomplexity.jobs`)."""
SKIPPED_ATTR = "sac_skipped"
"""``curves.attrs[SKIPPED_ATTR]``: {study task id: reason} of the tasks SAC did not run on."""
ACTORS_ATTR = "sac_actors"
"""``curves.attrs[ACTORS_ATTR]``: {study task id: (SAC key, path of its ``actors.npz``)} of the plain SAC variant."""
MISSING_ATTR = "sac_missing"
"""``curves.attrs[MISSING_ATTR]``: study task ids whose curves the cache does not hold yet (``cached_only``)."""


def sac_identity(task, settings, *, solved_return: float | None = None) -> dict:
    """What a SAC artefact is a function of: the task's identity, the settings (budget resolved) and, off the CPU,
    the device (:func:`taskcomplexity.rl.settings.device_identity`); where the batched kernel steps the environments,
    the backend (:func:`taskcomplexity.rl.settings.backend_identity`).

    ``solved_return`` (the study's threshold for envs that report no success) enters only when set.
    """
    identity = {"task": task.identity(), "settings": result_identity(settings), **device_identity(settings),
                **backend_identity(task, settings)}
    if solved_return is not None:
        identity["solved_return"] = float(solved_return)
    return identity


def run_key(entry, task, variant) -> str:
    """The cache key of one SAC run of a study entry (its ``solved_return`` included)."""
    return stage_key(STAGE, NUMERICS, sac_identity(task, variant, solved_return=entry.solved_return))


def check_resources(task, settings, cache: Cache | None = None) -> None:
    """Refuse, before anything is allocated or written, a SAC run (``settings`` with its budget) whose memory, or
    with ``cache`` whose disk under it, is beyond this machine, naming the setting that needs most of it
    (:func:`~taskcomplexity.stages.resources.sac_needs`)."""
    if settings.total_steps is None:
        return
    hidden = tuple(settings.hidden_sizes)
    seeds = len(settings.seeds)
    transitions = min(settings.buffer_size, settings.total_steps)
    memory, disk = sac_needs(task.observation_size, task.action_size, hidden, seeds=seeds, transitions=transitions,
                             snapshots=settings.total_steps // settings.checkpoint_every + 2)
    parameters = sum(mlp_parameters(task.observation_size + extra, hidden, out)
                     for extra, out in ((0, 2 * task.action_size), (task.action_size, 1), (task.action_size, 1)))
    if parameters >= transitions * (2 * task.observation_size + task.action_size + 4):
        what = (f"sac.hidden_sizes={list(hidden)} ({parameters:,} parameters per seed × {seeds} seeds on task "
                f"{task.task_id})")
    else:
        what = (f"sac.buffer_size={settings.buffer_size} ({transitions:,} transitions per seed × {seeds} seeds on task "
                f"{task.task_id})")
    refuse_beyond_memory(memory, what, "lower it")
    if cache is not None:
        refuse_beyond_disk(disk, what, cache.root)


def run_sac_stage(
    cache: Cache,
    task,
    settings,
    *,
    solved_return: float | None = None,
    force: bool = False,
    progress: bool = False,
    cached_only: bool = False,
    bar_position: int | None = None,
) -> tuple[Artefact | None, bool]:
    """Train (or reuse) one SAC variant of ``task`` over its seed group.

    ``settings.total_steps`` must be the run's budget (see :func:`taskcomplexity.rl.with_budget`).
    ``cached_only``: never train; (None, False) when the cache does not hold the curve. ``bar_position``: the
    progress bar's line when several runs train at once.
    """
    identity = sac_identity(task, settings, solved_return=solved_return)
    key = stage_key(STAGE, NUMERICS, identity)
    if cached_only or not force:
        found = cache.lookup(STAGE, key, config=identity)
        if cached_only or found is not None:
            return found, found is not None
    check_resources(task, settings, cache)  # what is to be trained, before anything is allocated or written
    variant = settings.variant

    def write(directory) -> dict:
        from taskcomplexity.rl import train_sac_run  # torch and torchrl: only when a run trains, not to look one up

        scratch = cache.scratch(STAGE, key)
        meter = JobMeter(variant)
        try:
            curves, actors = train_sac_run(
                task, settings, checkpoint_dir=scratch, progress=progress, solved_return=solved_return,
                bar_position=bar_position,
            )
        except BaseException:  # a run that saved no checkpoint leaves no scratch directory behind
            with contextlib.suppress(OSError):
                scratch.rmdir()
            raise
        curves.to_parquet(directory / CURVES, index=False)
        if actors is not None:
            actors.save(directory / ACTORS_FILE)
        meter.units = 1
        return {"label": f"{task.task_id} {variant} seeds={list(settings.seeds)}", "variant": variant,
                "jobs": [dataclasses.asdict(meter.record())]}

    def cleanup() -> None:
        shutil.rmtree(cache.scratch(STAGE, key), ignore_errors=True)

    return cache.get_or_compute(STAGE, key, write, config=identity, force=force, after=cleanup)


SEED_STEPS_PER_SECOND = 217.0
"""Training throughput of one of the protocol's runs, environment steps per second summed over the seeds of the
run (five seeds trained together, one gradient update per step, evaluations included), with a core of its own:
the median over `make paper`'s ten runs on the 2-core development machine, two at a time (2026-11-27, the
curves' training clock over windows of 20 000 steps not slowed by other work; ``bench/bench_sac.py``, on the
1-link dense task alone, gave 245 for one run and 489 for two at once). The basis of the upfront estimate of
`make paper`, which trains ``sac.workers`` runs at once; the bench measures it on yours."""


def training_plan(cache: Cache, runs, workers: int = 1) -> str:
    """One line: how many SAC runs are left to train, their seed-steps and the estimated wall time.

    ``runs`` are (StudyTask, Task, budgeted SACSettings); a run whose curve the cache holds is done. ``workers``:
    runs trained at once. An interrupted run resumes from its last checkpoint, so the estimate is an upper bound
    then.
    """
    from taskcomplexity.rl import protocol_variants

    total, todo, seed_steps = 0, 0, 0
    for entry, task, budgeted in runs:
        for variant in protocol_variants(task, budgeted):
            total += 1
            key = run_key(entry, task, variant)
            if cache.lookup(STAGE, key) is None:
                todo += 1
                seed_steps += int(variant.total_steps) * len(variant.seeds)
    if not todo:
        return f"all {total} runs in the cache"
    at_once = max(1, min(workers, todo))
    seconds = seed_steps / (SEED_STEPS_PER_SECOND * at_once)
    duration = f"{seconds / 3600:.1f} h" if seconds >= 3600 else f"{max(1, round(seconds / 60))} min"
    return (f"{todo} of {total} runs to train, {seed_steps:,} seed-steps: about {duration} at "
            f"{SEED_STEPS_PER_SECOND:.0f} seed-steps/s per run, {at_once} at once (bench/bench_sac.py measures this "
            "machine; an interrupted run resumes from its last checkpoint)")


def sac_workers(settings) -> int:
    """Runs trained at once: ``sac.workers``, or one per CPU when it is 0."""
    return settings.workers or usable_cores()


def train_at_once(cache: Cache, jobs, workers: int, *, force: bool = False, progress: bool = False) -> dict:
    """Train the runs of ``jobs`` that the cache lacks (all of them with ``force``), ``workers`` at a time, each in
    a process of its own; returns {key: seconds} of the runs trained (empty when fewer than two are left or
    ``workers`` < 2: the caller trains them one after the other).

    ``jobs`` are (StudyTask, Task, variant SACSettings). Each run is :func:`run_sac_stage` in a fresh interpreter
    (spawned: no inherited threads or locks); its artefact lands under the key the caller looks up, and the cache's
    per-key lock keeps two processes from training one run. A run's numbers do not depend on who trains it.
    """
    pending = []
    for entry, task, variant in jobs:
        key = run_key(entry, task, variant)
        if force or cache.lookup(STAGE, key) is None:
            pending.append((key, entry, task, variant))
    at_once = min(workers, len(pending))
    if at_once < 2:
        return {}
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    context = multiprocessing.get_context("spawn")
    seconds = {}
    slots = context.Queue()
    for slot in range(at_once):
        slots.put(slot)
    pool = ProcessPoolExecutor(max_workers=at_once, mp_context=context, initializer=_start_trainer, initargs=(slots,))
    try:
        running = {pool.submit(_train_one, cache, task, variant, entry.solved_return, force, progress):
                   (key, entry, variant) for key, entry, task, variant in pending}
        while running:
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                key, entry, variant = running.pop(future)
                try:
                    seconds[key] = future.result()
                except BrokenProcessPool:
                    unfinished = sorted({f"{e.id} {v.variant}" for _, e, v in running.values()}
                                        | {f"{entry.id} {variant.variant}"})
                    raise WorkerLost(f"a SAC worker process died (killed, or out of memory) with "
                                     f"{len(unfinished)} run{'s' if len(unfinished) != 1 else ''} unfinished "
                                     f"({', '.join(unfinished)}); the {len(seconds)} trained here and every "
                                     "evaluation checkpoint are saved: rerun the same command to resume") from None
                log.info("%-26s %s %s", entry.id, variant.variant, outcome(False, seconds[key]))
    except BaseException:
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)
    return seconds


_SLOTS = None
"""The progress-bar lines free in this SAC worker process's pool (a queue; set by :func:`_start_trainer`)."""


def _start_trainer(slots) -> None:
    global _SLOTS
    start_worker()
    _SLOTS = slots


def _train_one(cache: Cache, task, settings, solved_return, force: bool, progress: bool) -> float:
    """One run of :func:`train_at_once` in its worker process: its seconds. Its progress bar takes a free line."""
    slot = _SLOTS.get()
    try:
        started = time.perf_counter()
        run_sac_stage(cache, task, settings, solved_return=solved_return, force=force, progress=progress,
                      bar_position=slot)
        return time.perf_counter() - started
    finally:
        _SLOTS.put(slot)


def sac_settings_from_config(node: Any):
    from taskcomplexity.rl.settings import SACSettings

    return build(SACSettings, node, "sac")


def study_sac_curves(
    cache: Cache, tasks: Sequence[tuple[Any, Any]], node: Any, *, force: bool = False, progress: bool = False,
    cached_only: bool = False,
) -> pd.DataFrame:
    """Every variant of the SAC protocol (SAC; + HER on sparse reaching tasks) for every study task, as one tidy table.

    Parameters
    ----------
    tasks : sequence of (StudyTask, Task)
        The study's entries and their composed tasks. Each run's budget is ``sac.total_steps`` when
        set, else the entry's ``sac_steps``; the entry's ``solved_return`` scores envs that report no
        success. The ``task`` column holds the entry's id.
    node : the ``sac`` config node.
    cached_only : bool
        Train nothing: the curves the cache holds for these settings (the ids of the tasks it lacks
        in ``frame.attrs["sac_missing"]``).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`taskcomplexity.rl.CURVE_COLUMNS`. Tasks SAC cannot run on (discrete actions) are
        left out, each logged once ("SAC skipped for <id>: discrete actions") and listed in
        ``frame.attrs["sac_skipped"]`` ({task id: reason}); when every task is skipped the frame is
        empty (with the columns).

    Raises
    ------
    ConfigError
        If a task has neither ``sac.total_steps`` nor ``sac_steps`` (checked for every task first).
    """
    import pandas as pd

    from taskcomplexity.rl import CURVE_COLUMNS, protocol_variants, sac_skip_reason, with_budget

    settings = sac_settings_from_config(node)
    skipped: dict[str, str] = {}
    runs, unbudgeted = [], []
    for entry, task in tasks:
        reason = sac_skip_reason(task)
        if reason is not None:
            skipped[entry.id] = reason
            continue
        if cached_only and settings.total_steps is None and entry.sac_steps is None:
            unbudgeted.append(entry.id)  # no budget, so no curve can be cached: missing, not an error
            continue
        budgeted = with_budget(settings, entry.sac_steps, task_id=entry.id)
        runs.append((entry, task, budgeted))
    for task_id, reason in skipped.items():
        log.warning("SAC skipped for %s: %s", task_id, reason)
    trained = {}
    if runs and not cached_only:
        workers = sac_workers(settings)
        log.info("%-26s %s", "sac", training_plan(cache, runs, workers))
        jobs = [(entry, task, variant) for entry, task, budgeted in runs
                for variant in protocol_variants(task, budgeted)]
        trained = train_at_once(cache, jobs, workers, force=force, progress=progress)
    frames, missing, actors, jobs = [], list(unbudgeted), {}, {}
    for entry, task, budgeted in runs:
        found = []
        for variant in protocol_variants(task, budgeted):
            key = run_key(entry, task, variant)
            if key in trained:  # trained at once with the others, and logged then
                artefact = cache.lookup(STAGE, key)
            else:
                started = time.perf_counter()
                artefact, hit = run_sac_stage(cache, task, variant, solved_return=entry.solved_return, force=force,
                                              progress=progress, cached_only=cached_only)
                if artefact is not None:
                    log.info("%-26s %s %s", entry.id, variant.variant, outcome(hit, time.perf_counter() - started))
            if artefact is None:
                break
            found.append(pd.read_parquet(artefact.file(CURVES)).assign(task=entry.id))
            jobs.setdefault(entry.id, []).extend(artefact.manifest.get("jobs", []))
            if variant.variant == "sac" and artefact.path.joinpath(ACTORS_FILE).exists():
                actors[entry.id] = (artefact.key, str(artefact.path / ACTORS_FILE))
        else:  # every variant of the task (a task's curves are shown whole or not at all)
            frames.extend(found)
            continue
        missing.append(entry.id)
    curves = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=list(CURVE_COLUMNS))
    curves.attrs[SKIPPED_ATTR] = skipped
    curves.attrs[MISSING_ATTR] = missing
    curves.attrs[ACTORS_ATTR] = actors
    curves.attrs[JOBS_ATTR] = jobs
    return curves


def _sac(work: StudyWork):
    """Learning curves of every task (None for a study of variants, and when the study gives no task a SAC
    budget and ``sac.total_steps`` is not set).

    With ``sac.enabled=false`` nothing is trained: the curves the cache holds for these settings are used,
    the tasks it lacks are listed in ``curves.attrs["sac_missing"]`` and the command that trains them in
    ``curves.attrs["sac_command"]``. Tasks SAC skips (discrete actions) are listed in
    ``curves.attrs["sac_skipped"]`` ({id: reason}).
    """
    plan, settings = work.plan, work.settings(STAGE)
    study = plan.study
    if study.kind == "variants":
        return None
    if not study.has_sac_budgets and settings.total_steps is None:
        log.info("SAC: study %s gives no SAC budget (sac_steps) to any task, so it has no SAC reference", study.name)
        return None
    tasks = [(entry, request.task) for entry, request in zip(plan.entries, plan.requests, strict=True)]
    curves = study_sac_curves(plan.cache, tasks, settings, force=plan.force, progress=work.progress,
                              cached_only=not settings.enabled)
    if not settings.enabled:
        curves.attrs["sac_command"] = plan.sac_command
        missing = curves.attrs.get(MISSING_ATTR) or []
        if missing:
            log.info("SAC not trained (sac.enabled=false); no cached curves for %d of %d tasks: %s",
                     len(missing), len(tasks), plan.sac_command)
    return curves


def _check_sac(settings: SACSettings, study, requests, typed: list[str]) -> None:
    if settings.entry is not None:
        raise ConfigError(f"sac.entry={settings.entry} is read by pipelines/sac.py (one study task's SAC runs, e.g. a "
                          "job of `make paper-jobs`); the study trains every task: drop it")
    if not settings.enabled or study.kind == "variants":
        return
    if not study.has_sac_budgets and settings.total_steps is None:
        enabled = [o for o in typed if o.partition("=")[0].lstrip("+~") == "sac.enabled"]
        if enabled:
            raise ConfigError(f"{enabled[-1]}: study {study.name} gives no SAC budget (sac_steps) to any task, so "
                              "it has no SAC reference; set sac.total_steps to train SAC on it")
        return
    for entry, request in zip(study.tasks, requests, strict=True):
        if sac_skip_reason(request.task) is None:
            budgeted = with_budget(settings, entry.sac_steps, task_id=entry.id)
            check_resources(request.task, budgeted)
    if settings.backend != OWN_ENV and not any(env_backend(r.task, settings) for r in requests):
        raise ConfigError(f"sac.backend={settings.backend} steps the environments of none of study {study.name}'s "
                          "tasks (they keep their own environments): drop it")


RECORD = Stage(STAGE, NUMERICS, (CURVES,), _sac, group="sac", settings=SACSettings, check=_check_sac,
               judged=Judged(CURVES, CURVES, on=SEEDS), order=40)
"""The SAC stage's record (:class:`~taskcomplexity.stages.stage.Stage`): the empirical reference."""
