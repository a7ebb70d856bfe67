"""The occupancy stage: a task's random policies and its trained SAC actor → occupancy distances.

For the first K random policies of the task's RWG sample (the same weights, from the same seed) and
for the final SAC actor of every seed (the reference, "optimal" policy), the state–action pairs of E
episodes each are recorded on the task's env (:mod:`taskcomplexity.rwg.occupancy`); each random
policy's distance to the reference is the W₂ distance of :mod:`taskcomplexity.metrics.occupancy`.
Every registry metric of stage ``occupancy`` is estimated on those K distances.

Outputs under ``<cache>/occupancy/<key>/``:

- ``occupancy.parquet``: one row: ``policies``, ``episodes``, ``pairs``, every metric and its details,
  and ``<metric>_mean``, ``_sd``, ``_ci_low``, ``_ci_high`` of each bootstrapped metric;
- ``distances.parquet``: ``policy`` (sampling index n), ``distance``;
- ``bootstrap.parquet``: the bootstrap draws (policies resampled);
- ``batches.parquet``: each batched metric on consecutive policy batches (the Welch tests' samples).

The key hashes the RWG request's identity (task, network, prior, seed: the random policies), the SAC
artefact's key (the reference actor), the settings and the registry's signature of the stage.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from taskcomplexity.config import result_identity, setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.policies.mlp import sample_policies
from taskcomplexity.seeding import derive_seed
from taskcomplexity.stages import sac_stage
from taskcomplexity.stages.actor_stages import over_actor_tasks, trained_actors, unavailable_actors
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.metrics_stage import ESTIMATORS
from taskcomplexity.stages.rwg_stage import EPISODES, RWGRequest
from taskcomplexity.stages.stage import Judged, Stage, StudyWork

if TYPE_CHECKING:  # the estimators and pandas are imported by the functions that compute
    import pandas as pd

STAGE = "occupancy"
NUMERICS = Numerics(version=1, modules=(*EPISODES, *ESTIMATORS, "rwg.occupancy", "rl.snapshots", "rl.layers",
                                      "metrics.occupancy", "metrics.policy_tables", "stages.occupancy_stage"))
FILES = ("occupancy.parquet", "distances.parquet", "bootstrap.parquet", "batches.parquet")


@dataclass(frozen=True)
class OccupancySettings:
    """How the occupancy distance is sampled (``conf/occupancy``).

    Attributes
    ----------
    enabled : bool
        Compute it for every task whose SAC artefact holds actor snapshots.
    policies : int
        K: random policies measured, the first K of the RWG sample (>= 2·batches).
    episodes : int
        E: episodes recorded per random policy and per SAC seed.
    pairs : int
        At most this many state–action pairs per policy (and per SAC seed), evenly thinned.
    resamples : int
        Bootstrap resamples of the K policies.
    batches : int
        Consecutive policy batches for the Welch tests (>= 2).
    seed : int
        Seed of the bootstrap.
    """

    enabled: bool = setting(True, result=False)
    policies: int = 100
    episodes: int = 5
    pairs: int = 250
    resamples: int = 1000
    batches: int = 5
    seed: int = 0

    def validate(self) -> OccupancySettings:
        for name, minimum in (("episodes", 1), ("pairs", 1), ("resamples", 1), ("batches", 2)):
            value = getattr(self, name)
            if value < minimum:
                raise ConfigError(f"occupancy.{name} must be an integer >= {minimum}, got {value}")
        if self.policies < 2 * self.batches:
            raise ConfigError(f"occupancy.policies must be at least 2 × occupancy.batches = {2 * self.batches} "
                              f"(2 policies per batch), got {self.policies}")
        if self.seed < 0:
            raise ConfigError(f"occupancy.seed must be a non-negative integer, got {self.seed}")
        return self

    def identity(self) -> dict:
        return result_identity(self)


def occupancy_key(request: RWGRequest, sac_key: str, settings: OccupancySettings, registry: Registry) -> str:
    """Cache key: the random policies (task, network, prior, seed), the SAC actor, settings and metrics."""
    sampler = {k: v for k, v in request.identity().items() if k in ("task", "network", "prior", "seed")}
    return stage_key(STAGE, NUMERICS, {"policies": sampler, "sac": sac_key, **settings.identity(),
                                      "metrics": registry.signature(STAGE)})


def compute_distances(request: RWGRequest, actors_file: Path, settings: OccupancySettings,
                      progress=None) -> tuple[np.ndarray, int]:
    """(distances (K,), pairs of the reference) of the first K random policies of ``request``."""
    from taskcomplexity.metrics.occupancy import occupancy_distances
    from taskcomplexity.rl.snapshots import ActorSnapshots
    from taskcomplexity.rwg.occupancy import record_occupancies

    task = request.task
    seed = int(request.settings.seed)
    indices = np.arange(settings.policies)
    policies = sample_policies(request.network, request.prior, task.observation_size, task.action_size, seed,
                               indices)
    random_pairs = record_occupancies(task, policies, seed=seed, episodes=settings.episodes, pairs=settings.pairs,
                                      progress=progress)
    actors = ActorSnapshots.load(actors_file).policies()  # the trained actor of every seed
    reference = np.concatenate(record_occupancies(task, actors, seed=derive_seed(seed, "occupancy reference"),
                                                  episodes=settings.episodes, pairs=settings.pairs))
    return occupancy_distances(random_pairs, reference), len(reference)


def compute_tables(distances: np.ndarray, settings: OccupancySettings, *, episodes: int, reference_pairs: int,
                   registry: Registry = DEFAULT_REGISTRY) -> dict[str, pd.DataFrame]:
    """Every table of the stage from the K distances (see the module docstring)."""
    import pandas as pd

    from taskcomplexity.metrics.occupancy import OccupancySample
    from taskcomplexity.metrics.policy_tables import policy_sample_tables

    distances = np.asarray(distances, dtype=np.float64)
    row, draws, batches = policy_sample_tables(OccupancySample(distances), registry.of_stage(STAGE),
                                               policies=len(distances), resamples=settings.resamples,
                                               seed=settings.seed, batches=settings.batches)
    row = {"policies": len(distances), "episodes": episodes, "reference_pairs": reference_pairs, **row}
    return {
        "occupancy.parquet": pd.DataFrame([row]),
        "distances.parquet": pd.DataFrame({"policy": np.arange(len(distances)), "distance": distances}),
        "bootstrap.parquet": draws,
        "batches.parquet": batches,
    }


def run_occupancy_stage(cache: Cache, request: RWGRequest, sac_key: str, actors_file: Path,
                        settings: OccupancySettings, *, label: str = "", registry: Registry = DEFAULT_REGISTRY,
                        force: bool = False, progress=None) -> tuple[Artefact, bool]:
    """Compute (or reuse) one task's occupancy distances; returns (artefact, cache hit)."""
    settings.validate()
    key = occupancy_key(request, sac_key, settings, registry)

    def write(directory):
        distances, reference_pairs = compute_distances(request, actors_file, settings, progress=progress)
        tables = compute_tables(distances, settings, episodes=settings.episodes, reference_pairs=reference_pairs,
                                registry=registry)
        for name, table in tables.items():
            table.to_parquet(directory / name, index=False)
        return {"label": label}

    config = {**settings.identity(), "metrics": [m.name for m in registry.of_stage(STAGE)]}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs={"sac": sac_key}, force=force)


def study_occupancy(cache: Cache, requests: Mapping[str, RWGRequest], actors: Mapping[str, tuple[str, Path]],
                    settings: OccupancySettings, *, registry: Registry = DEFAULT_REGISTRY, force: bool = False,
                    progress: bool = False, unavailable: Mapping[str, str] | None = None) -> dict[str, Artefact]:
    """The occupancy artefact of every task (id → artefact) that has a trained SAC actor in ``actors``
    (task id → (SAC key, its ``actors.npz``); :func:`~taskcomplexity.stages.actor_stages.over_actor_tasks`,
    which logs why each other task has none, from ``unavailable``)."""
    if not settings.enabled or not registry.of_stage(STAGE):
        return {}

    def run(task_id, sac_key, actors_file, advance):
        return run_occupancy_stage(cache, requests[task_id], sac_key, actors_file, settings, label=task_id,
                                   registry=registry, force=force, progress=advance)

    return over_actor_tasks(STAGE, list(requests), actors, run, progress=progress,
                            episodes=lambda _: settings.policies * settings.episodes,
                            unavailable=unavailable)


SAC_NEEDED = ("it needs a trained SAC actor for each task (SAC on: `make beyond`, a fifth of the budgets in about "
              "an hour; `make paper`; or `sac.enabled=true`)")


def _occupancy(work: StudyWork) -> dict:
    plan, curves = work.plan, work.done[sac_stage.STAGE]
    if curves is None:
        return {}
    return study_occupancy(plan.cache, plan.tasks, trained_actors(curves), work.settings(STAGE), registry=work.registry,
                           force=plan.force, progress=work.progress, unavailable=unavailable_actors(curves))


RECORD = Stage(STAGE, NUMERICS, FILES, _occupancy, inputs=(sac_stage.STAGE,), group="occupancy",
               settings=OccupancySettings, judged=Judged("occupancy.parquet"), missing=SAC_NEEDED, order=50)
"""The occupancy stage's record (:class:`~taskcomplexity.stages.stage.Stage`)."""
