"""The RWG stage: (task, network, prior, N, M, seed, backend) → ``returns.parquet`` in the cache.

Work is split into chunks of policies; each finished chunk is saved under the key's scratch
directory, so an interrupted run resumes from its completed chunks. With ``shards > 1`` this job
computes one policy range; whichever job finds every shard present merges them into the artefact a
single job would have written (same key, same returns).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import shutil
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from taskcomplexity.config import canonical, result_identity
from taskcomplexity.errors import ArtefactError, ConfigError
from taskcomplexity.jobs import JobMeter, saved_records
from taskcomplexity.rwg.backends import AUTO, BACKENDS, refuse_workers, resolve_backend
from taskcomplexity.rwg.settings import RWGSettings
from taskcomplexity.stages.cache import Artefact, Cache, remove_orphans, waiting_lock
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.resources import refuse_beyond_disk, refuse_beyond_memory
from taskcomplexity.stages.stage import Stage, StudyWork
from taskcomplexity.stages.stage_log import each_task

if TYPE_CHECKING:  # the backends, the policy families and pandas are imported by the functions that run them
    import pandas as pd

    from taskcomplexity.policies.families import FamilySpec
    from taskcomplexity.policies.mlp import PriorSpec
    from taskcomplexity.progress import Progress
    from taskcomplexity.rwg.chunking import ReturnChunk
    from taskcomplexity.tasks.base import Task

log = logging.getLogger(__name__)

STAGE = "rwg"
EPISODES = (
    "policies.mlp", "policies.tanh", "policies.tanh_kernel", "policies.primitives", "policies.movement_primitives",
    "seeding",
    "rwg", "rwg.settings", "rwg.backends", "rwg.chunking", "rwg.run", "rwg.batch", "rwg.arm_resets",
    *dict.fromkeys(b.runner.partition(":")[0].removeprefix("taskcomplexity.") for b in BACKENDS.values()),
    "tasks.base", "tasks.spec", "tasks.mechanics", "tasks.rewards", "tasks.reward_kinds", "tasks.urdf", "tasks.batched",
    "tasks.dynamics", "tasks.contact", "tasks.step_kernel", "tasks.rollout_kernel", "tasks.pybullet_env",
    "tasks.gym_task", "tasks.classic", "tasks.classic.kernels", "tasks.classic.resets", "tasks.envpool_ids",
    "tasks.vectorised", "tasks.manipulation",
)
"""The modules that make a task's episodes under a batch of sampled policies: the policy families and their
sampling, the physics and reward kernels, the PyBullet and gymnasium envs, the backends that step them (each
registered backend's module, read from :data:`taskcomplexity.rwg.backends.BACKENDS`)."""
NUMERICS = Numerics(version=1, modules=(*EPISODES, "stages.rwg_stage"))
RETURNS = "returns.parquet"


@dataclass(frozen=True)
class RWGRequest:
    """Everything that determines a return matrix (plus how to split the work).

    ``backend`` is resolved when the request is made: ``auto`` (the default) becomes the task's fastest exact
    backend for the network's family, and a backend the task does not have is refused (ConfigError naming
    ``backend``), so a request always holds the backend that will run it.
    """

    task: Task
    network: FamilySpec
    prior: PriorSpec
    settings: RWGSettings
    backend: str = AUTO

    def __post_init__(self) -> None:
        from taskcomplexity.policies.mlp import NetworkSpec

        object.__setattr__(self, "backend", resolve_backend(self.task, str(self.backend), self.network))
        if self.settings.precision != "float64":
            if self.settings.precision not in BACKENDS[self.backend].precisions or not isinstance(self.network,
                                                                                                   NetworkSpec):
                fused = ", ".join(b.name for b in BACKENDS.values() if self.settings.precision in b.precisions)
                raise ConfigError(f"rwg.precision={self.settings.precision} is the MLP forward pass of the {fused} "
                                  f"backend; {self.task.task_id} runs backend={self.backend} with "
                                  f"network.family={getattr(self.network, 'family', 'mlp')} (allowed there: float64)")
            if self.task.arm.obstacle is not None:  # like rwg.contacts off the obstacle task: not this task's setting
                log.debug("%s: the forward pass stays float64 under rwg.precision=%s (the block's contacts are "
                          "chaotic: rounded actions would draw another sample of its returns)", self.task.task_id,
                          self.settings.precision)
                object.__setattr__(self, "settings", dataclasses.replace(self.settings, precision="float64"))

    def identity(self) -> dict:
        """What the key hashes: the task, the sampler, the backend and the RWG settings declared to change
        the returns (``config.setting``: sharding and chunking do not).

        The contact handling is dropped where it cannot change the returns (every task but the obstacle
        task on the batched backend), so those tasks' keys do not depend on it.
        """
        identity = {
            "task": self.task.identity(),
            "network": canonical(self.network.identity()),
            "prior": canonical(self.prior.identity()),
            "backend": self.backend,
            **result_identity(self.settings),
        }
        identity.update(BACKENDS[self.backend].key_fields())  # e.g. EnvPool's own MuJoCo build and reset generator
        if not self.models_contacts:
            identity.pop("contacts")
        if self.settings.precision == "float64":  # the keys from before the setting existed
            identity.pop("precision")
        return identity

    @property
    def models_contacts(self) -> bool:
        """Whether the obstacle's contacts come from the batched contact model rather than PyBullet."""
        arm = getattr(self.task, "arm", None)
        return arm is not None and arm.obstacle is not None and BACKENDS[self.backend].contact_model \
            and self.settings.contacts == "model"

    @property
    def key(self) -> str:
        return stage_key(STAGE, NUMERICS, self.identity())

    @property
    def label(self) -> str:
        s = self.settings
        contacts = " contact-model" if self.models_contacts else ""
        precision = f" {s.precision}" if s.precision != "float64" else ""
        # An env's constructor arguments tell apart two tasks of one env id (e.g. Pendulum-v1 at two gravities).
        kwargs = dict(sorted(getattr(self.task, "kwargs", {}).items()))
        arguments = "(" + ", ".join(f"{k}={v}" for k, v in kwargs.items()) + ")" if kwargs else ""
        return (f"{self.task.task_id}{arguments} {self.network.tag} {self.prior.kind} N={s.policies} M={s.episodes} "
                f"seed={s.seed}{contacts}{precision}")


def _chunk_file(scratch: Path, start: int, stop: int) -> Path:
    return scratch / f"chunk-{start:07d}-{stop:07d}.npz"


def _save_chunk(path: Path, chunk: ReturnChunk) -> None:
    tmp = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")
    np.savez(tmp, policy=chunk.policy, returns=chunk.returns, steps=chunk.steps, success=chunk.success,
             handoffs=np.int64(chunk.handoffs), contacts=np.int64(chunk.contacts))
    tmp.replace(path)


def _load_chunk(path: Path) -> ReturnChunk | None:
    from taskcomplexity.rwg.chunking import ReturnChunk

    try:
        with np.load(path) as z:
            return ReturnChunk(z["policy"], z["returns"], z["steps"], z["success"], int(z["handoffs"]),
                               int(z["contacts"]))
    except Exception as err:  # noqa: BLE001 - a damaged chunk is recomputed
        log.warning("discarding unreadable chunk %s (%s)", path, err)
        path.unlink(missing_ok=True)
        return None


def _shard_file(scratch: Path, shard: int, shards: int) -> Path:
    return scratch / f"shard-{shard:04d}-of-{shards:04d}.npz"


def compute_shard(cache: Cache, request: RWGRequest, shard: int, *, progress: Progress = False,
                  scratch: Path | None = None) -> ReturnChunk:
    """Compute (or reuse) one shard's returns, resuming from chunks saved in ``scratch``.

    ``scratch`` defaults to the key's shared partial-work directory (``Cache.scratch``).
    """
    from taskcomplexity.rwg import chunks, run_rwg

    settings = RWGSettings(**{**asdict(request.settings), "shard": shard})
    scratch = scratch or cache.scratch(STAGE, request.key)
    remove_orphans(scratch, "*.tmp.npz")  # half-written chunks of killed jobs
    shard_path = _shard_file(scratch, shard, settings.shards)
    if shard_path.exists():
        done = _load_chunk(shard_path)
        if done is not None:
            return done
    completed = {}
    for start, stop in chunks(request.task, request.network, settings, request.backend):
        path = _chunk_file(scratch, start, stop)
        if path.exists() and (chunk := _load_chunk(path)) is not None:
            completed[(start, stop)] = chunk
    if completed:
        log.info("resuming %s from %d saved chunks", request.label, len(completed))
    part = f"shard {shard} of {settings.shards}" if settings.shards > 1 else "all"
    meter = JobMeter(part, reused=sum(len(chunk.policy) for chunk in completed.values()))

    def on_chunk(key: tuple[int, int], chunk: ReturnChunk) -> None:
        _save_chunk(_chunk_file(scratch, *key), chunk)
        meter.units += len(chunk.policy)
        meter.save(scratch)  # a job killed later still leaves the record of the work it saved

    result = run_rwg(request.task, request.network, request.prior, settings, request.backend,
                     completed=completed, on_chunk=on_chunk, progress=progress)
    meter.save(scratch)  # the final record: with the CPU of the pool's workers, which have ended
    _save_chunk(shard_path, result)
    for start, stop in chunks(request.task, request.network, settings, request.backend):
        _chunk_file(scratch, start, stop).unlink(missing_ok=True)
    return result


def missing_shards(cache: Cache, request: RWGRequest, scratch: Path | None = None) -> list[int]:
    scratch = scratch or cache.scratch(STAGE, request.key)
    shards = request.settings.shards
    return [i for i in range(shards) if not _shard_file(scratch, i, shards).exists()]


def returns_frame(chunk: ReturnChunk) -> pd.DataFrame:
    """Tidy table: one row per (policy, episode)."""
    import pandas as pd

    n_pol, n_ep = chunk.returns.shape
    return pd.DataFrame(
        {
            "policy": np.repeat(chunk.policy.astype(np.int32), n_ep),
            "episode": np.tile(np.arange(n_ep, dtype=np.int32), n_pol),
            "return": chunk.returns.ravel(),
            "steps": chunk.steps.ravel().astype(np.int16),
            "success": chunk.success.ravel(),
        }
    )


def _shard_lock(cache: Cache, request: RWGRequest, shard: int):
    directory = cache.root / STAGE
    directory.mkdir(parents=True, exist_ok=True)
    return waiting_lock(directory / f".{request.key}.shard-{shard}.lock",
                        f"shard {shard} of rwg {request.key} ({request.label})")


def _ensure_shard(cache: Cache, request: RWGRequest, shard: int, *, progress: Progress) -> bool:
    """Compute one shard under its lock unless it (or the whole artefact) already exists.

    Returns False when the merged artefact appeared meanwhile (a concurrent job finished it).
    """
    with _shard_lock(cache, request, shard):
        if cache.lookup(STAGE, request.key, request.identity()) is not None:
            return False
        compute_shard(cache, request, shard, progress=progress)
    return True


BYTES_IN_MEMORY_PER_EPISODE = 64
"""Peak resident bytes per episode while a shard is merged into the tidy table (arrays + frame + writer)."""
BYTES_ON_DISK_PER_EPISODE = 48
"""Peak disk use per episode: saved chunks and the shard file (17 B each, uncompressed) and the parquet artefact."""


def check_memory(request: RWGRequest) -> None:
    """Refuse, before any work, a run whose memory need is beyond this machine, with the estimate: its tidy table,
    and one chunk's working memory on a backend that steps a chunk's P × M episodes at once
    (:attr:`~taskcomplexity.rwg.backends.Backend.steps_at_once`, each episode holding
    :meth:`~taskcomplexity.policies.families.FamilySpec.working_floats`), which an explicit ``rwg.chunk_policies``
    sets instead of ``rwg.chunk_memory_mb``; the others keep a bounded number of environments in flight."""
    from taskcomplexity.rwg.chunking import chunk_size

    settings = request.settings
    episodes = settings.policies * settings.episodes
    what = f"rwg.policies × rwg.episodes = {settings.policies:,} × {settings.episodes:,}"
    refuse_beyond_memory(episodes * BYTES_IN_MEMORY_PER_EPISODE, what, "lower N or M")
    if not BACKENDS[request.backend].steps_at_once:
        return
    start, stop = settings.shard_range()
    policies = min(chunk_size(request.task, request.network, settings, request.backend), stop - start)
    task = request.task
    need = policies * settings.episodes * 8 * request.network.working_floats(task.observation_size,
                                                                             task.action_size, task.max_steps)
    key = (f"rwg.chunk_policies={settings.chunk_policies}" if settings.chunk_policies
           else f"rwg.chunk_memory_mb={settings.chunk_memory_mb}")
    what = (f"{key} ({policies:,} policies × {settings.episodes:,} episodes stepped at once on the {request.backend} "
            "backend)")
    advice = "lower it" + (", or 0: chunks sized from rwg.chunk_memory_mb" if settings.chunk_policies else "")
    refuse_beyond_memory(need, what, advice)


def check_plan(cache: Cache, request: RWGRequest) -> None:
    """Refuse, before any work, a run whose memory or disk need is beyond this machine, with the estimate."""
    check_memory(request)
    episodes = request.settings.policies * request.settings.episodes
    what = f"rwg.policies × rwg.episodes = {request.settings.policies:,} × {request.settings.episodes:,}"
    refuse_beyond_disk(episodes * BYTES_ON_DISK_PER_EPISODE, what, cache.root)


def _compute_shards(cache: Cache, request: RWGRequest, scratch: Path, *, force: bool, progress: Progress,
                    compute_missing: bool) -> list[int]:
    """Compute this job's shard into ``scratch`` (every shard with ``force``, or with ``compute_missing``
    those no other job has saved); the shards still missing."""
    if force:
        # Recompute every shard in a scratch directory of this process's own, so that a job computing
        # the same key meanwhile is never pulled out from under its feet; the artefact replaces the old
        # one under the key's lock.
        for shard in range(request.settings.shards):
            compute_shard(cache, request, shard, progress=progress, scratch=scratch)
        return []
    _ensure_shard(cache, request, request.settings.shard, progress=progress)
    missing = missing_shards(cache, request) if cache.lookup(STAGE, request.key, request.identity()) is None else []
    if missing and not compute_missing:
        return missing
    for shard in missing:
        _ensure_shard(cache, request, shard, progress=progress)
    return []


def _discard_partial_work(cache: Cache, key: str, scratch: Path) -> None:
    """Remove the scratch directory and the shard locks of ``key`` (an env refused mid-run)."""
    shutil.rmtree(scratch, ignore_errors=True)
    for lock in (cache.root / STAGE).glob(f".{key}.shard-*.lock"):
        lock.unlink(missing_ok=True)


def _remove_if_empty(scratch: Path) -> None:
    """Remove the scratch directory of a failed run when it holds no saved work (``rmdir`` refuses a directory
    another job has meanwhile saved a chunk into)."""
    with contextlib.suppress(OSError):
        scratch.rmdir()


def run_rwg_stage(
    cache: Cache,
    request: RWGRequest,
    *,
    force: bool = False,
    progress: Progress = False,
    compute_missing: bool = True,
) -> tuple[Artefact | None, bool]:
    """Produce the returns artefact of ``request`` (or this job's shard of it).

    Concurrent jobs on the same key are safe: each shard is computed under its own file lock (a
    second job waits, then reuses it), and the merge runs under the key's lock in the cache.

    Returns
    -------
    (artefact, hit)
        ``artefact`` is None when this job finished its shard but others are still missing and
        ``compute_missing`` is False.
    """
    from pkgutil import resolve_name

    from taskcomplexity.rwg.env_checks import EnvContractError

    request.settings.validate()
    key = request.key
    if not force and (found := cache.lookup(STAGE, key, request.identity())) is not None:
        log.info("cache hit: rwg %s (%s) at %s", key, request.label, found.path)
        return found, True
    cache.require_writable(STAGE, key)
    check = BACKENDS[request.backend].check  # on a backend that runs a researcher's own env code
    if check is not None:
        resolve_name(check)(request.task, request.settings.seed)  # before anything is created under the cache
    check_plan(cache, request)
    started = time.time()
    shards = request.settings.shards
    scratch = cache.scratch(STAGE, f"{key}-force-{os.getpid()}" if force else key)
    try:
        missing = _compute_shards(cache, request, scratch, force=force, progress=progress,
                                  compute_missing=compute_missing)
    except EnvContractError:
        _discard_partial_work(cache, key, scratch)  # the env, not the run, failed: nothing of it is kept
        raise
    except BaseException:  # the env raised, a bug, Ctrl-C: saved chunks of completed work stay for the rerun
        _remove_if_empty(scratch)
        raise
    if missing:
        log.info("shard %d/%d of %s done; still missing shards %s", request.settings.shard, shards,
                 request.label, missing)
        return None, False

    def write(directory: Path) -> dict:
        from taskcomplexity.rwg.chunking import ReturnChunk

        parts = [_load_chunk(_shard_file(scratch, i, shards)) for i in range(shards)]
        if any(p is None for p in parts):
            raise ArtefactError(f"rwg {key}: a shard became unreadable while merging; rerun to recompute it")
        merged = ReturnChunk.concatenate(parts)
        returns_frame(merged).to_parquet(directory / RETURNS, index=False)
        return {
            "label": request.label,
            "policies": request.settings.policies,
            "episodes": request.settings.episodes,
            "seed": request.settings.seed,
            "backend": request.backend,
            "env_steps": int(merged.steps.sum()),
            "handoffs": merged.handoffs,
            "contacts": "model" if request.models_contacts else "pybullet",
            "modelled_contact_episodes": merged.contacts,
            "compute_seconds": round(time.time() - started, 3),
            "jobs": saved_records(scratch),
        }

    def cleanup() -> None:
        shutil.rmtree(scratch, ignore_errors=True)

    return cache.get_or_compute(STAGE, key, write, config=request.identity(), force=force, after=cleanup)


def load_returns(artefact: Artefact) -> np.ndarray:
    """The (N, M) return matrix of an RWG artefact."""
    import pandas as pd

    frame = pd.read_parquet(artefact.file(RETURNS), columns=["policy", "episode", "return"])
    n_pol = int(frame["policy"].max()) + 1
    n_ep = int(frame["episode"].max()) + 1
    if len(frame) != n_pol * n_ep:
        raise ArtefactError(f"{artefact.file(RETURNS)}: {len(frame)} rows, expected {n_pol} × {n_ep}")
    matrix = np.empty((n_pol, n_ep))
    matrix[frame["policy"].to_numpy(), frame["episode"].to_numpy()] = frame["return"].to_numpy()
    return matrix


def study_returns(cache: Cache, requests: Mapping[str, RWGRequest], *, force: bool = False,
                  progress: bool = False) -> dict[str, Artefact]:
    """The RWG artefact of every task (study id → request), in order; with ``progress``, one bar over the
    episodes of the tasks whose artefact is not cached yet (a cheap existence test; the stage verifies)."""

    def episodes(name: str, request: RWGRequest) -> int:
        cached = not force and cache.path(STAGE, request.key).exists()
        return 0 if cached else request.settings.policies * request.settings.episodes

    def run(name: str, request: RWGRequest, bar) -> tuple[Artefact, bool]:
        return run_rwg_stage(cache, request, force=force, progress=bar or False)

    return each_task(STAGE, requests, run, work=episodes, progress=progress)


def _returns(work: StudyWork) -> dict:
    plan = work.plan
    return study_returns(plan.cache, plan.tasks, force=plan.force, progress=work.progress)


def _check_rwg(settings: RWGSettings, study, requests, typed) -> None:
    refuse_workers(settings.workers, [r.backend for r in requests], f"study {study.name}")
    for request in requests:
        check_memory(request)


RECORD = Stage(STAGE, NUMERICS, (RETURNS,), _returns, group="rwg", settings=RWGSettings, check=_check_rwg, order=10)
"""The RWG stage's record (:class:`~taskcomplexity.stages.stage.Stage`): the first of a study's chain."""
