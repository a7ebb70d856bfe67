"""The SAC stage: (task, SAC settings, variant, seed group) → ``curves.parquet`` in the cache.

A run's checkpoints live in the key's scratch directory, so an interrupted run resumes from its last
checkpoint (exactly: see ``taskcomplexity.rl``); the curve is written atomically when it finishes.
The seeds of a task train together, and a seed's curve depends on its group, so the key hashes the
whole seed group.
"""

from __future__ import annotations

import logging
import shutil
from typing import Any

import pandas as pd

from taskcomplexity.config import build
from taskcomplexity.pipeline.cache import Artefact, Cache
from taskcomplexity.pipeline.keys import canonical, stage_key
from taskcomplexity.tasks.spec import TaskSpec

log = logging.getLogger(__name__)

STAGE = "sac"
VERSION = 1
CURVES = "curves.parquet"
# Settings that do not change the curve, left out of the key.
NOT_IN_KEY = ("enabled", "num_threads", "checkpoint_every")


def sac_identity(task: TaskSpec, settings) -> dict:
    values = canonical(settings)
    return {"task": canonical(task), "settings": {k: v for k, v in values.items() if k not in NOT_IN_KEY}}


def run_sac_stage(
    cache: Cache, task: TaskSpec, settings, *, force: bool = False, progress: bool = False
) -> tuple[Artefact, bool]:
    """Train (or reuse) one SAC variant of ``task`` over its seed group."""
    from taskcomplexity.rl import train_sac_seeds

    identity = sac_identity(task, settings)
    key = stage_key(STAGE, VERSION, identity)
    variant = "sac+her" if settings.her else "sac"

    def write(directory) -> dict:
        scratch = cache.scratch(STAGE, key)
        curves = train_sac_seeds(task, settings, checkpoint_dir=scratch, progress=progress)
        curves.to_parquet(directory / CURVES, index=False)
        return {"label": f"{task.task_id} {variant} seeds={list(settings.seeds)}", "variant": variant}

    def cleanup() -> None:
        shutil.rmtree(cache.root / STAGE / f".partial-{key}", ignore_errors=True)

    return cache.get_or_compute(STAGE, key, write, config=identity, force=force, after=cleanup)


def sac_settings_from_config(node: Any):
    from taskcomplexity.rl.settings import SACSettings

    return build(SACSettings, node, "sac")


def study_sac_curves(
    cache: Cache, tasks: list[TaskSpec], node: Any, *, force: bool = False, progress: bool = False
) -> pd.DataFrame:
    """Every variant of sac.md (SAC; + HER on sparse tasks) for every task, as one tidy table."""
    from taskcomplexity.rl.settings import protocol_variants

    settings = sac_settings_from_config(node)
    frames = []
    for task in tasks:
        for variant in protocol_variants(task, settings):
            artefact, hit = run_sac_stage(cache, task, variant, force=force, progress=progress)
            name = "sac+her" if variant.her else "sac"
            log.info("sac %s %s: %s", task.task_id, name, "cache hit" if hit else "trained")
            frames.append(pd.read_parquet(artefact.file(CURVES)))
    return pd.concat(frames, ignore_index=True)


