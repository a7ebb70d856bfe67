"""The verdict in words, generated from the verdict artefact: one or two sentences, then the details."""

from __future__ import annotations

import pandas as pd

from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import num, pvalue
from taskcomplexity.report.verdict_tables import survival_tables
from taskcomplexity.verdict.references import reference_label


def _count(summary: pd.DataFrame, metric: str) -> tuple[int, int]:
    row = summary.set_index("metric").loc[metric]
    return int(row["agreements"]), int(row["contradictions"])


def headline(data: StudyData, *, alpha: float) -> list[str]:
    """Plain-text sentences; the first one or two are the headline.

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
        return [f"The study gives no relation to judge between its {len(data.tasks)} "
                f"task{'s' if len(data.tasks) != 1 else ''}, so there is no verdict: the page shows the metrics of "
                "each task. Add relations (easier, harder, kind) to the study file to judge them."]
    relations = verdict[["easier", "harder"]].drop_duplicates().shape[0]
    scored = summary.assign(net=summary["agreements"] - summary["contradictions"],
                            label=summary["metric"].map(registry.label))
    best = scored.sort_values(["net", "agreements"], ascending=False, kind="stable").iloc[0]
    worst = scored.sort_values(["contradictions", "net"], ascending=[False, True], kind="stable").iloc[0]
    sentences = []
    primary = [m.name for m in registry if m.primary and m.name in set(summary["metric"])]
    if primary:
        parts = [f"{registry.label(m)} agrees with {a} and contradicts {c}" for m in primary
                 for a, c in [_count(summary, m)]]
        rest = "not significant or undefined" if (verdict["outcome"] == "undefined").any() else "not significant"
        sentences.append(f"Against the {relations} known complexity relations, " + "; ".join(parts)
                         + f" (Welch's test, p < {alpha:g}; the rest are {rest}).")
    if worst["contradictions"] > 0:
        example = verdict[(verdict["metric"] == worst["metric"]) & (verdict["outcome"] == "contradict")].iloc[0]
        contradiction = (f"; {worst['label']} contradicts it most often ({int(worst['contradictions'])} of "
                         f"{int(worst['relations'])}): for example, it rates {data.name(example['harder'])} easier "
                         f"than {data.name(example['easier'])}")
    else:
        contradiction = "; no metric contradicts it significantly"
    sentences.append(f"Of all {len(summary)} measures, {best['label']} agrees with the known order most often "
                     f"({int(best['agreements'])} of {int(best['relations'])}){contradiction}.")
    sac = scored[scored["metric"].map(lambda m: m in registry and registry[m].stage == "sac")]
    if sac.empty:
        sentences.append("SAC curves were not computed, so no empirical (training) order is checked.")
    else:
        first = sac.iloc[0]
        judged = int(first["relations"]) - int(first["undefined"])
        sentences.append(f"The empirical order of training ({first['label']}) agrees with {int(first['agreements'])} "
                         f"of {judged} relations it could judge.")
    sentences += reference_sentences(data)
    for quantity, table in survival_tables(data).items():
        others = list(table.columns[2:-1])
        sentences.append(f"{int((table['Survives'] == 'yes').sum())} of {len(table)} verdicts on {quantity} "
                         f"survive a change of estimator ({', '.join(others)}).")
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
