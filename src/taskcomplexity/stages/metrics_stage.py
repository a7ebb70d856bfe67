"""The metrics stage: an RWG artefact + estimator settings → metrics, bootstrap and batch tables.

Every metric of the registry whose stage is ``metrics`` is estimated (:mod:`taskcomplexity.metrics.registry`).
Outputs under ``<cache>/metrics/<key>/``:

- ``metrics.parquet``: one row: ``policies``, ``episodes``, every metric and its details (e.g. H(R),
  λ*, r_min, r_max), and ``<metric>_mean``, ``_sd``, ``_ci_low``, ``_ci_high`` of each bootstrapped
  metric;
- ``policies.parquet``: per-policy statistics (Mₙ, Vₙ, rank, scaled mean);
- ``bootstrap.parquet``: every bootstrap draw of each bootstrapped metric;
- ``batches.parquet``: each batched metric on the consecutive policy batches (the Welch tests' samples).

The key hashes the RWG key, the settings and the registry's signature of its metrics, so adding a
metric recomputes the artefact instead of serving one without it.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import pandas as pd

from taskcomplexity import metrics as est
from taskcomplexity.config import result_identity, setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.evaluate import batch_estimates, bootstrap_estimates, point_estimates
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.metrics.sample import Estimation, Sample
from taskcomplexity.metrics.temperature import POICSearch
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import stage_key
from taskcomplexity.stages.rwg_stage import load_returns

log = logging.getLogger(__name__)

STAGE = "metrics"
VERSION = 2
FILES = ("metrics.parquet", "policies.parquet", "bootstrap.parquet", "batches.parquet")


@dataclass(frozen=True)
class MetricsSettings:
    """Estimator settings (metrics.md).

    Attributes
    ----------
    bins : int
        B, histogram bins of PIC (>= 2).
    temperature_range : (float, float)
        POIC temperature search interval, 0 < low < high (the other search options keep their
        :class:`~taskcomplexity.metrics.temperature.POICSearch` defaults).
    resamples : int
        Bootstrap resamples of the policies (>= 1).
    batches : int
        Consecutive policy batches for the Welch tests (>= 2).
    alpha : float
        Significance cut-off of the tests.
    seed : int
        Seed of the bootstrap.
    """

    bins: int = 100_000
    temperature_range: tuple[float, float] = POICSearch().temperature_range
    resamples: int = 1000
    batches: int = 5
    alpha: float = setting(0.005, result=False)
    seed: int = 0

    def validate(self) -> None:
        if self.bins < 2:
            raise ConfigError(f"metrics.bins must be an integer >= 2 (B), got {self.bins}")
        low, high = self.temperature_range
        if not (math.isfinite(low) and math.isfinite(high) and 0 < low < high):
            raise ConfigError(
                f"metrics.temperature_range must be [low, high] with 0 < low < high, got [{low}, {high}]"
            )
        if self.resamples < 1:
            raise ConfigError(f"metrics.resamples must be an integer >= 1, got {self.resamples}")
        if self.batches < 2:
            raise ConfigError(f"metrics.batches must be an integer >= 2, got {self.batches}")
        if not 0 < self.alpha < 1:
            raise ConfigError(f"metrics.alpha must be in (0, 1), got {self.alpha}")
        if self.seed < 0:
            raise ConfigError(f"metrics.seed must be a non-negative integer, got {self.seed}")

    def identity(self) -> dict:
        """The fields declared to change the result (all but ``alpha``, which only the verdict reads)."""
        return result_identity(self)

    def poic_search(self) -> POICSearch:
        """The POIC temperature search over ``temperature_range``."""
        return POICSearch(temperature_range=tuple(self.temperature_range))

    def estimation(self) -> Estimation:
        """The estimator settings every registered metric reads."""
        return Estimation(bins=self.bins, search=self.poic_search(), resamples=self.resamples,
                          bootstrap_seed=self.seed)


def metrics_key(rwg_key: str, settings: MetricsSettings, registry: Registry = DEFAULT_REGISTRY) -> str:
    """Cache key: the RWG key, the settings and the registry's signature of the stage's metrics."""
    return stage_key(STAGE, VERSION, {"rwg": rwg_key, **settings.identity(), "metrics": registry.signature(STAGE)})


def compute_metrics(
    returns, settings: MetricsSettings, *, registry: Registry = DEFAULT_REGISTRY, progress: bool = False
) -> dict[str, pd.DataFrame]:
    """Every table of the stage from a return matrix (N, M); see the module docstring."""
    sample = Sample(returns, settings.estimation(), progress=progress)
    metrics = registry.of_stage(STAGE)
    row = {"policies": sample.returns.shape[0], "episodes": sample.returns.shape[1],
           **point_estimates(sample, metrics)}
    draws = bootstrap_estimates(sample, metrics)
    bootstrapped = {m.name: row[m.name] for m in metrics if m.bootstrapped}
    if bootstrapped:
        for _, s in est.summarise_bootstrap(draws, bootstrapped).iterrows():
            for column in ("mean", "sd", "ci_low", "ci_high"):
                row[f"{s['metric']}_{column}"] = s[column]
    return {
        "metrics.parquet": pd.DataFrame([row]),
        "policies.parquet": est.policy_statistics(sample.returns),
        "bootstrap.parquet": draws,
        "batches.parquet": batch_estimates(sample.returns, metrics, batches=settings.batches,
                                           estimation=settings.estimation()),
    }


def run_metrics_stage(
    cache: Cache,
    rwg: Artefact,
    settings: MetricsSettings,
    *,
    label: str = "",
    registry: Registry = DEFAULT_REGISTRY,
    force: bool = False,
    progress: bool = False,
) -> tuple[Artefact, bool]:
    """Compute (or reuse) the metrics of one RWG artefact; returns (artefact, cache hit)."""
    settings.validate()
    key = metrics_key(rwg.key, settings, registry)

    def write(directory):
        tables = compute_metrics(load_returns(rwg), settings, registry=registry, progress=progress)
        for name, table in tables.items():
            table.to_parquet(directory / name, index=False)
        return {"label": label or rwg.manifest.get("label", "")}

    config = {**settings.identity(), "metrics": [m.name for m in registry.of_stage(STAGE)]}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs={"rwg": rwg.key}, force=force)
