"""The metrics stage: an RWG artefact + estimator settings → metrics, bootstrap and batch tables.

Outputs under ``<cache>/metrics/<key>/``:

- ``metrics.parquet``: one row of point estimates (PIC, H(R), H(R|Θ), POIC, λ*, boundary flag,
  H(O), H(O|Θ), r_min, r_max, r_mean, score_R, variance) and the bootstrap mean, sd and interval
  of PIC and POIC;
- ``policies.parquet``: per-policy statistics (Mₙ, Vₙ, rank, scaled mean);
- ``bootstrap.parquet``: every bootstrap draw of PIC and POIC;
- ``batches.parquet``: PIC and POIC of the 5 consecutive policy batches (for the Welch tests).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import pandas as pd

from taskcomplexity import metrics as est
from taskcomplexity.errors import ConfigError
from taskcomplexity.pipeline.cache import Artefact, Cache
from taskcomplexity.pipeline.keys import stage_key
from taskcomplexity.pipeline.rwg_stage import load_returns

log = logging.getLogger(__name__)

STAGE = "metrics"
VERSION = 1
FILES = ("metrics.parquet", "policies.parquet", "bootstrap.parquet", "batches.parquet")


@dataclass(frozen=True)
class MetricsSettings:
    """Estimator settings (metrics.md).

    Attributes
    ----------
    bins : int
        B, histogram bins of PIC (>= 2).
    temperature_range : (float, float)
        POIC temperature search interval, 0 < low < high.
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
    temperature_range: tuple[float, float] = (1e-4, 2e4)
    resamples: int = 1000
    batches: int = 5
    alpha: float = 0.005
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
        return {
            "bins": self.bins,
            "temperature_range": list(self.temperature_range),
            "resamples": self.resamples,
            "batches": self.batches,
            "seed": self.seed,
        }


def metrics_key(rwg_key: str, settings: MetricsSettings) -> str:
    return stage_key(STAGE, VERSION, {"rwg": rwg_key, **settings.identity()})


def compute_metrics(returns, settings: MetricsSettings, *, progress: bool = False) -> dict[str, pd.DataFrame]:
    """Every table of the stage from a return matrix (N, M)."""
    returns = est.validate_returns(returns)
    options = {"bins": settings.bins, "temperature_range": tuple(settings.temperature_range)}
    pic = est.pic(returns, bins=settings.bins)
    poic = est.poic(returns, temperature_range=tuple(settings.temperature_range))
    score = est.random_sampling_score(returns)
    draws = est.bootstrap(returns, seed=settings.seed, resamples=settings.resamples, progress=progress, **options)
    summary = est.summarise_bootstrap(draws, {"pic": pic.pic, "poic": poic.poic})
    row = {
        "policies": returns.shape[0],
        "episodes": returns.shape[1],
        "pic": pic.pic,
        "h_r": pic.h_r,
        "h_r_given_theta": pic.h_r_given_theta,
        "poic": poic.poic,
        "temperature": poic.temperature,
        "temperature_at_boundary": poic.at_boundary,
        "h_o": poic.h_o,
        "h_o_given_theta": poic.h_o_given_theta,
        "r_min": score.r_min,
        "r_max": score.r_max,
        "r_mean": score.r_mean,
        "score": score.score,
        "variance": score.variance,
    }
    for _, s in summary.iterrows():
        for column in ("mean", "sd", "ci_low", "ci_high"):
            row[f"{s['metric']}_{column}"] = s[column]
    batches = est.batch_estimates(returns, batches=settings.batches, **options)
    return {
        "metrics.parquet": pd.DataFrame([row]),
        "policies.parquet": est.policy_statistics(returns),
        "bootstrap.parquet": draws,
        "batches.parquet": batches,
    }


def run_metrics_stage(
    cache: Cache,
    rwg: Artefact,
    settings: MetricsSettings,
    *,
    label: str = "",
    force: bool = False,
    progress: bool = False,
) -> tuple[Artefact, bool]:
    """Compute (or reuse) the metrics of one RWG artefact."""
    settings.validate()
    key = metrics_key(rwg.key, settings)

    def write(directory):
        tables = compute_metrics(load_returns(rwg), settings, progress=progress)
        for name, table in tables.items():
            table.to_parquet(directory / name, index=False)
        return {"label": label or rwg.manifest.get("label", "")}

    return cache.get_or_compute(STAGE, key, write, config=settings.identity(), inputs={"rwg": rwg.key}, force=force)
