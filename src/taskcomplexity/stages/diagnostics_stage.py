"""The diagnostics stage: how much of a task's PIC is estimator bias?

``docs/explanation/estimators.md`` § Estimator biases states the diagnostics.

An RWG artefact + the metrics estimator settings + :class:`DiagnosticsSettings` → tables under
``<cache>/diagnostics/<key>/``:

- ``null.parquet``: every estimator of I(Θ; R) (histogram, Miller–Madow and nearest-neighbour PIC) and
  POIC on the returns permuted across policies (true MI = 0), one row per repeat (``repeat``, ``pic``,
  ``h_r``, ``h_r_given_theta``, ``poic``, ``temperature``, ``pic_miller_madow``, ``pic_knn``);
- ``null_summary.parquet``: per estimator (pic, poic, pic_miller_madow, pic_knn) the observed value, null
  mean, null sd, observed minus null (``excess``) and its z-score;
- ``bins_sweep.parquet``: histogram and Miller–Madow PIC for B = 10 … the metrics bins;
- ``subsample_sweep.parquet``: histogram PIC on nested subsamples of policies and episodes;
- ``estimators.parquet``: one row: histogram PIC and POIC against their nulls, and every registered
  metric whose stage is ``diagnostics`` (:mod:`taskcomplexity.metrics.registry`) with its details;
- ``batches.parquet``: each of those metrics that is batched, on the consecutive policy batches of the
  metrics stage: the samples of the Welch tests behind "does the verdict survive a change of estimator".

Cost at the published N = 10⁴, M = 500, B = 10⁵ (``bench/bench_diagnostics.py``): about 12 CPU-s for a
dense task, 7 for a sparse one. The 10 POIC searches of the permutation null are over half of it (ℓ on
the coarse grid and on the refinement, the optimality curves), then the per-batch nulls (50 permutations
of N/5 policies) and the shuffles; each null permutation and its sorted rows are drawn one ahead in a
background thread, so that their serial work overlaps the parallel searches.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from taskcomplexity import metrics as est
from taskcomplexity.config import result_identity
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.stages import metrics_stage, rwg_stage
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.metrics_stage import ESTIMATORS, MetricsSettings, returns_shape
from taskcomplexity.stages.rwg_stage import load_returns
from taskcomplexity.stages.stage import Judged, Stage, StudyWork
from taskcomplexity.stages.stage_log import each_task

if TYPE_CHECKING:  # the estimators and pandas are imported by the functions that compute
    import pandas as pd

    from taskcomplexity.metrics.sample import Estimation

log = logging.getLogger(__name__)

STAGE = "diagnostics"
NUMERICS = Numerics(version=3, modules=(*ESTIMATORS, "stages.metrics_stage", "stages.diagnostics_stage"))
FILES = (
    "null.parquet",
    "null_summary.parquet",
    "bins_sweep.parquet",
    "subsample_sweep.parquet",
    "estimators.parquet",
    "batches.parquet",
)


@dataclass(frozen=True)
class DiagnosticsSettings:
    """Settings of the estimator diagnostics.

    Attributes
    ----------
    repeats : int
        Permutations of the null (>= 2, so that the null has a standard deviation).
    bins_sweep : tuple of int
        Numbers of bins of the sweep (each >= 2); values above the metrics bins are dropped and the
        metrics bins are always included.
    subsample_fractions : tuple of float
        Fractions of N (and, separately, of M) of the nested subsamples, each in (0, 1]; sizes are
        rounded down and those below 2 dropped; the full sample is always included.
    knn_neighbors : int
        Neighbours k of the nearest-neighbour MI (>= 1).
    knn_max_samples : int
        Largest number of (policy, episode) samples the nearest-neighbour MI uses (>= 100).
    knn_episodes_per_policy : int
        Episodes per policy kept by the nearest-neighbour MI before policies are dropped (> k).
    seed : int
        Seed of the permutations and subsamples (>= 0).
    """

    repeats: int = 10
    bins_sweep: tuple[int, ...] = (10, 100, 1000, 10_000, 100_000)
    subsample_fractions: tuple[float, ...] = (0.125, 0.25, 0.5, 1.0)
    knn_neighbors: int = 3
    knn_max_samples: int = 50_000
    knn_episodes_per_policy: int = 50
    seed: int = 0

    def validate(self) -> None:
        """Raise :class:`~taskcomplexity.errors.ConfigError` naming the first invalid key."""
        if _not_int(self.repeats) or self.repeats < 2:
            raise ConfigError(f"diagnostics.repeats must be an integer >= 2, got {self.repeats!r}")
        if not self.bins_sweep or any(_not_int(b) or b < 2 for b in self.bins_sweep):
            raise ConfigError(
                f"diagnostics.bins_sweep must be a non-empty list of integers >= 2, got {list(self.bins_sweep)!r}"
            )
        if not self.subsample_fractions or any(
            isinstance(f, bool) or not isinstance(f, int | float) or not 0 < f <= 1 for f in self.subsample_fractions
        ):
            raise ConfigError(
                "diagnostics.subsample_fractions must be a non-empty list of numbers in (0, 1], "
                f"got {list(self.subsample_fractions)!r}"
            )
        if _not_int(self.knn_neighbors) or self.knn_neighbors < 1:
            raise ConfigError(f"diagnostics.knn_neighbors must be an integer >= 1, got {self.knn_neighbors!r}")
        if _not_int(self.knn_max_samples) or self.knn_max_samples < 100:
            raise ConfigError(f"diagnostics.knn_max_samples must be an integer >= 100, got {self.knn_max_samples!r}")
        if _not_int(self.knn_episodes_per_policy) or self.knn_episodes_per_policy <= self.knn_neighbors:
            raise ConfigError(
                "diagnostics.knn_episodes_per_policy must be an integer > diagnostics.knn_neighbors "
                f"({self.knn_neighbors}), got {self.knn_episodes_per_policy!r}"
            )
        if _not_int(self.seed) or self.seed < 0:
            raise ConfigError(f"diagnostics.seed must be a non-negative integer, got {self.seed!r}")

    def identity(self) -> dict:
        """The settings the cache key hashes: every field (each changes the result), sweeps in sorted order."""
        identity = result_identity(self)
        identity["bins_sweep"] = sorted(self.bins_sweep)
        identity["subsample_fractions"] = sorted(float(f) for f in self.subsample_fractions)
        return identity


def _not_int(value: object) -> bool:
    return isinstance(value, bool) or not isinstance(value, int | np.integer)


def diagnostics_key(
    rwg_key: str, metrics_settings: MetricsSettings, settings: DiagnosticsSettings,
    registry: Registry = DEFAULT_REGISTRY,
) -> str:
    """Cache key: the RWG key, the estimator settings the diagnostics reuse, ``settings`` and the
    registry's signature of the stage's metrics."""
    estimator = {
        "bins": metrics_settings.bins,
        "temperature_range": list(metrics_settings.temperature_range),
        "batches": metrics_settings.batches,
    }
    return stage_key(STAGE, NUMERICS, {"rwg": rwg_key, "metrics": estimator, **settings.identity(),
                                      "registry": registry.signature(STAGE)})


def estimation(metrics_settings: MetricsSettings, settings: DiagnosticsSettings) -> Estimation:
    """The estimator settings of the stage's metrics."""
    from taskcomplexity.metrics.sample import Estimation

    return Estimation(bins=metrics_settings.resolved_bins, search=metrics_settings.poic_search(),
                      null_repeats=settings.repeats, knn_neighbors=settings.knn_neighbors,
                      knn_max_samples=settings.knn_max_samples,
                      knn_episodes_per_policy=settings.knn_episodes_per_policy, seed=settings.seed)


def _sizes(total: int, fractions: tuple[float, ...]) -> list[int]:
    sizes = {int(total * f) for f in fractions} | {total}
    return sorted(size for size in sizes if size >= 2)


def compute_diagnostics(
    returns: object,
    metrics_settings: MetricsSettings,
    settings: DiagnosticsSettings,
    *,
    registry: Registry = DEFAULT_REGISTRY,
    progress: bool = False,
) -> dict[str, pd.DataFrame]:
    """Every table of the stage from one task's return matrix.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n in sampling order.
    metrics_settings : MetricsSettings
        Bins B, POIC temperature range and number of batches, as the metrics stage used them.
    settings : DiagnosticsSettings
        Repeats, sweeps, nearest-neighbour options and seed.
    registry : Registry
        Its metrics of stage ``diagnostics`` are estimated.
    progress : bool, default False
        Show a progress bar over the steps.

    Returns
    -------
    dict of str to pandas.DataFrame
        One table per file name of :data:`FILES` (see the module docstring for their columns).
    """
    import pandas as pd
    from tqdm.auto import tqdm

    from taskcomplexity.metrics.evaluate import batch_estimates, point_estimates
    from taskcomplexity.metrics.sample import Sample, component_seeds

    sample = Sample(returns, estimation(metrics_settings, settings))
    returns, bins = sample.returns, sample.estimation.bins
    steps = tqdm(total=5, desc="diagnostics", disable=not progress, leave=False)

    null = est.permutation_null(returns, seed=sample.seed("null"), repeats=settings.repeats, bins=bins,
                                search=sample.estimation.search, knn=sample.knn_options)
    summary = est.summarise_null(null, {"pic": sample.pic.pic, "poic": sample.poic.poic,
                                        "pic_miller_madow": sample.pic_miller_madow.pic, "pic_knn": sample.knn.mi})
    steps.update()

    sweep_bins = sorted({b for b in settings.bins_sweep if b <= bins} | {bins})
    bins_sweep = est.pic_bins_sweep(returns, bins=sweep_bins)
    steps.update()

    n_policies, n_episodes = returns.shape
    subsample = est.pic_subsample_sweep(
        returns,
        seed=component_seeds(settings.seed)["subsample"],
        policies=_sizes(n_policies, settings.subsample_fractions),
        episodes=_sizes(n_episodes, settings.subsample_fractions),
        bins=bins,
    )
    steps.update()

    metrics = registry.of_stage(STAGE)
    by_metric = summary.set_index("metric")
    estimators = pd.DataFrame([{
        "policies": n_policies,
        "episodes": n_episodes,
        "bins": bins,
        "pic": sample.pic.pic,
        "pic_null_mean": by_metric.loc["pic", "null_mean"],
        "pic_null_sd": by_metric.loc["pic", "null_sd"],
        "poic": sample.poic.poic,
        "poic_null_mean": by_metric.loc["poic", "null_mean"],
        "poic_null_sd": by_metric.loc["poic", "null_sd"],
        "poic_minus_null": by_metric.loc["poic", "excess"],
        **point_estimates(sample, metrics),
    }])
    steps.update()

    batches = batch_estimates(returns, metrics, batches=metrics_settings.batches, estimation=sample.estimation)
    steps.update()
    steps.close()
    return {
        "null.parquet": null,
        "null_summary.parquet": summary,
        "bins_sweep.parquet": bins_sweep,
        "subsample_sweep.parquet": subsample,
        "estimators.parquet": estimators,
        "batches.parquet": batches,
    }


def run_diagnostics_stage(
    cache: Cache,
    rwg_artefact: Artefact,
    metrics_settings: MetricsSettings,
    diagnostics_settings: DiagnosticsSettings,
    *,
    registry: Registry = DEFAULT_REGISTRY,
    force: bool = False,
    progress: bool = False,
) -> tuple[Artefact, bool]:
    """Compute (or reuse) the estimator diagnostics of one RWG artefact.

    Parameters
    ----------
    cache : Cache
        The artefact store.
    rwg_artefact : Artefact
        The task's returns (stage ``rwg``).
    metrics_settings : MetricsSettings
        The estimator settings of the metrics stage (bins, temperature range, batches).
    diagnostics_settings : DiagnosticsSettings
        Repeats, sweeps, nearest-neighbour options and seed.
    registry : Registry
        Its metrics of stage ``diagnostics`` are estimated (and hashed into the key).
    force : bool, default False
        Recompute even when the key exists.
    progress : bool, default False
        Show a progress bar.

    Returns
    -------
    (Artefact, bool)
        The artefact and whether the cache already held it.
    """
    metrics_settings.validate()
    diagnostics_settings.validate()
    metrics_settings = metrics_settings.at_scale(*returns_shape(rwg_artefact))
    key = diagnostics_key(rwg_artefact.key, metrics_settings, diagnostics_settings, registry)

    def write(directory):
        tables = compute_diagnostics(load_returns(rwg_artefact), metrics_settings, diagnostics_settings,
                                     registry=registry, progress=progress)
        for name, table in tables.items():
            table.to_parquet(directory / name, index=False)
        return {"label": rwg_artefact.manifest.get("label", "")}

    config = {"metrics": {"bins": metrics_settings.bins, "temperature_range": list(metrics_settings.temperature_range),
                          "batches": metrics_settings.batches}, **diagnostics_settings.identity(),
              "registry": [m.name for m in registry.of_stage(STAGE)]}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs={"rwg": rwg_artefact.key}, force=force)


def study_diagnostics(
    cache: Cache,
    rwg_artefacts: Mapping[str, Artefact],
    metrics_settings: MetricsSettings,
    diagnostics_settings: DiagnosticsSettings,
    *,
    registry: Registry = DEFAULT_REGISTRY,
    force: bool = False,
    progress: bool = False,
) -> dict[str, Artefact]:
    """The diagnostics artefact of every task, keyed like ``rwg_artefacts`` (task id → RWG artefact).

    With ``progress``, one bar over the tasks (:func:`~taskcomplexity.stages.stage_log.each_task`).
    """

    def run(task_id: str, rwg: Artefact, bar) -> tuple[Artefact, bool]:
        return run_diagnostics_stage(cache, rwg, metrics_settings, diagnostics_settings, registry=registry,
                                     force=force)

    return each_task(STAGE, rwg_artefacts, run, progress=progress)


def _diagnostics(work: StudyWork) -> dict:
    plan = work.plan
    return study_diagnostics(plan.cache, work.done[rwg_stage.STAGE], work.settings(metrics_stage.STAGE),
                             work.settings(STAGE), registry=work.registry, force=plan.force, progress=work.progress)


def _check_diagnostics(settings: DiagnosticsSettings, study, requests, typed) -> None:
    episodes = min(request.settings.episodes for request in requests)
    if episodes <= settings.knn_neighbors:
        raise ConfigError(f"the diagnostics' k-NN estimate needs M > diagnostics.knn_neighbors = "
                          f"{settings.knn_neighbors} episodes per policy, but M = {episodes} (rwg.episodes or "
                          f"study.episodes): allowed M >= {settings.knn_neighbors + 1}")


RECORD = Stage(STAGE, NUMERICS, FILES, _diagnostics, inputs=(rwg_stage.STAGE,), group="diagnostics",
               settings=DiagnosticsSettings, check=_check_diagnostics, judged=Judged("estimators.parquet"), order=30)
"""The diagnostics stage's record (:class:`~taskcomplexity.stages.stage.Stage`)."""
