"""The learning-path stage: a task's SAC actor snapshots → PIC and POIC around each, and their path means.

At every chosen snapshot θ_k of the trained SAC actor (``actors.npz`` of the SAC artefact: step 0
and every checkpoint), N policies θₙ = θ_k + σεₙ run M episodes each on the task's RWG backend, and
every registry metric of stage ``learning_path`` is estimated on the K return matrices
(:class:`~taskcomplexity.metrics.learning_path.LearningPath`), with the metrics stage's estimator
settings (POIC search, bootstrap) and its B unless ``learning_path.bins`` sets one: K snapshots × N × M
returns are far fewer than the study's, and at the study's B every return has a bin of its own, so PIC_k
sits at its ceiling ln N whatever the policies do.

Outputs under ``<cache>/learning_path/<key>/``:

- ``learning_path.parquet``: one row: ``policies``, ``episodes``, ``snapshots``, ``sigma``, every
  metric and ``<metric>_mean``, ``_sd``, ``_ci_low``, ``_ci_high`` of its bootstrap;
- ``path.parquet``: per snapshot: ``step`` and PIC_k, H(R), H(R|Θ), POIC_k, H(O), H(O|Θ);
- ``bootstrap.parquet``, ``batches.parquet``: as the metrics stage's.

The key hashes the task, the backend and what changes its episodes, the SAC artefact's key, the
settings, the estimator settings and the registry's signature of the stage.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from taskcomplexity.config import result_identity, setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages import metrics_stage, sac_stage
from taskcomplexity.stages.actor_stages import over_actor_tasks, trained_actors, unavailable_actors
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.metrics_stage import ESTIMATORS, MetricsSettings
from taskcomplexity.stages.rwg_stage import EPISODES, RWGRequest
from taskcomplexity.stages.stage import Judged, Stage, StudyWork

if TYPE_CHECKING:  # the estimators and pandas are imported by the functions that compute
    import pandas as pd

    from taskcomplexity.metrics.learning_path import LearningPath

STAGE = "learning_path"
NUMERICS = Numerics(version=2, modules=(*EPISODES, *ESTIMATORS, "rwg.given_policies", "rl.snapshots", "rl.layers",
                                      "metrics.learning_path", "metrics.policy_tables", "stages.metrics_stage",
                                      "stages.learning_path_stage"))
FILES = ("learning_path.parquet", "path.parquet", "bootstrap.parquet", "batches.parquet")


@dataclass(frozen=True)
class LearningPathSettings:
    """How the learning path is sampled (``conf/learning_path``).

    Attributes
    ----------
    enabled : bool
        Compute it for every task whose SAC artefact holds actor snapshots.
    every : int
        Use every ``every``-th snapshot (the last one always).
    sigma : float
        σ of the Gaussian perturbation of every actor parameter (> 0).
    policies, episodes : int
        N perturbed policies per snapshot, M episodes each.
    bins : int or None
        B of the histogram estimators at every snapshot (20: N·M/B = 50 returns per bin at the default N
        and M, the published scale's ratio; None: the metrics stage's B).
    batches : int
        Consecutive policy batches for the Welch tests (>= 2, at most N/2).
    seed : int
        Seed of the perturbations and of the episodes' reset states.
    seed_index : int
        Which SAC seed's actor (position in ``sac.seeds``).
    """

    enabled: bool = setting(True, result=False)
    every: int = 1
    sigma: float = 1.0
    policies: int = 100
    episodes: int = 10
    bins: int | None = 20
    batches: int = 5
    seed: int = 0
    seed_index: int = 0

    def validate(self) -> LearningPathSettings:
        for name, minimum in (("every", 1), ("episodes", 2), ("batches", 2)):
            if getattr(self, name) < minimum:
                raise ConfigError(f"learning_path.{name} must be an integer >= {minimum}, got {getattr(self, name)}")
        if self.policies < 2 * self.batches:
            raise ConfigError(f"learning_path.policies must be at least 2 × learning_path.batches = "
                              f"{2 * self.batches} (2 policies per batch), got {self.policies}")
        if self.bins is not None and self.bins < 2:
            raise ConfigError(f"learning_path.bins must be an integer >= 2 or null (metrics.bins), got {self.bins}")
        if not (self.sigma >= 0 and np.isfinite(self.sigma)):
            raise ConfigError(f"learning_path.sigma must be a finite number >= 0, got {self.sigma}")
        if self.seed < 0 or self.seed_index < 0:
            raise ConfigError(f"learning_path.seed and learning_path.seed_index must be >= 0, got {self.seed}, "
                              f"{self.seed_index}")
        return self

    def identity(self) -> dict:
        return result_identity(self)

    def estimators(self, metrics: MetricsSettings, policies: int, episodes: int) -> MetricsSettings:
        """The metrics stage's estimator settings, with this stage's B when it has one (else ``metrics.bins``
        resolved for this stage's N × M return matrices)."""
        chosen = metrics if self.bins is None else dataclasses.replace(metrics, bins=self.bins)
        return chosen.at_scale(policies, episodes)


def chosen_snapshots(count: int, every: int) -> list[int]:
    """Positions of the snapshots used: 0, every, 2·every, … and always the last."""
    return sorted({*range(0, count, every), count - 1})


def learning_path_key(request: RWGRequest, sac_key: str, settings: LearningPathSettings, metrics: MetricsSettings,
                      registry: Registry) -> str:
    from taskcomplexity.policies.tanh import NUMPY, implementation

    rwg = request.identity()
    kept = ("task", "backend", "simulator", "contacts", "common_initial_states")
    episodes = {k: v for k, v in rwg.items() if k in kept}
    if implementation() != NUMPY:  # the actors' tanh output, where its last bits are not NumPy's
        episodes["tanh"] = implementation()
    return stage_key(STAGE, NUMERICS, {"episodes": episodes, "sac": sac_key, **settings.identity(),
                                      "estimation": metrics.identity(), "metrics": registry.signature(STAGE)})


def compute_path(request: RWGRequest, actors_file: Path, settings: LearningPathSettings, metrics: MetricsSettings,
                 progress=None) -> LearningPath:
    """The K return matrices of the perturbed actors (the episodes are RWG's on ``request``'s backend)."""
    from taskcomplexity.metrics.learning_path import LearningPath
    from taskcomplexity.metrics.sample import Sample
    from taskcomplexity.rl.snapshots import ActorSnapshots
    from taskcomplexity.rwg.given_policies import run_policies

    snapshots = ActorSnapshots.load(actors_file)
    if settings.seed_index >= len(snapshots.seeds):
        raise ConfigError(f"learning_path.seed_index={settings.seed_index}, but SAC trained "
                          f"{len(snapshots.seeds)} seed(s): allowed 0 … {len(snapshots.seeds) - 1}")
    chosen = chosen_snapshots(len(snapshots.steps), settings.every)
    indices = np.arange(settings.policies)
    samples = []
    for k in chosen:
        policies = snapshots.around(k, sigma=settings.sigma, seed=settings.seed, indices=indices,
                                    seed_index=settings.seed_index)
        run = run_policies(request.task, policies, seed=settings.seed, episodes=settings.episodes,
                           backend=request.backend, common_initial_states=request.settings.common_initial_states,
                           contacts=request.settings.contacts)
        samples.append(Sample(run.returns, metrics.estimation()))
        if progress is not None:
            progress(settings.policies * settings.episodes)
    return LearningPath(snapshots.steps[chosen], tuple(samples))


def compute_tables(path: LearningPath, settings: LearningPathSettings, metrics: MetricsSettings, *,
                   registry: Registry = DEFAULT_REGISTRY) -> dict[str, pd.DataFrame]:
    """Every table of the stage (see the module docstring)."""
    import pandas as pd

    from taskcomplexity.metrics.policy_tables import policy_sample_tables

    estimation = metrics.estimation()
    row, draws, batches = policy_sample_tables(path, registry.of_stage(STAGE), policies=settings.policies,
                                               resamples=estimation.resamples, seed=estimation.bootstrap_seed,
                                               batches=settings.batches)
    row = {"policies": settings.policies, "episodes": settings.episodes, "snapshots": len(path.steps),
           "sigma": settings.sigma, **row}
    return {"learning_path.parquet": pd.DataFrame([row]), "path.parquet": path.curve(),
            "bootstrap.parquet": draws, "batches.parquet": batches}


def run_learning_path_stage(cache: Cache, request: RWGRequest, sac_key: str, actors_file: Path,
                            settings: LearningPathSettings, metrics: MetricsSettings, *, label: str = "",
                            registry: Registry = DEFAULT_REGISTRY, force: bool = False,
                            progress=None) -> tuple[Artefact, bool]:
    """Compute (or reuse) one task's learning path; returns (artefact, cache hit)."""
    settings.validate()
    metrics = settings.estimators(metrics, settings.policies, settings.episodes)
    key = learning_path_key(request, sac_key, settings, metrics, registry)

    def write(directory):
        path = compute_path(request, actors_file, settings, metrics, progress=progress)
        for name, table in compute_tables(path, settings, metrics, registry=registry).items():
            table.to_parquet(directory / name, index=False)
        return {"label": label}

    config = {**settings.identity(), "metrics": [m.name for m in registry.of_stage(STAGE)]}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs={"sac": sac_key}, force=force)


def study_learning_paths(cache: Cache, requests: Mapping[str, RWGRequest], actors: Mapping[str, tuple[str, Path]],
                         settings: LearningPathSettings, metrics: MetricsSettings, *,
                         registry: Registry = DEFAULT_REGISTRY, force: bool = False,
                         progress: bool = False, unavailable: Mapping[str, str] | None = None) -> dict[str, Artefact]:
    """The learning-path artefact of every task (id → artefact) with a trained SAC actor in ``actors``
    (task id → (SAC key, its ``actors.npz``); :func:`~taskcomplexity.stages.actor_stages.over_actor_tasks`)."""
    if not settings.enabled or not registry.of_stage(STAGE):
        return {}

    def episodes(task_id: str) -> int:
        with np.load(actors[task_id][1]) as data:
            snapshots = len(chosen_snapshots(len(data["steps"]), settings.every))
        return snapshots * settings.policies * settings.episodes

    def run(task_id, sac_key, actors_file, advance):
        return run_learning_path_stage(cache, requests[task_id], sac_key, actors_file, settings, metrics,
                                       label=task_id, registry=registry, force=force, progress=advance)

    return over_actor_tasks(STAGE, list(requests), actors, run, episodes=episodes, progress=progress,
                            unavailable=unavailable)


def _learning_path(work: StudyWork) -> dict:
    plan, curves = work.plan, work.done[sac_stage.STAGE]
    if curves is None:
        return {}
    return study_learning_paths(plan.cache, plan.tasks, trained_actors(curves), work.settings(STAGE),
                                work.settings(metrics_stage.STAGE), registry=work.registry, force=plan.force,
                                progress=work.progress, unavailable=unavailable_actors(curves))


RECORD = Stage(STAGE, NUMERICS, FILES, _learning_path, inputs=(sac_stage.STAGE,), group="learning_path",
               settings=LearningPathSettings, judged=Judged("learning_path.parquet"),
               missing=("it needs the snapshots of a SAC run for each task (SAC on: `make beyond`, a fifth of the "
                        "budgets in about an hour; `make paper`; or `sac.enabled=true`)"), order=60)
"""The learning-path stage's record (:class:`~taskcomplexity.stages.stage.Stage`)."""
