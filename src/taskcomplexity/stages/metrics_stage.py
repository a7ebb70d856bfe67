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

import ast
import dataclasses
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from taskcomplexity import metrics as est
from taskcomplexity.config import build, plain, result_identity, setting
from taskcomplexity.errors import ConfigError
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.metrics.temperature import POICSearch
from taskcomplexity.stages import rwg_stage
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.keys import PACKAGE, Numerics, stage_key
from taskcomplexity.stages.resources import refuse_beyond_memory
from taskcomplexity.stages.rwg_stage import load_returns
from taskcomplexity.stages.stage import Judged, Stage, StudyWork
from taskcomplexity.stages.stage_log import each_task

if TYPE_CHECKING:  # the estimators and pandas are imported by the functions that compute
    import pandas as pd

    from taskcomplexity.metrics.sample import Estimation

log = logging.getLogger(__name__)

STAGE = "metrics"


def estimator_modules(registry: Registry) -> tuple[str, ...]:
    """The modules of ``taskcomplexity.metrics`` that compute ``registry``'s metrics (dotted, without the package
    prefix, sorted): the modules of every metric's functions (``compute``, ``draws``, its details'), the modules the
    package re-exports (the :class:`~taskcomplexity.metrics.sample.Sample` whose shared estimates those functions
    read, the evaluation over batches and bootstrap resamples, the tables the stages read through the package),
    and every module they import at any depth. Private modules (``_validation``: input checks) compute no number."""
    directory = Path(est.__file__).parent
    functions = [f for m in registry for f in (m.compute, m.draws, *(d.compute for d in m.details)) if f is not None]
    todo = [est.__name__, *(getattr(getattr(f, "func", f), "__module__", "") for f in functions)]
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        module = name.removeprefix(f"{est.__name__}.") if name != est.__name__ else "__init__"
        path = directory / f"{module}.py"
        if name in seen or module == name or "." in module or not path.is_file():
            continue
        seen.add(name)
        for node in _import_statements(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                todo += [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level <= 1:  # absolute, or relative within the package
                base = ".".join(filter(None, (est.__name__ if node.level else "", node.module)))
                todo += [base, *(f"{base}.{alias.name}" for alias in node.names)]
    return tuple(sorted(n.removeprefix(f"{PACKAGE}.") for n in seen
                        if n != est.__name__ and not n.rpartition(".")[2].startswith("_")))


def _import_statements(tree: ast.Module):
    """Every ``import`` and ``from … import`` of a module, at any depth (in functions, classes, branches): a walk
    over its statements only, since an import is always one (a walk of every node costs the start of each command
    tens of milliseconds)."""
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
            continue
        for field in ("body", "orelse", "finalbody", "handlers", "cases"):
            todo.extend(getattr(node, field, ()))


ESTIMATORS = estimator_modules(DEFAULT_REGISTRY)
"""The estimators of the registry's metrics on a return matrix, their bootstrap and their policy batches: derived
from :data:`~taskcomplexity.metrics.registry.DEFAULT_REGISTRY` (:func:`estimator_modules`), so a metric in a
module of its own is declared with its registry entry."""
NUMERICS = Numerics(version=3, modules=(*ESTIMATORS, "stages.metrics_stage"))
FILES = ("metrics.parquet", "policies.parquet", "bootstrap.parquet", "batches.parquet")
AUTO = "auto"
"""``metrics.bins`` chosen from the return matrix's N and M (:meth:`MetricsSettings.at_scale`)."""


@dataclass(frozen=True)
class MetricsSettings:
    """Estimator settings (metrics.md).

    Attributes
    ----------
    bins : int or "auto"
        B, histogram bins of PIC (>= 2); ``"auto"`` (the default) resolves, for a return matrix of
        N policies × M episodes, to the pinned B of its protocol when it is sampled at that protocol's
        N and M (a study's ``published`` block), else to the paper's ratio N·M / 50
        (:func:`~taskcomplexity.metrics.pic.auto_bins`; 10⁵ at the published N = 10⁴, M = 500).
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
    pinned : (int, int, int) or None
        (N, M, B) of the study's protocol (its ``published`` block): ``bins="auto"`` is that B for a
        return matrix of that N and M. Set by the study's plan, not a config key; not hashed (the
        resolved B is).
    """

    bins: int | str = AUTO
    temperature_range: tuple[float, float] = POICSearch().temperature_range
    resamples: int = 1000
    batches: int = 5
    alpha: float = setting(0.005, result=False)
    seed: int = 0
    pinned: tuple[int, int, int] | None = setting(None, result=False)

    @staticmethod
    def from_config(node, published=None) -> MetricsSettings:
        """Build from the ``metrics`` config node (its ``scope`` is the metrics command's, not a setting); with
        a study's ``published`` protocol, its (N, M, B) pinned, so that ``metrics.bins=auto`` is its B at its N
        and M."""
        settings = build(MetricsSettings, {k: v for k, v in dict(plain(node)).items() if k != "scope"}, "metrics")
        if published is None:
            return settings
        return dataclasses.replace(settings, pinned=(published.policies, published.episodes, published.bins))

    def validate(self) -> None:
        if self.bins != AUTO and (isinstance(self.bins, bool) or not isinstance(self.bins, int) or self.bins < 2):
            from taskcomplexity.metrics.bins import RETURNS_PER_BIN

            raise ConfigError(f"metrics.bins must be an integer >= 2 (B) or {AUTO} (N·M / {RETURNS_PER_BIN}, or the "
                              f"study's pinned B at its published N and M), got {self.bins!r}")
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

    def at_scale(self, policies: int, episodes: int) -> MetricsSettings:
        """These settings with ``bins="auto"`` resolved for an N × M return matrix (an integer B is kept):
        the pinned protocol's B at its own N and M, else :func:`~taskcomplexity.metrics.pic.auto_bins`."""
        from taskcomplexity.metrics.bins import auto_bins

        if self.bins != AUTO:
            return self
        if self.pinned is not None and (int(policies), int(episodes)) == tuple(self.pinned[:2]):
            return dataclasses.replace(self, bins=int(self.pinned[2]))
        return dataclasses.replace(self, bins=auto_bins(int(policies), int(episodes)))

    @property
    def resolved_bins(self) -> int:
        """B as an integer (raises when it is still ``"auto"``: resolve with :meth:`at_scale` first)."""
        if self.bins == AUTO:
            raise ValueError("metrics.bins is 'auto': resolve it for a return matrix with at_scale(N, M) first")
        return int(self.bins)

    def poic_search(self) -> POICSearch:
        """The POIC temperature search over ``temperature_range``."""
        return POICSearch(temperature_range=tuple(self.temperature_range))

    def estimation(self) -> Estimation:
        """The estimator settings every registered metric reads."""
        from taskcomplexity.metrics.sample import Estimation

        return Estimation(bins=self.resolved_bins, search=self.poic_search(), resamples=self.resamples,
                          bootstrap_seed=self.seed)


def metrics_key(rwg_key: str, settings: MetricsSettings, registry: Registry = DEFAULT_REGISTRY) -> str:
    """Cache key: the RWG key, the settings and the registry's signature of the stage's metrics."""
    return stage_key(STAGE, NUMERICS, {"rwg": rwg_key, **settings.identity(), "metrics": registry.signature(STAGE)})


def compute_metrics(
    returns, settings: MetricsSettings, *, registry: Registry = DEFAULT_REGISTRY, progress: bool = False
) -> dict[str, pd.DataFrame]:
    """Every table of the stage from a return matrix (N, M); see the module docstring."""
    import pandas as pd

    from taskcomplexity.metrics.evaluate import batch_estimates, bootstrap_estimates, point_estimates
    from taskcomplexity.metrics.sample import Sample

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
    """Compute (or reuse) the metrics of one RWG artefact; returns (artefact, cache hit).

    ``settings.bins="auto"`` is resolved here from the artefact's N and M (the study chain resolves it
    before, with the study's pinned protocol).
    """
    settings.validate()
    check_memory(settings, *returns_shape(rwg))
    settings = settings.at_scale(*returns_shape(rwg))
    key = metrics_key(rwg.key, settings, registry)

    def write(directory):
        tables = compute_metrics(load_returns(rwg), settings, registry=registry, progress=progress)
        for name, table in tables.items():
            table.to_parquet(directory / name, index=False)
        return {"label": label or rwg.manifest.get("label", "")}

    config = {**settings.identity(), "metrics": [m.name for m in registry.of_stage(STAGE)]}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs={"rwg": rwg.key}, force=force)


def returns_shape(rwg: Artefact) -> tuple[int, int]:
    """(N, M) of an RWG artefact, from its manifest (the settings its key hashes)."""
    config = rwg.manifest.get("config", {})
    return int(config["policies"]), int(config["episodes"])


def study_metrics_of(cache: Cache, returns: Mapping[str, Artefact], labels: Mapping[str, str],
                     settings: MetricsSettings, *, registry: Registry = DEFAULT_REGISTRY, force: bool = False,
                     progress: bool = False) -> dict[str, Artefact]:
    """The metrics artefact of every task's RWG artefact (study id → artefact), in order; ``labels`` name
    each task's artefact (its manifest's label)."""

    def run(name: str, rwg: Artefact, bar) -> tuple[Artefact, bool]:
        return run_metrics_stage(cache, rwg, settings, label=labels[name], registry=registry, force=force)

    return each_task(STAGE, returns, run, progress=progress)


def _metrics(work: StudyWork) -> dict:
    plan = work.plan
    labels = {task_id: request.label for task_id, request in plan.tasks.items()}
    return study_metrics_of(plan.cache, work.done[rwg_stage.STAGE], labels, work.settings(STAGE),
                            registry=work.registry, force=plan.force, progress=work.progress)


def bytes_per_bin() -> int:
    """Peak bytes per histogram bin: a count table of B per thread of numba's (64- and 32-bit) and the edges and bin
    bounds."""
    import numba

    return 12 * numba.config.NUMBA_NUM_THREADS + 32


BYTES_PER_RESAMPLE_AND_POLICY = 5
"""Peak bytes per bootstrap resample and policy: its multiplicity (32-bit) and its blocked copy (8-bit)."""


def check_memory(settings: MetricsSettings, policies: int, episodes: int) -> None:
    """Refuse, before any work, bins or resamples whose tables would not fit in this machine's memory."""
    from taskcomplexity.metrics.bins import auto_bins

    bins = settings.at_scale(policies, episodes).resolved_bins
    for need, what, advice in (
            (bins * bytes_per_bin(), f"metrics.bins = {bins:,}",
             f"lower it; metrics.bins=auto gives B = {auto_bins(policies, episodes):,} at N = {policies:,}, "
             f"M = {episodes:,}"),
            (settings.resamples * policies * BYTES_PER_RESAMPLE_AND_POLICY,
             f"metrics.resamples × N = {settings.resamples:,} × {policies:,}", "lower metrics.resamples")):
        refuse_beyond_memory(need, what, advice)


def _check_metrics(settings: MetricsSettings, study, requests, typed) -> None:
    for request in requests:
        policies = request.settings.policies
        check_memory(settings, policies, request.settings.episodes)
        if settings.batches > policies // 2:
            raise ConfigError(f"metrics.batches={settings.batches} needs at least 2 policies per batch, but N = "
                              f"{policies} (rwg.policies or study.policies): allowed metrics.batches <= "
                              f"{max(policies // 2, 2)}, or more policies")


def _read_metrics(node: Any, study) -> MetricsSettings:
    return MetricsSettings.from_config(node, getattr(study, "published", None))


RECORD = Stage(STAGE, NUMERICS, FILES, _metrics, inputs=(rwg_stage.STAGE,), group="metrics",
               settings=MetricsSettings, read=_read_metrics, check=_check_metrics, judged=Judged("metrics.parquet"),
               order=20)
"""The metrics stage's record (:class:`~taskcomplexity.stages.stage.Stage`)."""
