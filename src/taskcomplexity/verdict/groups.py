"""Does a metric rank a study's ordered difficulty groups? (e.g. Meta-World's easy, medium, hard, very hard)

A study with ``groups`` (:class:`~taskcomplexity.study_data.DifficultyGroups`) puts every task in one of a few
ordered groups instead of (or beside) pairwise relations. Every metric is judged two ways, on each of the bases of
:func:`~taskcomplexity.verdict.references.on_bases` (every task's value; only the tasks where it carries
information; its value net of its null):

- **rank agreement** (:func:`rank_agreement`): Kendall's τ-b (ties: the groups are ties of the known order) and
  Spearman's ρ between the metric's easiness and the group's easiness across tasks, with two 95 % percentile
  intervals of τ: over the policies (the metric's bootstrap draws, each task's centred on its value) and across the
  tasks (the tasks resampled with replacement). ``agree`` / ``contradict``: τ's two-sided p below the cut-off and τ
  above / below zero; ``not significant``; ``uninformative`` when fewer than :data:`MIN_TASKS` tasks are left.
- **group relations** (:func:`group_relations`): for every ordered pair of groups (easier, harder), Welch's test
  between the two groups' task values (the tasks are the samples): ``agree`` / ``contradict`` when significant and
  the easier group's mean easiness is above / below the harder's, ``not significant``, ``uninformative`` when either
  group keeps fewer than 2 tasks on the basis.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import scipy.stats

from taskcomplexity.metrics.registry import Registry
from taskcomplexity.study_data import Study
from taskcomplexity.verdict.references import CONFIDENCE, easiness_draws, on_bases

MIN_TASKS = 4
"""Fewest tasks (of at least two groups) a rank agreement is computed on."""
TASK_RESAMPLES = 2000
"""Resamples of the tasks for the interval across tasks."""
TASK_SEED = 20220601
"""Seed of those resamples (the interval is a fixed function of the values)."""
OUTCOMES = AGREE, CONTRADICT, NOT_SIGNIFICANT, UNINFORMATIVE = ("agree", "contradict", "not significant",
                                                                "uninformative")

RANK_COLUMNS = ("metric", "basis", "tasks", "kendall_tau", "kendall_p", "spearman_rho", "spearman_p",
                "policies_low", "policies_high", "resamples", "tasks_low", "tasks_high", "outcome")
"""Columns of :func:`rank_agreement` (``policies_low``/``_high``: τ's interval over the bootstrap draws of the
policies, of which ``resamples`` were used, NaN without draws; ``tasks_low``/``_high``: over resampled tasks)."""
RELATION_COLUMNS = ("metric", "basis", "easier", "harder", "tasks_easier", "tasks_harder", "mean_easier",
                    "mean_harder", "statistic", "pvalue", "outcome")
"""Columns of :func:`group_relations` (``mean_*``: the group's mean easiness of the metric on the basis)."""


def rank_agreement(values: pd.DataFrame, study: Study, *, registry: Registry, alpha: float,
                   draws: pd.DataFrame | None = None, information: pd.DataFrame | None = None) -> pd.DataFrame:
    """Kendall's τ-b and Spearman's ρ of every metric with the study's difficulty groups, on every basis.

    Parameters
    ----------
    values : pandas.DataFrame
        ``task``, ``metric``, ``value``: the verdict's values.
    study : Study
        Its ``groups`` and each task's ``group``.
    registry : Registry
        The metrics' directions and order.
    alpha : float
        Significance cut-off of τ's p.
    draws : pandas.DataFrame, optional
        ``task``, ``metric``, ``resample``, ``value``: bootstrap draws over policies.
    information : pandas.DataFrame, optional
        The information table (bases ``informative`` and ``net of null``).

    Returns
    -------
    pandas.DataFrame, columns :data:`RANK_COLUMNS`
        One row per (metric, basis), for the metrics comparable across tasks; empty when the study has no
        groups. Positive τ: the metric calls the easier groups' tasks easier.
    """
    difficulty = study.difficulty()
    if not difficulty:
        return pd.DataFrame(columns=list(RANK_COLUMNS))
    resampled = easiness_draws(draws, registry)
    checked = information if information is not None and not information.empty else None
    rows = []
    for metric in _ranked(values, registry):
        for basis, easiness, own in _bases(values, metric, difficulty, registry, resampled.get(metric), checked):
            tasks = list(easiness.index)
            known = -np.array([difficulty[t] for t in tasks], dtype=np.float64)  # higher = easier group
            y = easiness.to_numpy(dtype=np.float64)
            row = {"metric": metric, "basis": basis, "tasks": len(tasks), **_rank(known, y, own, tasks)}
            row["outcome"] = _outcome(row["kendall_tau"], row["kendall_p"], alpha, len(tasks), len(set(known)))
            rows.append(row)
    return pd.DataFrame(rows, columns=list(RANK_COLUMNS))


def _ranked(values: pd.DataFrame, registry: Registry) -> list[str]:
    """The metrics of ``values`` that rank tasks (comparable across tasks), in registry order."""
    return [m for m in registry.order(values["metric"]) if m in registry and registry[m].comparable_across_tasks]


def _bases(values: pd.DataFrame, metric: str, difficulty: dict[str, int], registry: Registry,
           draws: pd.DataFrame | None, checked: pd.DataFrame | None):
    """The metric's easiness on the grouped tasks, finite, on each basis (with its draws):
    :func:`~taskcomplexity.verdict.references.on_bases` of the metric's values as easiness."""
    sign = 1.0 if registry[metric].higher_is_easier else -1.0
    mine = values[(values["metric"] == metric) & values["task"].isin(list(difficulty))]
    by_task = mine.set_index("task")["value"].astype(float) * sign
    for basis, easiness, own in on_bases(by_task, draws, checked, metric, sign):
        yield basis, easiness[np.isfinite(easiness.to_numpy(dtype=np.float64))], own


def _rank(known: np.ndarray, y: np.ndarray, own: pd.DataFrame | None, tasks: list[str]) -> dict:
    row = dict.fromkeys(("kendall_tau", "kendall_p", "spearman_rho", "spearman_p", "policies_low", "policies_high",
                         "tasks_low", "tasks_high"), float("nan"))
    row["resamples"] = 0
    if len(tasks) < 3 or np.ptp(known) == 0 or np.ptp(y) == 0:
        return row
    tau = scipy.stats.kendalltau(y, known)
    rho = scipy.stats.spearmanr(y, known)
    row.update(kendall_tau=float(tau.statistic), kendall_p=float(tau.pvalue), spearman_rho=float(rho.statistic),
               spearman_p=float(rho.pvalue))
    tail = (1 - CONFIDENCE) / 2
    if own is not None and set(tasks) <= set(own.columns):
        matrix = own[tasks].to_numpy(dtype=np.float64)
        matrix = matrix[np.isfinite(matrix).all(axis=1)]
        taus = _taus(matrix, known[np.newaxis, :])
        taus = taus[np.isfinite(taus)]
        if taus.size >= 2:
            row["policies_low"], row["policies_high"] = (float(q) for q in np.quantile(taus, [tail, 1 - tail]))
            row["resamples"] = int(taus.size)
    rng = np.random.default_rng(TASK_SEED)
    picks = rng.integers(0, len(tasks), size=(TASK_RESAMPLES, len(tasks)))
    taus = _taus(y[picks], known[picks])
    taus = taus[np.isfinite(taus)]
    if taus.size >= 2:
        row["tasks_low"], row["tasks_high"] = (float(q) for q in np.quantile(taus, [tail, 1 - tail]))
    return row


def _taus(ys: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Kendall's τ-b of each row of ``ys`` (R, n) with the matching row of ``known`` (R, n), or with its one row
    (1, n): scipy's ``kendalltau`` along ``axis=1`` (R values; NaN where a row is constant)."""
    if ys.shape[0] == 0:
        return np.empty(0)
    known = np.broadcast_to(known, ys.shape)
    return np.asarray(scipy.stats.kendalltau(ys, known, axis=1).statistic, dtype=np.float64).reshape(-1)


def _outcome(tau: float, p: float, alpha: float, tasks: int, groups: int) -> str:
    if tasks < MIN_TASKS or groups < 2 or not np.isfinite(tau):
        return UNINFORMATIVE
    if p >= alpha:
        return NOT_SIGNIFICANT
    return AGREE if tau > 0 else CONTRADICT


def group_relations(values: pd.DataFrame, study: Study, *, registry: Registry, alpha: float,
                    information: pd.DataFrame | None = None) -> pd.DataFrame:
    """Welch's test between the task values of every ordered pair of the study's groups, per metric and basis.

    Parameters are those of :func:`rank_agreement` (no draws).

    Returns
    -------
    pandas.DataFrame, columns :data:`RELATION_COLUMNS`
        One row per (metric, basis, easier group, harder group), pairs in group order over the groups that have
        tasks in the study; empty without groups.
    """
    difficulty = study.difficulty()
    if not difficulty:
        return pd.DataFrame(columns=list(RELATION_COLUMNS))
    order = [g for g in study.groups.order if g in {study.groups.order[r] for r in difficulty.values()}]
    checked = information if information is not None and not information.empty else None
    rows = []
    for metric in _ranked(values, registry):
        for basis, easiness, _ in _bases(values, metric, difficulty, registry, None, checked):
            members = {g: easiness[[t for t in easiness.index if study.groups.order[difficulty[t]] == g]].to_numpy()
                       for g in order}
            for i, easier in enumerate(order):
                for harder in order[i + 1:]:
                    a, b = members[easier], members[harder]
                    row = {"metric": metric, "basis": basis, "easier": easier, "harder": harder,
                           "tasks_easier": a.size, "tasks_harder": b.size,
                           "mean_easier": float(a.mean()) if a.size else float("nan"),
                           "mean_harder": float(b.mean()) if b.size else float("nan"),
                           "statistic": float("nan"), "pvalue": float("nan"), "outcome": UNINFORMATIVE}
                    if a.size >= 2 and b.size >= 2 and (np.ptp(a) > 0 or np.ptp(b) > 0):
                        test = scipy.stats.ttest_ind(a, b, equal_var=False)
                        row["statistic"], row["pvalue"] = float(test.statistic), float(test.pvalue)
                        significant = np.isfinite(row["pvalue"]) and row["pvalue"] < alpha
                        row["outcome"] = (NOT_SIGNIFICANT if not significant
                                          else AGREE if row["statistic"] > 0 else CONTRADICT)
                    rows.append(row)
    return pd.DataFrame(rows, columns=list(RELATION_COLUMNS))
