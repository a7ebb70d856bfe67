"""The primitives stage: PIC and POIC of every study task under the movement-primitive family (``network=dmp``).

The paper's first proposal asks whether PIC and POIC judge tasks better under a policy family with
an inductive bias for reaching. For each task this stage runs RWG with the family of
``primitives.network`` (``conf/network/dmp.yaml``) and ``primitives.prior``, through the RWG stage
(its own cached, resumable artefact, on the task's batched or PyBullet backend, with the study's seed,
contact handling and common-initial-states choice), and estimates every registry metric of stage
``primitives`` on the return matrix with the metrics stage's estimators.

Outputs under ``<cache>/primitives/<key>/``:

- ``primitives.parquet``: one row: ``policies``, ``episodes``, every metric and its details, and
  ``<metric>_mean``, ``_sd``, ``_ci_low``, ``_ci_high`` of its bootstrap;
- ``bootstrap.parquet``, ``batches.parquet``: as the metrics stage's.

The key hashes the family's RWG key, the estimator settings and the registry's signature of the stage.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from taskcomplexity.config import build, setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.policies.families import network_from_config
from taskcomplexity.policies.mlp import PriorSpec
from taskcomplexity.policies.primitives import PrimitiveSpec
from taskcomplexity.rwg.backends import AUTO, family_backends
from taskcomplexity.stages import metrics_stage, rwg_stage
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.metrics_stage import ESTIMATORS, MetricsSettings
from taskcomplexity.stages.rwg_stage import RWGRequest, load_returns, run_rwg_stage
from taskcomplexity.stages.stage import Judged, Stage, StudyWork
from taskcomplexity.stages.stage_log import each_task

if TYPE_CHECKING:  # the estimators and pandas are imported by the functions that compute
    import pandas as pd

STAGE = "primitives"
NUMERICS = Numerics(version=2, modules=(*ESTIMATORS, "metrics.policy_tables", "stages.metrics_stage",
                                      "stages.primitives_stage"))
FILES = ("primitives.parquet", "bootstrap.parquet", "batches.parquet")


@dataclass(frozen=True)
class PrimitivesSettings:
    """What the stage samples (``conf/primitives``).

    Attributes
    ----------
    enabled : bool
        Compute it for every study task that is a reaching arm.
    policies, episodes : int or None
        N and M under the family (None: the study's RWG N and M).
    bins : int or None
        B of the histogram estimators (None: the metrics stage's B).
    batches : int
        Consecutive policy batches for the Welch tests (>= 2, at most N/2).
    network : PrimitiveSpec
        The family (``primitives.network``; the defaults of ``conf/network/dmp.yaml``).
    prior : PriorSpec
        The prior of its weights.
    """

    enabled: bool = setting(True, result=False)
    policies: int | None = None
    episodes: int | None = None
    bins: int | None = None
    batches: int = 5
    network: PrimitiveSpec = field(default_factory=PrimitiveSpec)
    prior: PriorSpec = field(default_factory=PriorSpec)

    @staticmethod
    def from_config(node) -> PrimitivesSettings:
        """Build from the ``primitives`` config node (its ``network`` must be a movement-primitive family)."""
        node = dict(node)
        network = network_from_config(node.pop("network", {"family": "dmp"}), "primitives.network")
        if not isinstance(network, PrimitiveSpec):
            raise ConfigError(f"primitives.network.family must be 'dmp', got {network.family!r}")
        prior = build(PriorSpec, node.pop("prior", {}), "primitives.prior")
        settings = build(PrimitivesSettings, node, "primitives")
        return dataclasses.replace(settings, network=network, prior=prior).validate()

    def validate(self) -> PrimitivesSettings:
        for name in ("policies", "episodes"):
            value = getattr(self, name)
            if value is not None and value < 2:
                raise ConfigError(f"primitives.{name} must be an integer >= 2 or null (the study's), got {value}")
        if self.bins is not None and self.bins < 2:
            raise ConfigError(f"primitives.bins must be an integer >= 2 or null (metrics.bins), got {self.bins}")
        if self.batches < 2:
            raise ConfigError(f"primitives.batches must be an integer >= 2, got {self.batches}")
        if self.policies is not None and self.policies < 2 * self.batches:
            raise ConfigError(f"primitives.policies must be at least 2 × primitives.batches = {2 * self.batches} "
                              f"(2 policies per batch), got {self.policies}")
        return self

    def estimators(self, metrics: MetricsSettings, policies: int, episodes: int) -> MetricsSettings:
        """The metrics stage's estimator settings, with this stage's B when it has one (else ``metrics.bins``
        resolved for this stage's N × M return matrices)."""
        chosen = metrics if self.bins is None else dataclasses.replace(metrics, bins=self.bins)
        return chosen.at_scale(policies, episodes)

    def request(self, study_request: RWGRequest) -> RWGRequest | None:
        """The family's RWG request for a study task (None: not a reaching arm, the family cannot run it)."""
        if getattr(study_request.task, "arm", None) is None:
            return None
        rwg = study_request.settings
        rwg = dataclasses.replace(rwg, policies=self.policies or rwg.policies, episodes=self.episodes or rwg.episodes,
                                  shard=0, shards=1, precision="float64")  # rwg.precision is the MLPs' forward pass
        rwg.validate()
        backend = study_request.backend  # the study's, where the family runs on it, else the family's fastest
        return RWGRequest(study_request.task, self.network, self.prior, rwg,
                          backend if backend in family_backends(self.network) else AUTO)


def primitives_key(request: RWGRequest, metrics: MetricsSettings, settings: PrimitivesSettings,
                   registry: Registry) -> str:
    return stage_key(STAGE, NUMERICS, {"rwg": request.key, "batches": settings.batches,
                                      "estimation": metrics.identity(), "metrics": registry.signature(STAGE)})


def compute_tables(returns: np.ndarray, metrics: MetricsSettings, settings: PrimitivesSettings, *,
                   registry: Registry = DEFAULT_REGISTRY) -> dict[str, pd.DataFrame]:
    """Every table of the stage from the family's (N, M) return matrix."""
    import pandas as pd

    from taskcomplexity.metrics.policy_tables import policy_sample_tables
    from taskcomplexity.metrics.sample import Sample

    estimation = metrics.estimation()
    if returns.shape[0] < 2 * settings.batches:
        raise ConfigError(f"primitives.batches={settings.batches} needs at least 2 policies per batch, but N = "
                          f"{returns.shape[0]}: allowed primitives.batches <= {max(returns.shape[0] // 2, 2)}")
    row, draws, batches = policy_sample_tables(Sample(returns, estimation), registry.of_stage(STAGE),
                                               policies=returns.shape[0], resamples=estimation.resamples,
                                               seed=estimation.bootstrap_seed, batches=settings.batches)
    row = {"policies": returns.shape[0], "episodes": returns.shape[1], **row}
    return {"primitives.parquet": pd.DataFrame([row]), "bootstrap.parquet": draws, "batches.parquet": batches}


def run_primitives_stage(cache: Cache, request: RWGRequest, metrics: MetricsSettings, settings: PrimitivesSettings,
                         *, label: str = "", registry: Registry = DEFAULT_REGISTRY, force: bool = False,
                         progress=False) -> tuple[Artefact, bool]:
    """Compute (or reuse) one task's family returns and their metrics; returns (artefact, cache hit)."""
    metrics = settings.estimators(metrics, request.settings.policies, request.settings.episodes)
    key = primitives_key(request, metrics, settings, registry)

    def write(directory):
        rwg, _ = run_rwg_stage(cache, request, force=force, progress=progress)
        for name, table in compute_tables(load_returns(rwg), metrics, settings, registry=registry).items():
            table.to_parquet(directory / name, index=False)
        return {"label": label, "rwg": rwg.key}

    config = {"family": request.network.identity(), "prior": request.prior.identity(),
              "policies": request.settings.policies, "episodes": request.settings.episodes, "bins": metrics.bins,
              "metrics": [m.name for m in registry.of_stage(STAGE)]}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs={"rwg": request.key}, force=force)


def study_primitives(cache: Cache, requests: Mapping[str, RWGRequest], metrics: MetricsSettings,
                     settings: PrimitivesSettings, *, registry: Registry = DEFAULT_REGISTRY, force: bool = False,
                     progress: bool = False) -> dict[str, Artefact]:
    """The primitives artefact of every study task that is a reaching arm (task id → artefact)."""
    if not settings.enabled or not registry.of_stage(STAGE):
        return {}
    chosen = {t: r for t, r in ((t, settings.request(r)) for t, r in requests.items()) if r is not None}
    if not chosen:
        return {}

    def episodes(task_id: str, request: RWGRequest) -> int:
        return request.settings.policies * request.settings.episodes

    def run(task_id: str, request: RWGRequest, bar) -> tuple[Artefact, bool]:
        return run_primitives_stage(cache, request, metrics, settings, label=task_id, registry=registry,
                                    force=force, progress=bar if bar is not None else False)

    return each_task(STAGE, chosen, run, work=episodes, progress=progress)


def _primitives(work: StudyWork) -> dict:
    plan = work.plan
    if plan.study.kind == "variants":
        return {}
    return study_primitives(plan.cache, plan.tasks, work.settings(metrics_stage.STAGE), work.settings(STAGE),
                            registry=work.registry, force=plan.force, progress=work.progress)


def _read_primitives(node: Any, study) -> PrimitivesSettings:
    return PrimitivesSettings.from_config(node)


def _check_primitives(settings: PrimitivesSettings, study, requests, typed) -> None:
    if settings.enabled and study.kind != "variants":
        for request in requests:
            settings.request(request)  # N, M and the backend checked before any work


RECORD = Stage(STAGE, NUMERICS, FILES, _primitives, inputs=(rwg_stage.STAGE,), group="primitives",
               settings=PrimitivesSettings, read=_read_primitives, check=_check_primitives,
               judged=Judged("primitives.parquet"), missing="it needs reaching-arm tasks and `primitives.enabled=true`",
               order=70)
"""The movement-primitives stage's record (:class:`~taskcomplexity.stages.stage.Stage`)."""
