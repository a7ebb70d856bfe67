"""The verdict stage: a study's metrics (+ diagnostics, SAC) artefacts and its relations → the verdict.

Outputs under ``<cache>/verdict/<key>/``:

- ``verdict.parquet``: one row per (metric, relation), metrics in registry order, relations in study
  order (columns :data:`taskcomplexity.verdict.VERDICT_COLUMNS`: ``metric, easier, harder, kind,
  value_easier, value_harder, pvalue, outcome`` and the direction, difference, significance and
  sample sizes);
- ``summary.parquet``: one row per metric: outcome counts, Kendall's τ per study order;
- ``references.parquet`` (``task, reference, value``): the study's reference scores, and Score(A) and
  Score(R) when it gives algorithm scores (:mod:`taskcomplexity.verdict.references`);
- ``correlations.parquet``: Pearson and Spearman r (with p) of every metric (by its easiness) and
  every shown detail (e.g. H(R)) with each reference score, across tasks (empty without references); for a
  bootstrapped metric the percentile interval of r over its bootstrap draws, and for a metric the information
  check judges, r again on its informative tasks only and on its value net of its null
  (:func:`taskcomplexity.verdict.references.correlations`);
- ``values.parquet`` / ``samples.parquet``: the tidy values (``task, metric, value``) judged and
  the samples of their Welch tests;
- ``welch.parquet``: Welch's test between every ordered pair of tasks for every metric with at least
  2 finite samples on each of at least 2 tasks (``metric, task_a, task_b, statistic, pvalue,
  significant``): the matrices of the paper's significance tests;
- ``replications.parquet``: each correlation the study's published tables print, beside ours on every basis,
  with its outcome (reproduced, estimator bias, not reproduced, unresolved at this budget;
  :mod:`taskcomplexity.verdict.replication`);
- ``information.parquet``: per (metric, task) whose metric declares a null or a ceiling, whether the
  value carries information, its null (mean, sd, repeats, p), the null's share of the value, and its
  ceiling ln N (:mod:`taskcomplexity.verdict.information`); a relation judged on a value without
  information is ``uninformative``;
- ``groups.parquet`` and ``group_relations.parquet`` (a study with ordered difficulty ``groups``): each metric's
  Kendall's τ-b and Spearman's ρ with the group order across tasks, with intervals over policies and across tasks,
  and Welch's test between every ordered pair of groups (:mod:`taskcomplexity.verdict.groups`);
- ``sac_per_seed.parquet`` (with SAC curves): final return, normalised final return and AUC, and
  steps to 90 % per (task, variant, seed).

The key hashes the metrics and diagnostics keys of every task, a content hash of the SAC curves,
the study's relations, orders, difficulty groups, reference scores and algorithm scores, the significance cut-off
and the registry's signature, so any change upstream (or a new metric) recomputes the verdict.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Mapping

import pandas as pd

from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.rl import WALL_CLOCK
from taskcomplexity.stages.cache import Artefact, Cache
from taskcomplexity.stages.declared import STAGES, judged_stages
from taskcomplexity.stages.diagnostics_stage import STAGE as DIAGNOSTICS
from taskcomplexity.stages.keys import Numerics, stage_key
from taskcomplexity.stages.metrics_stage import STAGE as METRICS
from taskcomplexity.stages.stage import POLICIES, SEEDS, Stage, StudyWork
from taskcomplexity.stages.stage_log import StageLog, outcome
from taskcomplexity.study_data import Study
from taskcomplexity.verdict import (
    gather,
    gather_details,
    gather_policies,
    information,
    judge,
    null_means,
    pairwise_welch,
    summarise,
    uninformative,
)
from taskcomplexity.verdict.groups import group_relations, rank_agreement
from taskcomplexity.verdict.references import correlations, quantities, reference_scores
from taskcomplexity.verdict.replication import replications

log = logging.getLogger(__name__)

STAGE = "verdict"
NUMERICS = Numerics(version=7, modules=(
    "verdict.gather", "verdict.judge", "verdict.information", "verdict.references", "verdict.replication",
    "verdict.groups", "metrics.registry", "metrics.batches", "metrics.sac", "metrics.statistics",
    "stages.verdict_stage",
))
FILES = ("verdict.parquet", "summary.parquet", "references.parquet", "correlations.parquet", "values.parquet",
         "samples.parquet", "welch.parquet", "information.parquet", "replications.parquet")
SAC_FILE = "sac_per_seed.parquet"
GROUP_FILES = ("groups.parquet", "group_relations.parquet")
"""Written only for a study with ordered difficulty ``groups``: each metric's rank agreement with them, and the
relations between the groups (:mod:`taskcomplexity.verdict.groups`)."""


def curves_digest(curves: pd.DataFrame | None) -> str | None:
    """Content hash of a SAC curve table (None without curves): the verdict's key of its SAC input. The wall-clock
    columns (:data:`taskcomplexity.rl.WALL_CLOCK`) are left out: a retrained run with the same numbers keeps the
    key."""
    if curves is None or curves.empty:
        return None
    curves = curves[[c for c in curves.columns if not str(c).startswith(WALL_CLOCK)]]
    digest = hashlib.sha256(",".join(map(str, curves.columns)).encode())
    digest.update(pd.util.hash_pandas_object(curves, index=False).to_numpy().tobytes())
    return digest.hexdigest()[:16]


def verdict_key(
    study: Study,
    metrics: Mapping[str, str],
    diagnostics: Mapping[str, str],
    sac: str | None,
    *,
    alpha: float,
    registry: Registry,
    stages: Mapping[str, Mapping[str, str]] | None = None,
) -> str:
    """Cache key of the verdict of ``study`` over the artefact keys given (task id → key)."""
    ids = list(metrics)
    payload = {
        "metrics": dict(metrics),
        "diagnostics": dict(diagnostics),
        "sac": sac,
        "relations": [[r.easier, r.harder, r.kind] for r in study.relations_among(ids)],
        "orders": {name: list(order) for name, order in study.orders.items()},
        "reference": dict(study.reference),
        "algorithm_scores": {t: [a.max, a.average] for t, a in study.algorithm_scores.items()},
        "published": {name: {r: {q: list(v) for q, v in row.items()} for r, row in table.correlations.items()}
                      for name, table in (study.published.tables if study.published else {}).items()},
        "alpha": float(alpha),
        "registry": registry.signature(),
        "information": {m.name: m.information.identity() for m in registry if m.information is not None},
    }
    if study.groups is not None:
        payload["groups"] = {"order": list(study.groups.order), "tasks": study.difficulty()}
    for stage, keys in (stages or {}).items():  # the further policy-sample stages (occupancy, learning path)
        if keys:
            payload[stage] = dict(keys)
    return stage_key(STAGE, NUMERICS, payload)


def gather_draws(metrics: Mapping[str, Artefact], *, registry: Registry) -> pd.DataFrame:
    """``task``, ``metric``, ``resample``, ``value``: the bootstrap draws over policies of the metrics stage's
    bootstrapped metrics (its ``bootstrap.parquet``), for the intervals of their correlations."""
    names = [m.name for m in registry.of_stage(METRICS) if m.bootstrapped]
    parts = []
    for task, artefact in metrics.items():
        path = artefact.file("bootstrap.parquet")
        if not names or not path.exists():
            continue
        draws = pd.read_parquet(path)
        present = [n for n in names if n in draws.columns]
        if present:
            parts.append(draws.melt(id_vars="resample", value_vars=present, var_name="metric").assign(task=task))
    columns = ["task", "metric", "resample", "value"]
    return pd.concat(parts, ignore_index=True)[columns] if parts else pd.DataFrame(columns=columns)


def run_verdict_stage(
    cache: Cache,
    study: Study,
    metrics: Mapping[str, Artefact],
    *,
    diagnostics: Mapping[str, Artefact] | None = None,
    sac_curves: pd.DataFrame | None = None,
    stages: Mapping[str, Mapping[str, Artefact]] | None = None,
    alpha: float = SIGNIFICANCE_LEVEL,
    registry: Registry = DEFAULT_REGISTRY,
    force: bool = False,
) -> tuple[Artefact, bool]:
    """Compute (or reuse) the verdict of a study.

    Parameters
    ----------
    cache : Cache
        The artefact store.
    study : Study
        Its relations (among the tasks of ``metrics``), orders, reference and algorithm scores are judged.
    metrics : mapping of task id to Artefact
        Each task's metrics artefact, in study order.
    diagnostics : mapping of task id to Artefact, optional
        Each task's diagnostics artefact (the other estimators); None leaves them out.
    sac_curves : pandas.DataFrame, optional
        Tidy SAC curves of the study (``task`` = study id); None or empty leaves SAC out.
    stages : mapping of stage to mapping of task id to Artefact, optional
        The artefacts of the further stages judged on policy samples (:data:`~taskcomplexity.stages.declared.STAGES`
        with a :class:`~taskcomplexity.stages.stage.Judged`: ``occupancy``, ``learning_path``, ``primitives``);
        a missing stage is left out.
    alpha : float, default 0.005
        Significance cut-off.
    registry : Registry
        The metrics to judge and their directions.
    force : bool
        Recompute even when the key exists.

    Returns
    -------
    (Artefact, bool)
        The artefact and whether the cache already held it.
    """
    diagnostics = {t: a for t, a in (diagnostics or {}).items() if t in metrics}
    further = {stage: {t: a for t, a in found.items() if t in metrics} for stage, found in (stages or {}).items()}
    judged = judged_stages()
    on_policies = [s for s, how in judged.items() if how.on == POLICIES and s not in (METRICS, DIAGNOSTICS)]
    unknown = [s for s in further if s not in on_policies]
    if unknown:
        raise ValueError(f"stages must be further stages of {on_policies}, got {sorted(unknown)}")
    sac = curves_digest(sac_curves)
    key = verdict_key(study, {t: a.key for t, a in metrics.items()}, {t: a.key for t, a in diagnostics.items()},
                      sac, alpha=alpha, registry=registry,
                      stages={s: {t: a.key for t, a in found.items()} for s, found in further.items()})

    def write(directory):
        given = {METRICS: metrics, DIAGNOSTICS: diagnostics, **further}
        tables = {stage: {t: (pd.read_parquet(a.file(how.values)), pd.read_parquet(a.file(how.samples)))
                          for t, a in given[stage].items()}
                  for stage, how in judged.items() if stage in given}
        bounds = {t: values.iloc[0] for t, (values, _) in tables[METRICS].items()
                  if {"r_min", "r_max", "r_mean"} <= set(values.columns)}
        seeds = [stage for stage, how in judged.items() if how.on == SEEDS]
        normalisation = {t: (float(v["r_min"].iloc[0]), float(v["r_max"].iloc[0]))  # of the SAC curves
                         for t, (v, _) in tables[METRICS].items() if {"r_min", "r_max"} <= set(v.columns)}
        values, samples, per_seed = gather(
            tables, registry=registry, curves={stage: sac_curves for stage in seeds if sac_curves is not None},
            bounds=normalisation)
        relations = study.relations_among(list(metrics))
        nulls = {}
        for task, artefact in diagnostics.items():
            null = pd.read_parquet(artefact.file("null.parquet"))
            nulls.update({(name, task): null[name].to_numpy() for name in registry.nulls() if name in null.columns})
        policies = gather_policies(tables, registry=registry)
        checked = information(values, nulls, policies, registry=registry, alpha=alpha)
        blank = uninformative(checked)
        centres = null_means(checked)
        table = judge(values, samples, relations, registry=registry, alpha=alpha, uninformative=blank,
                      nulls=centres, policies=policies)
        summary = summarise(table, values, registry=registry, orders=study.orders, uninformative=blank,
                            nulls=centres)
        references = reference_scores(study, bounds)
        correlated = correlations(quantities(values, gather_details(tables, registry=registry), registry=registry),
                                  references, draws=gather_draws(metrics, registry=registry), information=checked,
                                  registry=registry)
        replicated = replications(correlated, study, registry=registry)
        welch = pairwise_welch(samples, registry=registry, alpha=alpha)
        if study.groups is not None:
            drawn = gather_draws(metrics, registry=registry)
            rank_agreement(values, study, registry=registry, alpha=alpha, draws=drawn, information=checked).to_parquet(
                directory / GROUP_FILES[0], index=False)
            group_relations(values, study, registry=registry, alpha=alpha, information=checked).to_parquet(
                directory / GROUP_FILES[1], index=False)
        for name, frame in (("verdict.parquet", table), ("summary.parquet", summary),
                            ("references.parquet", references), ("correlations.parquet", correlated),
                            ("values.parquet", values), ("samples.parquet", samples), ("welch.parquet", welch),
                            ("information.parquet", checked), ("replications.parquet", replicated)):
            frame.to_parquet(directory / name, index=False)
        if per_seed is not None:
            per_seed.to_parquet(directory / SAC_FILE, index=False)
        return {"label": f"{study.name}: {len(relations)} relations × {summary.shape[0]} metrics"}

    config = {"study": study.name, "tasks": list(metrics), "alpha": float(alpha), "metrics": list(registry.names),
              "sac": sac}
    inputs = {**{f"metrics/{t}": a.key for t, a in metrics.items()},
              **{f"diagnostics/{t}": a.key for t, a in diagnostics.items()},
              **{f"{s}/{t}": a.key for s, found in further.items() for t, a in found.items()}}
    return cache.get_or_compute(STAGE, key, write, config=config, inputs=inputs, force=force)


def study_verdict(work: StudyWork) -> Artefact:
    """The verdict over the outputs of every declared stage the verdict judges (:class:`StudyWork`): the metrics
    and diagnostics artefacts, SAC's curves, and the further stages' artefacts."""
    plan, done = work.plan, work.done
    judged = judged_stages()
    further = {s: done[s] for s, how in judged.items() if how.on == POLICIES and s not in (METRICS, DIAGNOSTICS)}
    curves = [done[s] for s, how in judged.items() if how.on == SEEDS]
    log_ = StageLog(STAGE)
    with log_.task(plan.study.name) as record:
        record.artefact, record.hit = run_verdict_stage(
            plan.cache, plan.study, done[METRICS], diagnostics=done[DIAGNOSTICS],
            sac_curves=curves[0] if curves else None, stages=further, alpha=work.settings(METRICS).alpha,
            registry=work.registry, force=plan.force)
    log.info("%-12s %s: %s", STAGE, outcome(record.hit, record.seconds), record.artefact.file("verdict.parquet"))
    return record.artefact


VERDICT = Stage(STAGE, NUMERICS, FILES, study_verdict, inputs=tuple(s.name for s in STAGES if s.judged is not None))
"""The verdict's record: it closes a study's chain, after every stage it judges."""
