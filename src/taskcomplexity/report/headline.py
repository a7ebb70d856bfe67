"""The verdict in words, generated from the verdict artefact: one or two sentences, then the details."""

from __future__ import annotations

import numpy as np
import pandas as pd

from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import num, of_total, plural, pvalue, significant_int
from taskcomplexity.report.verdict_tables import survival_tables
from taskcomplexity.verdict.references import reference_label


def _count(summary: pd.DataFrame, metric: str) -> dict[str, int]:
    row = summary.set_index("metric").loc[metric]
    return {"agree": int(row["agreements"]), "contradict": int(row["contradictions"]),
            "uninformative": int(row.get("uninformative", 0))}


def information_sentences(data: StudyData) -> list[str]:
    """One sentence per primary metric whose verdicts here measure its estimator: on how many tasks it
    equals its permutation null or sits at its ceiling, and on how many relations that leaves it
    uninformative (empty when every primary verdict rests on values with information)."""
    verdict, registry = data.verdict["verdict"], data.registry
    checked = data.verdict.get("information", pd.DataFrame(columns=["metric", "task", "reason", "informative"]))
    sentences = []
    for metric in (m for m in registry if m.primary):
        rows = verdict[verdict["metric"] == metric.name]
        blank = int((rows["outcome"] == "uninformative").sum())
        if not blank:
            continue
        mine = checked[checked["metric"] == metric.name]
        tasks = len(mine)
        parts = []
        for cause, words in (("permutation null", "equals its permutation null"),
                             ("ceiling", "sits at its ceiling ln N")):
            hit = int(mine["reason"].str.contains(cause).sum())
            if hit:
                parts.append(f"{words} on {of_total(hit, tasks, 'task')}")
        nulls_only = int(((rows["outcome"] == "uninformative") & rows["informative_easier"].astype(bool)
                          & rows["informative_harder"].astype(bool)).sum())
        relations = of_total(nulls_only, len(rows), "relation")
        if nulls_only and parts:
            parts.append(f"on {relations} more its difference between the two tasks is mostly the difference of "
                         "their permutation nulls")
        if parts:
            subject = f"{metric.label} " + ", and ".join(parts)
        elif nulls_only:
            subject = (f"On {relations}, {metric.label}'s difference between the two tasks is mostly the difference "
                       "of their permutation nulls")
        else:
            subject = f"{metric.label} carries no information here"
        sentences.append(f"{subject}: its verdict on {of_total(blank, len(rows), 'relation')} measures the estimator, "
                         "not the tasks (uninformative).")
    return sentences


def headline(data: StudyData, *, alpha: float) -> list[str]:
    """Plain-text sentences; the first one or two are the headline.

    When a primary metric's verdicts rest on values without information (its permutation null, its
    ceiling), that comes first, before any count of agreements.

    Parameters
    ----------
    data : StudyData
        The study's artefacts (its verdict tables, registry and names).
    alpha : float
        The significance cut-off used (for the wording).
    """
    verdict, summary, registry = data.verdict["verdict"], data.verdict["summary"], data.registry
    if verdict.empty:
        correlated = reference_sentences(data)
        if correlated:
            return correlated + ["The study gives no relation (easier, harder, kind) to judge, so there is no "
                                 "verdict by relation."]
        return [f"The study gives no relation to judge between its {plural(len(data.tasks), 'task')}, so there is "
                "no verdict: the page shows the metrics of each task. Add relations (easier, harder, kind) to the "
                "study file to judge them."]
    relations = verdict[["easier", "harder"]].drop_duplicates().shape[0]
    sentences = information_sentences(data)
    primary = [m.name for m in registry if m.primary and m.name in set(summary["metric"])]
    if primary:
        parts = []
        for m in primary:
            counts = _count(summary, m)
            if counts["uninformative"] == relations:
                parts.append(f"{registry.label(m)} is uninformative on {'it' if relations == 1 else 'every one'}")
                continue
            if relations == 1:
                word = ("agrees with it" if counts["agree"] else "contradicts it" if counts["contradict"]
                        else "is not significant or undefined on it")
                parts.append(f"{registry.label(m)} {word}")
                continue
            part = f"{registry.label(m)} agrees with {counts['agree']} and contradicts {counts['contradict']}"
            if counts["uninformative"]:
                part += f" and is uninformative on {counts['uninformative']}"
            parts.append(part)
        chosen = verdict[verdict["metric"].isin(primary)]
        rest = [o for o in ("not significant", "undefined") if (chosen["outcome"] == o).any()]
        known = ("Against the known complexity relation" if relations == 1
                 else f"Against the {relations} known complexity relations")
        sentences.append(f"{known}, " + "; ".join(parts) + f" (Welch's test, p < {alpha:g}"
                         + (f"; the rest are {' or '.join(rest)})." if rest else ")."))
    sentences.append(best_measure_sentence(data))
    sac = summary[summary["metric"].map(lambda m: m in registry and registry[m].stage == "sac")]
    if sac.empty:
        sentences.append("SAC curves were not computed, so no empirical (training) order is checked.")
    else:
        first = sac.iloc[0]
        judged = int(first["relations"]) - int(first["undefined"])
        sentences.append(f"The empirical order of training ({registry.label(first['metric'])}) agrees with "
                         f"{int(first['agreements'])} of the {plural(judged, 'relation')} it could judge.")
    sentences += resolve_sentences(data)
    sentences += reference_sentences(data)
    for quantity, table in survival_tables(data).items():
        others = list(table.columns[2:-1])
        kept, total = int((table["Survives"] == "yes").sum()), len(table)
        if total == 1:
            verdicts = f"The verdict on {quantity} {'survives' if kept else 'does not survive'}"
        else:
            verdicts = (f"{'None' if kept == 0 else kept} of the {total} verdicts on {quantity} "
                        f"{'survives' if kept <= 1 else 'survive'}")
        sentences.append(f"{verdicts} a change of estimator ({', '.join(others)}).")
    return sentences


def best_measure_sentence(data: StudyData) -> str:
    """Which measure agrees with the known relations most often, among those on one scale across tasks (a raw
    mean return in each task's own reward units is never promoted), and which contradicts them most often."""
    verdict, summary, registry = data.verdict["verdict"], data.verdict["summary"], data.registry
    comparable = summary[summary["metric"].map(lambda m: m not in registry or registry[m].comparable_across_tasks)]
    scored = comparable.assign(net=comparable["agreements"] - comparable["contradictions"],
                               label=comparable["metric"].map(registry.label))
    best = scored.sort_values(["net", "agreements"], ascending=False, kind="stable").iloc[0]
    worst = scored.sort_values(["contradictions", "net"], ascending=[False, True], kind="stable").iloc[0]
    them = "it" if int(worst["relations"]) == 1 else "them"
    if worst["contradictions"] > 0:
        example = verdict[(verdict["metric"] == worst["metric"]) & (verdict["outcome"] == "contradict")].iloc[0]
        often = (f" most often ({int(worst['contradictions'])} of {int(worst['relations'])})"
                 if int(worst["relations"]) > 1 else "")
        contradiction = (f"{worst['label']} contradicts {them}{often}: for example, it rates "
                         f"{data.name(example['harder'])} easier than {data.name(example['easier'])}")
    else:
        contradiction = f"no measure contradicts {them} significantly"
    left_out = len(summary) - len(comparable)
    among = (f"Of the {plural(len(comparable), 'measure')} on one scale across tasks"
             + (f" ({left_out} in each task's own reward units left out)" if left_out else ""))
    if int(best["agreements"]) == 0:
        return f"{among}, none agrees significantly with any known relation; {contradiction}."
    if int(best["relations"]) == 1:
        return f"{among}, {best['label']} agrees with the known relation; {contradiction}."
    return (f"{among}, {best['label']} agrees with the known relations most often ({int(best['agreements'])} of "
            f"{int(best['relations'])}); {contradiction}.")


def resolve_sentences(data: StudyData) -> list[str]:
    """For each primary metric with relations not significant (on values with information): the N (at this M)
    at which the Welch test would resolve them, from the verdict's estimate (the batch sd falling as N^-1/2).
    The verdict table gives the estimate of every unresolved relation, uninformative ones included."""
    verdict, registry = data.verdict["verdict"], data.registry
    sentences = []
    for metric in (m for m in registry if m.primary):
        rows = verdict[(verdict["metric"] == metric.name) & (verdict["outcome"] == "not significant")
                       & np.isfinite(verdict["policies_to_resolve"])
                       & (verdict["policies_to_resolve"] > verdict["policies"])]
        if rows.empty:
            continue
        n = int(rows["policies"].max())
        needs = sorted(rows["policies_to_resolve"])
        span = (f"N ≈ {significant_int(needs[0])}" if len(needs) == 1 else
                f"N ≈ {significant_int(needs[0])} to {significant_int(needs[-1])}")
        sentences.append(f"More sampling: {plural(len(rows), 'unresolved relation')} of {metric.label} would be "
                         f"resolved at {span} policies (now N = {n:,}, same M; assuming the batches' sd falls as "
                         "N^-1/2 and the difference stays as measured).")
    return sentences


def reference_sentences(data: StudyData) -> list[str]:
    """One sentence per reference score: the primary metrics' Pearson r with it, and the measure most
    correlated with it (from the verdict's ``correlations``)."""
    correlated, registry = data.verdict["correlations"], data.registry
    metrics = correlated[(correlated["quantity"] == correlated["metric"]) & correlated["pearson_r"].notna()]
    sentences = []
    for reference, rows in metrics.groupby("reference", sort=False):
        rows = rows.set_index("metric")
        primary = [m.name for m in registry if m.primary and m.name in rows.index]
        parts = [f"{registry.label(m)} r = {num(rows.loc[m, 'pearson_r'], 2)} (p = {pvalue(rows.loc[m, 'pearson_p'])})"
                 for m in primary]
        best = rows["pearson_r"].idxmax()
        tasks = int(rows["tasks"].max())
        sentence = f"Against {reference_label(reference)} across {tasks} tasks, " + (
            "; ".join(parts) + "; " if parts else "")
        sentences.append(sentence + f"the measure most correlated with it is {registry.label(best)} "
                                    f"(r = {num(rows.loc[best, 'pearson_r'], 2)}, p = "
                                    f"{pvalue(rows.loc[best, 'pearson_p'])}; Pearson, on the metrics' easiness).")
    return sentences
