"""Display tables of the verdict artefact: the relation × metric matrix, the summary, survival, the full
table, the reference scores and the correlations with them, and the published numbers beside ours."""

from __future__ import annotations

import numpy as np
import pandas as pd

from taskcomplexity.report.budget import to_resolve
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import MISSING, num, percent, plural, pvalue
from taskcomplexity.report.labels import kind_label
from taskcomplexity.report.outcomes import OUTCOME_DISPLAY, UNINFORMATIVE_REASONS, mark, uninformative_reasons
from taskcomplexity.verdict import by_relation
from taskcomplexity.verdict.references import on_values, reference_label
from taskcomplexity.verdict.replication import shown_outcome

SYMBOLS = {outcome: shown.mark for outcome, shown in OUTCOME_DISPLAY.items()}
"""Outcome → its matrix mark (from :data:`~taskcomplexity.report.outcomes.OUTCOME_DISPLAY`)."""
RELATION = "Known relation (easier < harder)"


def relation_name(data: StudyData, easier: str, harder: str) -> str:
    return f"{data.name(easier)} < {data.name(harder)}"


def headline_metrics(data: StudyData) -> tuple[list[str], dict[str, str], str | None]:
    """The metrics of the verdict box's matrix: every primary metric, each family's most agreeing other
    metric, and the metric that contradicts the known relations most often.

    "Most agreeing" is the most agreements net of contradictions, then the most agreements, then registry
    order; "contradicts most often" the most contradictions, then the fewest net agreements, then registry
    order (the orders the headline's words use). As in the headline, only metrics on one scale across tasks
    are candidates (not a raw return in each task's own units), a family's representative agrees with at
    least one relation, and a metric whose every outcome is undefined is not a candidate. The full matrix
    (every metric) is the appendix's.

    Returns
    -------
    (metrics, representatives, contradicting) : list of str, dict of str to str, str or None
        The chosen metrics in registry order; family → its most agreeing metric other than a primary one;
        the metric that contradicts most often (None when none contradicts).
    """
    verdict, registry = data.verdict["verdict"], data.registry
    judged = registry.order(verdict["metric"])
    family = {m: registry[m].family if m in registry else "other" for m in judged}
    primary = [m for m in judged if m in registry and registry[m].primary]
    counts = verdict.assign(agree=verdict["outcome"] == "agree", contradict=verdict["outcome"] == "contradict",
                            defined=verdict["outcome"] != "undefined").groupby("metric", sort=False)[
        ["agree", "contradict", "defined"]].sum()
    comparable = [m for m in judged if m not in registry or registry[m].comparable_across_tasks]
    candidates = [m for m in comparable if counts.loc[m, "defined"] > 0]
    net = {m: int(counts.loc[m, "agree"] - counts.loc[m, "contradict"]) for m in candidates}
    representatives = {}
    for name in dict.fromkeys(family.values()):
        members = [m for m in candidates if family[m] == name and m not in primary and counts.loc[m, "agree"] > 0]
        if members:
            representatives[name] = min(members, key=lambda m: (-net[m], -counts.loc[m, "agree"], judged.index(m)))
    against = [m for m in candidates if counts.loc[m, "contradict"] > 0]
    contradicting = min(against, key=lambda m: (-counts.loc[m, "contradict"], net[m], judged.index(m)),
                        default=None)
    chosen = set(primary) | set(representatives.values()) | ({contradicting} - {None})
    return [m for m in judged if m in chosen], representatives, contradicting


def information_reasons(data: StudyData) -> dict[tuple[str, str], str]:
    """(metric, task) → the information check's reason ("" when the value carries information)."""
    checked = data.verdict.get("information")
    if checked is None or checked.empty:
        return {}
    return dict(zip(zip(checked["metric"].astype(str), checked["task"].astype(str), strict=True),
                    checked["reason"].fillna("").astype(str), strict=True))


def reasons_shown(data: StudyData, metrics) -> set[str]:
    """The reasons (keys of :data:`~taskcomplexity.report.outcomes.UNINFORMATIVE_REASONS`) behind the ○ cells of
    ``metrics`` in the verdict: what the legend of a matrix of those metrics lists."""
    verdict, known = data.verdict["verdict"], information_reasons(data)
    chosen = verdict[verdict["metric"].isin(list(metrics))]
    return {key for _, row in chosen.iterrows() for key in uninformative_reasons(row, known)}


def verdict_matrix(data: StudyData, metrics: list[str] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Relations × metrics of outcome marks, and the tooltip text of every cell.

    Parameters
    ----------
    data : StudyData
        The study's verdict.
    metrics : list of str, optional
        The metric columns, in order (default: every metric of the verdict).

    Returns
    -------
    (matrix, titles) : pandas.DataFrame, pandas.DataFrame
        ``Known relation``, ``Kind`` and one column per metric (short label) with each outcome's mark
        (:data:`~taskcomplexity.report.outcomes.OUTCOME_DISPLAY`); ``titles`` holds "value vs value, p = …",
        and for ○ the reason the verdict is uninformative.
    """
    verdict, known = data.verdict["verdict"], information_reasons(data)
    relations = verdict[["easier", "harder", "kind"]].drop_duplicates()
    metrics = list(dict.fromkeys(verdict["metric"])) if metrics is None else list(metrics)
    indexed = verdict.set_index(["metric", "easier", "harder"])
    rows, tips = [], []
    for easier, harder, kind in relations.itertuples(index=False):
        row = {RELATION: relation_name(data, easier, harder), "Kind": kind_label(kind)}
        tip = dict.fromkeys(row, "")
        for metric in metrics:
            column = data.registry.short(metric)
            v = indexed.loc[(metric, easier, harder)]
            row[column] = mark(v["outcome"])
            why = uninformative_reasons({**v, "metric": metric, "easier": easier, "harder": harder}, known)
            because = f" ({'; '.join(UNINFORMATIVE_REASONS[k] for k in why)})" if why else ""
            tip[column] = (f"{data.registry.label(metric)}, {v['outcome']}{because}: {num(v['value_easier'])} vs "
                           f"{num(v['value_harder'])}, p = {pvalue(v['pvalue'])}")
        rows.append(row)
        tips.append(tip)
    return pd.DataFrame(rows), pd.DataFrame(tips)


def outcome_words(matrix: pd.DataFrame) -> pd.DataFrame:
    """A matrix of marks with each mark spelled out as its outcome (for the table files)."""
    return matrix.replace({shown.mark: outcome for outcome, shown in OUTCOME_DISPLAY.items()})


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
        "Nulls' share of Δ": verdict["null_share_of_difference"].map(percent),
        "To resolve": to_resolve(data).to_numpy(),
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
        if summary["uninformative"].any():
            table["Uninformative"] = summary["uninformative"]
        if summary["undefined"].any():
            table["Undefined"] = summary["undefined"]
    for column in [c for c in summary.columns if c.startswith("kendall_tau_")]:
        table[f"τ {column.removeprefix('kendall_tau_')}"] = summary[column].map(lambda x: num(x, 2))
    correlated = on_values(data.verdict["correlations"])
    for reference in dict.fromkeys(correlated["reference"]):
        chosen = correlated[(correlated["reference"] == reference) & (correlated["quantity"] == correlated["metric"])]
        cells = {q: r_p(r, p) for q, r, p in zip(chosen["quantity"], chosen["pearson_r"], chosen["pearson_p"],
                                                   strict=True)}
        table[f"r with {reference_label(reference)} (p)"] = [cells.get(m, MISSING) for m in summary["metric"]]
    return table


def r_p(r: float, p: float) -> str:
    """``r (p)`` of a correlation."""
    return f"{num(r, 2)} ({pvalue(p)})"


def quantity_label(data: StudyData, name: str) -> str:
    """Display label of a metric or of a metric's detail (e.g. H(R))."""
    if name in data.registry:
        return data.registry.label(name)
    for metric in data.registry:
        for detail in metric.details:
            if detail.name == name:
                return detail.label
    return name


def reference_table(data: StudyData) -> pd.DataFrame:
    """Per task: every metric of the metrics stage with its shown details, then the reference scores
    (Score(R), Score(A) of Furuta et al. 2021, or the study's own): the original PIC/POIC protocol's table."""
    references = data.verdict["references"]
    names = list(dict.fromkeys(references["reference"]))
    scores = references.set_index(["task", "reference"])["value"]
    columns = [(name, quantity_label(data, name)) for m in data.registry.of_stage("metrics")
               for name in (m.name, *(d.name for d in m.details if d.shown))]
    rows = []
    for _, r in data.metrics.iterrows():
        row = {"Task": data.name(r["task"])}
        row.update({label: num(r[name]) for name, label in columns if name in r})
        row.update({reference_label(n): num(scores.get((r["task"], n), np.nan), 3) for n in names})
        rows.append(row)
    return pd.DataFrame(rows)


def correlation_display(data: StudyData) -> pd.DataFrame:
    """Pearson r (p) and Spearman ρ of every metric and shown detail with every reference score, across tasks."""
    correlated = on_values(data.verdict["correlations"])
    references = list(dict.fromkeys(correlated["reference"]))
    rows = []
    for quantity, group in correlated.groupby("quantity", sort=False):
        by_reference = group.set_index("reference")
        metric = by_reference["metric"].iloc[0]
        row = {"Quantity": quantity_label(data, quantity),
               "Of metric": "" if quantity == metric else data.registry.label(metric)}
        for reference in references:
            if reference in by_reference.index:
                c = by_reference.loc[reference]
                row[f"r with {reference_label(reference)} (p)"] = r_p(c["pearson_r"], c["pearson_p"])
                row[f"ρ with {reference_label(reference)}"] = num(c["spearman_r"], 2)
        row["Tasks"] = int(group["tasks"].max())
        rows.append(row)
    return pd.DataFrame(rows)


def published_values_display(data: StudyData, name: str) -> pd.DataFrame:
    """Per task of the study's published table ``name``: each quantity it prints, ours (published).

    Ours are the whole-sample values of the metrics artefact (a metric or a shown detail) or the verdict's reference
    scores (Score(A), Score(R)); a cell is ``ours (published)``."""
    table = data.study.published.tables[name]
    scores = data.verdict["references"].set_index(["task", "reference"])["value"]
    metrics = data.metrics.set_index("task")
    rows = []
    for task in [t for t in data.tasks if t in table.values]:
        row = {"Task": data.name(task)}
        for quantity in table.quantities:
            if not any(quantity in values for values in table.values.values()):
                continue
            if (task, quantity) in scores.index:
                ours = float(scores.loc[(task, quantity)])
            else:
                ours = float(metrics.loc[task, quantity]) if quantity in metrics.columns else np.nan
            printed = table.values[task].get(quantity)
            label = reference_label(quantity) if quantity in set(data.verdict["references"]["reference"]) \
                else quantity_label(data, quantity)
            row[label] = num(ours) if printed is None else f"{num(ours)} ({num(printed)})"
        rows.append(row)
    return pd.DataFrame(rows)


def replication_display(data: StudyData) -> pd.DataFrame:
    """Every published correlation beside ours: r (p) printed, ours with its bootstrap interval, on the
    informative tasks, net of the null, and the outcome as shown (:func:`~taskcomplexity.verdict.replication.
    shown_outcome`: a reproduced finding whose value ours excludes says so)."""
    rows = []
    for _, r in data.verdict["replications"].iterrows():
        interval = (f" [{num(r['pearson_low'], 2)}, {num(r['pearson_high'], 2)}]"
                    if np.isfinite(r["pearson_low"]) else "")
        net = (f"{num(r['net_r'], 2)}" + (f" [{num(r['net_low'], 2)}, {num(r['net_high'], 2)}]"
                                          if np.isfinite(r["net_low"]) else "") + f" ({pvalue(r['net_p'])})"
               if np.isfinite(r["net_r"]) else MISSING)
        informative = MISSING
        if np.isfinite(r["informative_tasks"]):
            tasks = plural(int(r["informative_tasks"]), "task")
            informative = (f"{r_p(r['informative_r'], r['informative_p'])}, {tasks}" if np.isfinite(r["informative_r"])
                           else f"{tasks}: too few")
        rows.append({"Quantity": quantity_label(data, r["quantity"]), "With": reference_label(r["reference"]),
                     "Published r (p)": f"{num(r['published_r'], 3)} ({pvalue(r['published_p'])})",
                     "Ours r [interval] (p)": r_p(r["pearson_r"], r["pearson_p"]).replace(" (", interval + " (", 1),
                     "Tasks": int(r["tasks"]) if np.isfinite(r["tasks"]) else MISSING,
                     "Informative tasks only": informative, "Net of the null": net,
                     "Outcome": shown_outcome(r), "Why": r["why"]})
    return pd.DataFrame(rows)


def survival_tables(data: StudyData) -> dict[str, pd.DataFrame]:
    """Per quantity estimated by several metrics (e.g. I(Θ; R)): does each verdict survive a change of estimator?

    Returns
    -------
    dict of quantity to pandas.DataFrame
        ``Known relation``, ``Kind``, one outcome column per metric (labels) and ``Survives``
        (:func:`~taskcomplexity.verdict.judge.survival`: yes, no, one informative estimator, no significant
        verdict); only quantities with at least two metrics in the verdict.
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
        tables[quantity] = wide.rename(columns={"kind": "Kind", "survives": "Survives", **{
            m: data.registry.label(m) for m in metrics}})
    return tables
