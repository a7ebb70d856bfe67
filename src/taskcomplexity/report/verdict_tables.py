"""Display tables of the verdict artefact: the relation × metric matrix, the summary, survival, the full table."""

from __future__ import annotations

import pandas as pd

from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import num, pvalue
from taskcomplexity.report.labels import kind_label
from taskcomplexity.verdict import by_relation

SYMBOLS = {"agree": "✓", "contradict": "✗", "not significant": "–", "undefined": "?"}
RELATION = "Known relation (easier < harder)"


def relation_name(data: StudyData, easier: str, harder: str) -> str:
    return f"{data.name(easier)} < {data.name(harder)}"


def verdict_matrix(data: StudyData) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Relations × metrics of outcome symbols, and the tooltip text of every cell.

    Returns
    -------
    (matrix, titles) : pandas.DataFrame, pandas.DataFrame
        ``Known relation``, ``Kind`` and one column per metric (short label) with ✓ (agree),
        ✗ (contradict), – (not significant) or ? (undefined); ``titles`` holds "value vs value, p = …".
    """
    verdict = data.verdict["verdict"]
    relations = verdict[["easier", "harder", "kind"]].drop_duplicates()
    metrics = list(dict.fromkeys(verdict["metric"]))
    indexed = verdict.set_index(["metric", "easier", "harder"])
    rows, tips = [], []
    for easier, harder, kind in relations.itertuples(index=False):
        row = {RELATION: relation_name(data, easier, harder), "Kind": kind_label(kind)}
        tip = dict.fromkeys(row, "")
        for metric in metrics:
            column = data.registry.short(metric)
            v = indexed.loc[(metric, easier, harder)]
            row[column] = SYMBOLS[v["outcome"]]
            tip[column] = (f"{v['outcome']}: {num(v['value_easier'])} vs {num(v['value_harder'])}, "
                           f"p = {pvalue(v['pvalue'])}")
        rows.append(row)
        tips.append(tip)
    return pd.DataFrame(rows), pd.DataFrame(tips)


def verdict_display(data: StudyData) -> pd.DataFrame:
    """The full verdict table, one row per (metric, relation), formatted."""
    verdict = data.verdict["verdict"]
    pairs = list(zip(verdict["value_easier"], verdict["value_harder"], strict=True))
    return pd.DataFrame({
        "Metric": verdict["metric"].map(data.registry.label),
        "Kind": verdict["kind"].map(kind_label),
        "Easier task": verdict["easier"].map(data.name),
        "Harder task": verdict["harder"].map(data.name),
        "Value (easier)": [num(a, like=max(abs(a), abs(b))) for a, b in pairs],
        "Value (harder)": [num(b, like=max(abs(a), abs(b))) for a, b in pairs],
        "Outcome": verdict["outcome"],
        "p": verdict["pvalue"].map(pvalue),
        "Samples": [f"{a} vs {b}" for a, b in zip(verdict["samples_easier"], verdict["samples_harder"], strict=True)],
    })


def summary_display(data: StudyData) -> pd.DataFrame:
    """The per-metric summary: counts, Kendall's τ per order, correlation with the reference scores."""
    summary = data.verdict["summary"]
    table = pd.DataFrame({
        "Metric": summary["metric"].map(data.registry.label),
        "Family": summary["metric"].map(lambda m: data.registry[m].family if m in data.registry else ""),
    })
    if len(data.verdict["verdict"]):
        table["Relations"] = summary["relations"]
        table["Agree"] = summary["agreements"]
        table["Contradict"] = summary["contradictions"]
        table["Not significant"] = summary["not_significant"]
        if summary["undefined"].any():
            table["Undefined"] = summary["undefined"]
    for column in [c for c in summary.columns if c.startswith("kendall_tau_")]:
        table[f"τ {column.removeprefix('kendall_tau_')}"] = summary[column].map(lambda x: num(x, 2))
    for name, title in (("pearson", "Pearson r"), ("spearman", "Spearman r")):
        if f"{name}_r" in summary.columns:
            table[f"{title} (p)"] = [f"{num(r, 2)} ({pvalue(p)})" for r, p in zip(summary[f"{name}_r"],
                                                                                summary[f"{name}_p"], strict=True)]
    return table


def survival_tables(data: StudyData) -> dict[str, pd.DataFrame]:
    """Per quantity estimated by several metrics (e.g. I(Θ; R)): does each verdict survive a change of estimator?

    Returns
    -------
    dict of quantity to pandas.DataFrame
        ``Known relation``, ``Kind``, one outcome column per metric (labels) and ``Survives`` (yes/no);
        only quantities with at least two metrics in the verdict.
    """
    verdict = data.verdict["verdict"]
    quantities = dict.fromkeys(m.quantity for m in data.registry if m.quantity)
    tables = {}
    for quantity in quantities:
        metrics = [m.name for m in data.registry if m.quantity == quantity]
        wide = by_relation(verdict, metrics)
        if wide.empty:
            continue
        wide.insert(0, RELATION, [relation_name(data, a, b) for a, b in zip(wide.pop("easier"), wide.pop("harder"),
                                                                             strict=True)])
        wide["kind"] = wide["kind"].map(kind_label)
        wide["survives"] = wide["survives"].map({True: "yes", False: "no"})
        tables[quantity] = wide.rename(columns={"kind": "Kind", "survives": "Survives", **{
            m: data.registry.label(m) for m in metrics}})
    return tables
