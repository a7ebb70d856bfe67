"""The report's verdict: every metric against every known relation, and how robust the answers are.

Builds on :mod:`taskcomplexity.metrics.verdict` (one call per study, with p-values computed here so
that every metric family uses its own samples):

========================  =====================  ==================================================
metric family             values                 samples of the Welch test
========================  =====================  ==================================================
PIC, POIC                 whole-sample estimate  the metrics stage's consecutive policy batches
RWG statistics            whole-sample value     the same batches, recomputed from the returns
other PIC estimators      whole-sample estimate  the diagnostics stage's batches
SAC                       mean across seeds      one value per seed (≥ 2 seeds, else untested)
========================  =====================  ==================================================

Directions (``higher_is_easier``), and why:

- ``pic``, ``poic`` — higher is easier: the paper's claim. More information between the policy
  parameters and the return (PIC) or the optimality of the episode (POIC) means that the choice of
  parameters matters, which is what optimisation exploits.
- ``pic_miller_madow``, ``pic_knn``, ``pic_minus_null`` — higher is easier: other estimators of the
  same quantity I(Θ; R) as PIC (bias-corrected, nearest-neighbour, and net of its permutation null),
  so they inherit PIC's direction; only the estimator changes.
- ``score`` (score_R) — higher is easier: the mean return of random policies sits closer to the best
  return found, so good behaviour is common under the prior and cheap to find.
- ``r_mean`` — higher is easier: rewards are what the agent maximises, so a prior whose average
  behaviour already earns more starts closer to the goal. Returns are in task units (a longer arm
  has larger distances; sparse returns count steps), so this is a crude baseline across tasks.
- ``variance`` — higher is easier: the spread of returns across random behaviour (normalised by
  the return range) is the signal that random search and policy gradients follow; a task where
  every policy earns the same return gives no direction to improve. A baseline of Furuta et al.
- ``sac_final``, ``sac_auc`` (and ``sac_her_…``) — higher is easier by definition of the empirical
  order: a higher normalised final return, and a larger area under the normalised learning curve
  (faster convergence to a higher return), mean an easier task.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from taskcomplexity import metrics as est
from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL, welch_test
from taskcomplexity.metrics.verdict import Relation
from taskcomplexity.report.tables import ARM_LABELS, split_task_id


@dataclass(frozen=True)
class MetricInfo:
    """A metric the verdict checks.

    Attributes
    ----------
    name : str
        Column name in the tidy tables.
    label : str
        Name shown in figures and tables.
    unit : str
        Unit of its values.
    higher_is_easier : bool
        Direction (justified in the module docstring).
    family : str
        ``"random policies"``, ``"estimator"`` or ``"SAC"``.
    short : str
        Compact name for matrix headers.
    """

    name: str
    label: str
    unit: str
    higher_is_easier: bool
    family: str
    short: str


METRICS: dict[str, MetricInfo] = {
    m.name: m
    for m in (
        MetricInfo("pic", "PIC", "nats", True, "random policies", "PIC"),
        MetricInfo("poic", "POIC", "nats", True, "random policies", "POIC"),
        MetricInfo("score", "score_R", "fraction of range", True, "random policies", "score_R"),
        MetricInfo("r_mean", "mean return", "sum of rewards", True, "random policies", "mean R"),
        MetricInfo("variance", "variance", "sum of rewards", True, "random policies", "var."),
        MetricInfo("pic_miller_madow", "PIC (Miller–Madow)", "nats", True, "estimator", "PIC MM"),
        MetricInfo("pic_knn", "PIC (k-NN)", "nats", True, "estimator", "PIC kNN"),
        MetricInfo("pic_minus_null", "PIC − null", "nats", True, "estimator", "PIC − null"),
        MetricInfo("sac_final", "SAC final", "normalised return", True, "SAC", "SAC final"),
        MetricInfo("sac_auc", "SAC AUC", "normalised return", True, "SAC", "SAC AUC"),
        MetricInfo("sac_her_final", "SAC+HER final", "normalised return", True, "SAC", "HER final"),
        MetricInfo("sac_her_auc", "SAC+HER AUC", "normalised return", True, "SAC", "HER AUC"),
    )
}
"""Every metric of the verdict, in the order of its tables."""

RWG_METRICS = ("pic", "poic", "score", "r_mean", "variance")
ESTIMATOR_METRICS = ("pic_miller_madow", "pic_knn", "pic_minus_null")
SURVIVAL_METRICS = ("pic", "pic_miller_madow", "pic_knn", "pic_minus_null")
"""The estimators of I(Θ; R) compared by :func:`survival_table` (histogram PIC first)."""

SAC_METRICS = {"sac": ("sac_final", "sac_auc"), "sac+her": ("sac_her_final", "sac_her_auc")}
"""Verdict metric names of each SAC variant: (normalised final return, normalised AUC)."""

KIND_LABELS = {
    "link_length": "link length",
    "degrees_of_freedom": "DoF",
    "reward": "reward",
    "obstacle": "obstacle",
}


def label(metric: str) -> str:
    """Display name of ``metric`` (the name itself when unknown)."""
    return METRICS[metric].label if metric in METRICS else metric


def short(metric: str) -> str:
    """Compact display name of ``metric`` (the name itself when unknown)."""
    return METRICS[metric].short if metric in METRICS else metric


def rwg_values(metrics: pd.DataFrame) -> pd.DataFrame:
    """Tidy point values of the random-policy metrics.

    Parameters
    ----------
    metrics : pandas.DataFrame
        One row per task (``metrics_frame``), with ``task`` and the columns of :data:`RWG_METRICS`.

    Returns
    -------
    pandas.DataFrame
        ``task``, ``metric``, ``value``.
    """
    return metrics.melt(id_vars="task", value_vars=list(RWG_METRICS), var_name="metric")[["task", "metric", "value"]]


def rwg_samples(batches: Mapping[str, pd.DataFrame], returns: Mapping[str, np.ndarray]) -> pd.DataFrame:
    """Per-batch values of the random-policy metrics, the samples of their Welch tests.

    Parameters
    ----------
    batches : mapping of task id to pandas.DataFrame
        The metrics stage's ``batches.parquet`` (``batch``, ``policies``, ``pic``, ``poic``).
    returns : mapping of task id to numpy.ndarray, shape (N, M)
        The task's returns; score_R, mean return and variance are recomputed on the same
        consecutive policy batches (sizes from ``batches``).

    Returns
    -------
    pandas.DataFrame
        ``task``, ``metric``, ``value``; one row per (task, metric, batch).
    """
    rows = []
    for task, table in batches.items():
        for metric in ("pic", "poic"):
            rows += [{"task": task, "metric": metric, "value": float(v)} for v in table[metric]]
        if task not in returns:
            continue
        bounds = np.cumsum([0, *table["policies"].astype(int)])
        for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
            score = est.random_sampling_score(returns[task][start:stop])
            for metric in ("score", "r_mean", "variance"):
                rows.append({"task": task, "metric": metric, "value": float(getattr(score, metric))})
    return pd.DataFrame(rows, columns=["task", "metric", "value"])


def estimator_values(estimators: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Tidy point values of the alternative PIC estimators from each task's ``estimators.parquet``."""
    rows = [
        {"task": task, "metric": metric, "value": float(table[metric].iloc[0])}
        for task, table in estimators.items()
        for metric in ESTIMATOR_METRICS
    ]
    return pd.DataFrame(rows, columns=["task", "metric", "value"])


def estimator_samples(batches: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Per-batch values of the alternative PIC estimators from each task's diagnostics ``batches.parquet``."""
    rows = [
        {"task": task, "metric": metric, "value": float(v)}
        for task, table in batches.items()
        for metric in ESTIMATOR_METRICS
        for v in table[metric]
    ]
    return pd.DataFrame(rows, columns=["task", "metric", "value"])


def sac_values_and_samples(per_seed: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """SAC verdict metrics from per-seed summaries.

    Parameters
    ----------
    per_seed : pandas.DataFrame
        :func:`~taskcomplexity.report.sac_summary.seed_summary` (``task``, ``variant``, ``seed``,
        ``final_normalised``, ``auc_normalised``).

    Returns
    -------
    (values, samples) : pandas.DataFrame, pandas.DataFrame
        Tidy ``task``, ``metric``, ``value``: the mean across seeds, and one row per seed. Variants
        other than those of :data:`SAC_METRICS` are ignored.
    """
    rows = []
    for variant, (final, auc) in SAC_METRICS.items():
        chosen = per_seed[per_seed["variant"] == variant]
        for column, metric in (("final_normalised", final), ("auc_normalised", auc)):
            for task, value in zip(chosen["task"], chosen[column], strict=True):
                if np.isfinite(value):
                    rows.append({"task": task, "metric": metric, "value": float(value)})
    samples = pd.DataFrame(rows, columns=["task", "metric", "value"])
    values = samples.groupby(["task", "metric"], sort=False, as_index=False)["value"].mean()
    return values, samples


def verdict_table(
    values: pd.DataFrame,
    samples: pd.DataFrame,
    *,
    alpha: float = SIGNIFICANCE_LEVEL,
    relations: Iterable[Relation],
) -> pd.DataFrame:
    """Every (metric, known relation) with its outcome: agree, contradict or not significant.

    Parameters
    ----------
    values : pandas.DataFrame
        Tidy point values (``task``, ``metric``, ``value``) of metrics named in :data:`METRICS`. A
        relation involving a non-finite value (e.g. score_R of a task whose returns are all equal)
        gets the outcome "undefined" and NaN values.
    samples : pandas.DataFrame
        Tidy samples of the same metrics (batches or seeds). A pair is tested with Welch's t-test
        when both tasks have at least 2 samples; otherwise its p-value is NaN and the outcome is
        "not significant" (untested, never assumed significant).
    alpha : float, default 0.005
        A difference is significant when p < alpha.
    relations : iterable of Relation
        The study's known relations (those whose tasks lack values are skipped).

    Returns
    -------
    pandas.DataFrame
        The columns of :func:`taskcomplexity.metrics.verdict` plus ``label`` (display name),
        ``samples_easier`` and ``samples_harder`` (sizes of the tested samples), in the metric
        order of :data:`METRICS`.
    """
    relations = tuple(relations)
    finite = np.isfinite(values["value"].to_numpy(dtype=np.float64))
    undefined = set(zip(values.loc[~finite, "metric"], values.loc[~finite, "task"], strict=True))
    values = values[finite]
    samples = samples[np.isfinite(samples["value"].to_numpy(dtype=np.float64))]
    order = [m for m in METRICS if m in set(values["metric"])]
    order += [m for m in dict.fromkeys(values["metric"]) if m not in order]
    rank = {metric: i for i, metric in enumerate(order)}
    values = values.iloc[np.argsort(values["metric"].map(rank).to_numpy(), kind="stable")]
    counts = samples.groupby(["metric", "task"]).size()
    pvalues, sizes = [], {}
    for metric in order:
        for relation in relations:
            draws = [
                samples.loc[(samples["metric"] == metric) & (samples["task"] == task), "value"].to_numpy()
                for task in (relation.easier, relation.harder)
            ]
            testable = all(d.size >= 2 for d in draws)
            pvalue = welch_test(*draws).pvalue if testable else float("nan")
            pvalues.append({"metric": metric, "task_a": relation.easier, "task_b": relation.harder, "pvalue": pvalue})
            sizes[(metric, relation.easier, relation.harder)] = (
                int(counts.get((metric, relation.easier), 0)),
                int(counts.get((metric, relation.harder), 0)),
            )
    directions = {m: METRICS[m].higher_is_easier if m in METRICS else True for m in order}
    table = est.verdict(
        values,
        higher_is_easier=directions,
        pvalues=pd.DataFrame(pvalues, columns=["metric", "task_a", "task_b", "pvalue"]),
        alpha=alpha,
        relations=relations,
    )
    table = _with_undefined(table, values, undefined, order, relations)
    table.insert(1, "label", table["metric"].map(label))
    pairs = list(zip(table["metric"], table["easier"], table["harder"], strict=True))
    table["samples_easier"] = [sizes.get(p, (0, 0))[0] for p in pairs]
    table["samples_harder"] = [sizes.get(p, (0, 0))[1] for p in pairs]
    return table


def _with_undefined(
    table: pd.DataFrame,
    values: pd.DataFrame,
    undefined: set[tuple[str, str]],
    order: list[str],
    relations: tuple[Relation, ...],
) -> pd.DataFrame:
    """Add an "undefined" row for each (metric, relation) left out because a value is not finite."""
    if not undefined:
        return table
    present = set(zip(values["metric"], values["task"], strict=True)) | undefined
    rows = []
    for metric in order + sorted({m for m, _ in undefined} - set(order)):
        for relation in relations:
            pair = {(metric, relation.easier), (metric, relation.harder)}
            if pair <= present and pair & undefined:
                rows.append(
                    {
                        "metric": metric,
                        "easier": relation.easier,
                        "harder": relation.harder,
                        "kind": relation.kind,
                        "higher_is_easier": METRICS[metric].higher_is_easier if metric in METRICS else True,
                        "value_easier": float("nan"),
                        "value_harder": float("nan"),
                        "difference": float("nan"),
                        "agrees": False,
                        "significant": False,
                        "pvalue": float("nan"),
                        "outcome": "undefined",
                    }
                )
    if not rows:
        return table
    rank = {m: i for i, m in enumerate(order + sorted({m for m, _ in undefined} - set(order)))}
    position = {(r.easier, r.harder): i for i, r in enumerate(relations)}
    merged = pd.concat([table, pd.DataFrame(rows, columns=table.columns)], ignore_index=True)
    keys = [(rank[m], position[(e, h)]) for m, e, h in zip(merged["metric"], merged["easier"], merged["harder"],
                                                            strict=True)]
    return merged.iloc[sorted(range(len(merged)), key=keys.__getitem__)].reset_index(drop=True)


def summary_table(verdict: pd.DataFrame, values: pd.DataFrame, orders=None) -> pd.DataFrame:
    """Per metric: relations judged, agreements, contradictions, not significant, Kendall's τ.

    See :func:`taskcomplexity.metrics.verdict_summary`; adds ``label``, ``family`` and ``undefined``
    (relations with a non-finite value; counted in ``relations``).
    """
    if verdict.empty:
        columns = ["metric", "label", "family", "relations", "agreements", "contradictions", "not_significant",
                   "undefined"]
        return pd.DataFrame(columns=columns)
    finite = np.isfinite(values["value"].to_numpy(dtype=np.float64))
    summary = est.verdict_summary(verdict, values[finite & values["metric"].isin(set(verdict["metric"]))], orders)
    undefined = verdict[verdict["outcome"] == "undefined"].groupby("metric").size()
    summary["undefined"] = summary["metric"].map(undefined).fillna(0).astype(int)
    summary.insert(1, "label", summary["metric"].map(label))
    summary.insert(2, "family", summary["metric"].map(lambda m: METRICS[m].family if m in METRICS else ""))
    return summary


def survival_table(verdict: pd.DataFrame, metrics: Iterable[str] = SURVIVAL_METRICS) -> pd.DataFrame:
    """Does each relation's verdict survive a change of the estimator of I(Θ; R)?

    Parameters
    ----------
    verdict : pandas.DataFrame
        Output of :func:`verdict_table`.
    metrics : iterable of str
        Estimators to compare, default histogram PIC, Miller–Madow, k-NN and PIC minus its null.

    Returns
    -------
    pandas.DataFrame
        One row per relation: ``easier``, ``harder``, ``kind``, one outcome column per estimator
        (display names) and ``survives`` (every estimator reached the same outcome). Empty when
        fewer than two of the estimators are present.
    """
    chosen = verdict[verdict["metric"].isin(list(metrics))]
    if chosen["metric"].nunique() < 2:
        return pd.DataFrame(columns=["easier", "harder", "kind", "survives"])
    wide = est.verdict_by_relation(chosen).rename(columns={"unanimous": "survives"})
    wide = wide.rename(columns=label).reset_index()
    return wide


def _count(summary: pd.DataFrame, metric: str) -> tuple[int, int, int]:
    row = summary.set_index("metric").loc[metric]
    return int(row["agreements"]), int(row["contradictions"]), int(row["not_significant"])


def _pair_phrase(easier_by_metric: str, other: str) -> str:
    """"the 2-link arm easier than the 1-link, L = 1.0 m arm (dense rewards)" and the like."""
    arm_a, reward_a = split_task_id(easier_by_metric)
    arm_b, reward_b = split_task_id(other)
    name_a, name_b = ARM_LABELS.get(arm_a, arm_a), ARM_LABELS.get(arm_b, arm_b)
    if arm_a == arm_b:
        return f"the {name_a} arm easier with {reward_a} than with {reward_b} rewards"
    if reward_a == reward_b:
        return f"the {name_a} arm easier than the {name_b} arm ({reward_a} rewards)"
    return f"the {name_a} arm ({reward_a}) easier than the {name_b} arm ({reward_b})"


def headline(verdict: pd.DataFrame, summary: pd.DataFrame, *, alpha: float = SIGNIFICANCE_LEVEL) -> list[str]:
    """The verdict in words, generated from the numbers: one or two sentences, then the details.

    Parameters
    ----------
    verdict, summary : pandas.DataFrame
        Outputs of :func:`verdict_table` and :func:`summary_table`.
    alpha : float
        The significance cut-off used (for the wording).

    Returns
    -------
    list of str
        Plain-text sentences; the first one or two are the headline.
    """
    if verdict.empty:
        return ["No known relation could be checked: the study needs at least two tasks of environments.md "
                "that are related (for example the same arm with dense and sparse rewards)."]
    relations = verdict[["easier", "harder"]].drop_duplicates().shape[0]
    scored = summary.assign(net=summary["agreements"] - summary["contradictions"])
    best = scored.sort_values(["net", "agreements"], ascending=False, kind="stable").iloc[0]
    worst = scored.sort_values(["contradictions", "net"], ascending=[False, True], kind="stable").iloc[0]

    sentences = []
    paper = [m for m in ("pic", "poic") if m in set(summary["metric"])]
    if paper:
        parts = []
        for metric in paper:
            agree, contradict, _ = _count(summary, metric)
            parts.append(f"{label(metric)} agrees with {agree} and contradicts {contradict}")
        sentences.append(
            f"Against the {relations} known complexity relations, " + "; ".join(parts)
            + f" (Welch's test, p < {alpha:g}; the rest are not significant)."
        )
    contradiction = ""
    if worst["contradictions"] > 0:
        example = verdict[(verdict["metric"] == worst["metric"]) & (verdict["outcome"] == "contradict")].iloc[0]
        contradiction = (
            f"; {worst['label']} contradicts it most often ({int(worst['contradictions'])} of "
            f"{int(worst['relations'])}): for example, it rates {_pair_phrase(example['harder'], example['easier'])}"
        )
    else:
        contradiction = "; no metric contradicts it significantly"
    sentences.append(
        f"Of all {len(summary)} measures, {best['label']} agrees with the known order most often "
        f"({int(best['agreements'])} of {int(best['relations'])}){contradiction}."
    )
    sac = summary[summary["family"] == "SAC"]
    if sac.empty:
        sentences.append("SAC curves were not computed, so no empirical (training) order is checked.")
    else:
        first = sac.iloc[0]
        sentences.append(
            f"The empirical order of training ({first['label']}) agrees with {int(first['agreements'])} of "
            f"{int(first['relations'])} relations it could judge."
        )
    survival = survival_table(verdict)
    if not survival.empty:
        survives = int(survival["survives"].sum())
        sentences.append(
            f"{survives} of {len(survival)} PIC verdicts survive a change of estimator "
            "(Miller–Madow, k-NN, PIC minus its permutation null)."
        )
    return sentences
