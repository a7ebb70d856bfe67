"""The report's part on ordered difficulty groups (a study with ``groups``, e.g. Meta-World's easy … very hard).

It reads the verdict's ``groups`` and ``group_relations`` tables (:mod:`taskcomplexity.verdict.groups`) and writes
the headline sentences (which metric ranks the groups, which contradicts them, which only measures its estimator),
a figure of every ranked metric per task against its group, the rank-agreement table and the group-relations table.

Each metric is read on one basis, :func:`judged_basis`: net of its permutation null when it has one (what is left
of the value once the estimator's own floor is taken away), else its value. A significant order on the value that
is gone net of the null is the estimator's, not the task's.
"""

from __future__ import annotations

import matplotlib as mpl
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from taskcomplexity.report import figures as fig
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import and_list, num, plural, pvalue
from taskcomplexity.report.labels import GROUP_COLOURS
from taskcomplexity.report.writer import Writer
from taskcomplexity.verdict.groups import AGREE, CONTRADICT, NOT_SIGNIFICANT, UNINFORMATIVE
from taskcomplexity.verdict.references import NET_OF_NULL, VALUE


def has_groups(data: StudyData) -> bool:
    """Whether the study declares ordered difficulty groups and the verdict ranked a metric by them."""
    return data.study.groups is not None and len(data.verdict.get("groups", ())) > 0


def group_label(name: str) -> str:
    """A group name as prose: ``very_hard`` → "very hard"."""
    return name.replace("_", " ")


def judged_basis(ranks: pd.DataFrame, metric: str) -> str:
    """The basis a metric is read on: net of its null when the verdict has that basis for it, else its value."""
    bases = set(ranks.loc[ranks["metric"] == metric, "basis"])
    return NET_OF_NULL if NET_OF_NULL in bases else VALUE


def _row(ranks: pd.DataFrame, metric: str, basis: str) -> pd.Series | None:
    found = ranks[(ranks["metric"] == metric) & (ranks["basis"] == basis)]
    return None if found.empty else found.iloc[0]


def _tau(row: pd.Series) -> str:
    """"τ-b = 0.31 (0.25 to 0.36 over policies; 0.12 to 0.48 across tasks), p = 0.002"."""
    parts = []
    if np.isfinite(row["policies_low"]):
        parts.append(f"{num(row['policies_low'], 2)} to {num(row['policies_high'], 2)} over policies")
    if np.isfinite(row["tasks_low"]):
        parts.append(f"{num(row['tasks_low'], 2)} to {num(row['tasks_high'], 2)} across tasks")
    interval = f" ({'; '.join(parts)})" if parts else ""
    return f"τ-b = {num(row['kendall_tau'], 2)}{interval}, p = {pvalue(row['kendall_p'])}"


def verdict_of(ranks: pd.DataFrame, metric: str) -> tuple[str, pd.Series]:
    """What a metric does with the groups: ``ranks``, ``contradicts``, ``estimator`` (significant on its value,
    not net of its null), ``uninformative`` or ``no order``; and the row it is read on."""
    basis = judged_basis(ranks, metric)
    judged, value = _row(ranks, metric, basis), _row(ranks, metric, VALUE)
    if judged["outcome"] == AGREE:
        return "ranks", judged
    if judged["outcome"] == CONTRADICT:
        return "contradicts", judged
    if basis != VALUE and value is not None and value["outcome"] in (AGREE, CONTRADICT):
        return "estimator", value
    if judged["outcome"] == UNINFORMATIVE:
        return "uninformative", judged
    return "no order", judged


def group_sentences(data: StudyData, *, alpha: float) -> list[str]:
    """The headline on the groups: each primary metric's verdict with its τ-b and intervals, then the other
    metrics that rank or contradict the groups (empty without groups)."""
    if not has_groups(data):
        return []
    ranks, registry, groups = data.verdict["groups"], data.registry, data.study.groups
    present = [g for g in groups.order if any(data.study.task(t).group == g for t in data.tasks)]
    counts = {g: sum(data.study.task(t).group == g for t in data.tasks) for g in present}
    order = " < ".join(f"{group_label(g)} ({counts[g]})" for g in present)
    first = (f"Against the published difficulty groups of these {plural(len(data.tasks), 'task')} ({order}; "
             f"{groups.source}), judged by Kendall's τ-b across tasks (p < {alpha:g})")
    clauses = []
    for metric in (m.name for m in registry if m.primary and m.name in set(ranks["metric"])):
        what, row = verdict_of(ranks, metric)
        net = " net of its null" if row["basis"] == NET_OF_NULL else ""
        label = registry.label(metric)
        if what == "ranks":
            clauses.append(f"{label} ranks them{net}: {_tau(row)}")
        elif what == "contradicts":
            clauses.append(f"{label} contradicts them{net}: {_tau(row)}")
        elif what == "estimator":
            judged = _row(ranks, metric, judged_basis(ranks, metric))
            clauses.append(f"{label} orders them on its value ({_tau(row)}) but not net of its null "
                           f"({_tau(judged)}): that order is its estimator's")
        elif what == "uninformative":
            clauses.append(f"{label} is left with {plural(int(row['tasks']), 'task')} to rank{net}, too few to judge")
        else:
            clauses.append(f"{label} does not order them{net}: {_tau(row)}")
    sentences = [first + (": " + "; ".join(clauses) if clauses else "") + "."]
    sentences += information_by_group(data)
    others = {}
    for metric in dict.fromkeys(ranks["metric"]):
        if metric in registry and registry[metric].primary:
            continue
        what, _ = verdict_of(ranks, metric)
        others.setdefault(what, []).append(registry.label(metric))
    named = {"ranks": "rank the groups", "contradicts": "contradict them",
             "estimator": "order them only through their estimator (not net of its null)"}
    said = [f"{and_list(labels)} {verb}" for what, verb in named.items() if (labels := others.get(what))]
    if said:
        sentences.append("Of the other measures, " + "; ".join(said) + ".")
    elif others:
        sentences.append(f"None of the other {plural(sum(map(len, others.values())), 'measure')} ranks the groups "
                         "significantly.")
    return sentences


def information_by_group(data: StudyData) -> list[str]:
    """Per primary metric the information check checks: on how many tasks of each group its value carries
    information, why not on the others, and what more sampling does to that (the plug-in estimator's rules of
    ``docs/explanation/information-check.md``: with B held its nulls shrink with M; under ``metrics.bins=auto``
    more policies do not settle it; a ceiling ln N rises with N)."""
    checked, registry, groups = data.verdict.get("information"), data.registry, data.study.groups
    if checked is None or checked.empty:
        return []
    present = [g for g in groups.order if any(data.study.task(t).group == g for t in data.tasks)]
    sentences = []
    for metric in (m for m in registry if m.primary and m.information is not None):
        mine = checked[checked["metric"] == metric.name].set_index("task")
        if mine.empty:
            continue
        informative = mine["informative"].astype(bool)
        per_group = []
        for group in present:
            tasks = [t for t in data.tasks if data.study.task(t).group == group and t in mine.index]
            per_group.append(f"{group_label(group)} {int(informative[tasks].sum())} of {len(tasks)}")
        reasons = mine.loc[~informative, "reason"].astype(str)
        why = []
        for cause, words in (("permutation null", "equals its permutation null"),
                             ("ceiling", "sits at its ceiling ln N")):
            hit = int(reasons.str.contains(cause).sum())
            if hit:
                why.append(f"on {plural(hit, 'task')} it {words}")
        sentence = (f"The information check finds {metric.label} informative on {int(informative.sum())} of the "
                    f"{plural(len(mine), 'task')} ({', '.join(per_group)})")
        sentence += ("; " + " and ".join(why) if why else "") + "."
        if int((~informative).sum()):
            advice = []
            if metric.information.binned:
                advice.append("with B held (metrics.bins) its nulls shrink with more episodes M, while under "
                              "metrics.bins=auto more policies do not settle it")
            elif metric.information.null:
                advice.append("its nulls move with N and M, and the report does not predict them there: a larger "
                              "budget is measured, not projected")
            if metric.information.ceiling and reasons.str.contains("ceiling").any():
                advice.append("the ceiling ln N rises with the policies N")
            if advice:
                sentence += f" For the rest, {'; '.join(advice)}."
        sentences.append(sentence)
    return sentences


def rank_display(data: StudyData) -> pd.DataFrame:
    """The rank-agreement table as the page shows it: one row per (metric, basis)."""
    ranks, registry = data.verdict["groups"], data.registry
    rows = []
    for _, r in ranks.iterrows():
        rows.append({
            "metric": registry.label(r["metric"]), "basis": r["basis"], "tasks": int(r["tasks"]),
            "Kendall τ-b": num(r["kendall_tau"], 2), "p": pvalue(r["kendall_p"]),
            "over policies": (f"{num(r['policies_low'], 2)} to {num(r['policies_high'], 2)}"
                              if np.isfinite(r["policies_low"]) else "–"),
            "across tasks": (f"{num(r['tasks_low'], 2)} to {num(r['tasks_high'], 2)}"
                             if np.isfinite(r["tasks_low"]) else "–"),
            "Spearman ρ": num(r["spearman_rho"], 2), "outcome": r["outcome"],
        })
    return pd.DataFrame(rows)


def relations_display(data: StudyData) -> pd.DataFrame:
    """The group-relations table: one row per (easier, harder) pair, one column per metric on its judged basis."""
    relations, ranks, registry = data.verdict["group_relations"], data.verdict["groups"], data.registry
    rows = {}
    for metric in dict.fromkeys(relations["metric"]):
        basis = judged_basis(ranks, metric)
        mine = relations[(relations["metric"] == metric) & (relations["basis"] == basis)]
        column = registry.label(metric) + (" (net)" if basis == NET_OF_NULL else "")
        for _, r in mine.iterrows():
            pair = f"{group_label(r['easier'])} < {group_label(r['harder'])}"
            cell = r["outcome"] if r["outcome"] in (UNINFORMATIVE, NOT_SIGNIFICANT) else (
                f"{r['outcome']} (p = {pvalue(r['pvalue'])})")
            rows.setdefault(pair, {"groups (easier < harder)": pair})[column] = cell
    return pd.DataFrame(list(rows.values()))


def group_figure(data: StudyData, metrics: list[str]) -> Figure:
    """Each metric's value per task against the task's group (easiest left): a dot per task (filled: the value
    carries information; open: it does not), the group's median as a bar, τ-b on the judged basis in the title."""
    ranks, registry, groups = data.verdict["groups"], data.registry, data.study.groups
    values, checked = data.verdict["values"], data.verdict.get("information")
    present = [g for g in groups.order if any(data.study.task(t).group == g for t in data.tasks)]
    colours = {g: GROUP_COLOURS[i % len(GROUP_COLOURS)] for i, g in enumerate(groups.order)}
    columns = min(len(metrics), 3)
    rows = -(-len(metrics) // columns)
    rng = np.random.default_rng(0)  # the jitter only places dots; it is the same on every build
    with fig.paper_style():
        figure = Figure(figsize=(fig.WIDTH, 2.3 * rows), layout="constrained")
        axes = np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()
        for ax, metric in zip(axes, metrics, strict=False):
            mine = values[values["metric"] == metric].set_index("task")["value"].astype(float)
            informative = {}
            if checked is not None and len(checked):
                found = checked[checked["metric"] == metric].set_index("task")
                informative = {t: bool(found.loc[t, "informative"]) for t in found.index}
            for x, group in enumerate(present):
                tasks = [t for t in data.tasks if data.study.task(t).group == group and t in mine.index
                         and np.isfinite(mine[t])]
                ys = mine[tasks].to_numpy()
                xs = x + rng.uniform(-0.22, 0.22, size=len(tasks))
                filled = np.array([informative.get(t, True) for t in tasks], dtype=bool)
                ax.scatter(xs[filled], ys[filled], s=16, color=colours[group], edgecolors="black", linewidths=0.3,
                           zorder=3)
                ax.scatter(xs[~filled], ys[~filled], s=16, facecolors="none", edgecolors=colours[group],
                           linewidths=0.8, zorder=3)
                if len(ys):
                    ax.hlines(np.median(ys), x - 0.32, x + 0.32, color="black", linewidth=1.2, zorder=4)
            ax.set_xticks(range(len(present)), [group_label(g) for g in present])
            ax.set_xlim(-0.6, len(present) - 0.4)
            unit = registry[metric].unit if metric in registry else ""
            ax.set_ylabel(registry.label(metric) + (f" ({unit})" if unit else ""))
            ax.yaxis.set_major_locator(mpl.ticker.MaxNLocator(nbins=5))
            row = _row(ranks, metric, judged_basis(ranks, metric))
            if row is not None and np.isfinite(row["kendall_tau"]):
                net = ", net" if row["basis"] == NET_OF_NULL else ""
                ax.set_title(f"τ-b = {row['kendall_tau']:.2f}{net}, p = {pvalue(row['kendall_p'])}")
            direction = "higher = easier" if registry[metric].higher_is_easier else "lower = easier"
            ax.text(0.99, 0.99, direction, transform=ax.transAxes, ha="right", va="top", fontsize=6.5,
                    color="#555555")
        for ax in axes[len(metrics):]:
            ax.axis("off")
    return figure


def group_blocks(writer: Writer, data: StudyData, *, alpha: float) -> list:
    """The figure and the two tables of the groups part (empty without groups)."""
    if not has_groups(data):
        return []
    ranks, registry, groups = data.verdict["groups"], data.registry, data.study.groups
    primary = [m.name for m in registry if m.primary and m.name in set(ranks["metric"])]
    shown = primary + [m for m in dict.fromkeys(ranks["metric"]) if m not in primary][: 6 - len(primary)]
    blocks = [writer.figure(
        [(group_figure(data, shown), "groups")], "Every task's metric against its difficulty group.",
        f"Groups: {groups.source}, easiest left. A dot per task (open: its value does not carry information: it is "
        "within its permutation null, or at its ceiling); a bar: the group's median. Titles: Kendall's τ-b across "
        "tasks between the metric's easiness and the group order (net: of each value minus its null's mean).")]
    blocks.append(writer.table(
        rank_display(data), "group_rank_agreement", "Rank agreement with the difficulty groups.",
        "Kendall's τ-b and Spearman's ρ across tasks between each metric's easiness (negated where lower is "
        "easier) and its task's group (ties within a group); positive: the metric calls the easier groups easier. "
        "Over policies: 2.5–97.5 % percentiles of τ-b over the bootstrap resamples of the policies (each task's "
        "centred on its value); across tasks: over the tasks resampled with replacement. Bases: every task's "
        "value; only the tasks where it carries information; its value net of its null's mean. Outcome: agree / "
        f"contradict when p < {alpha:g}; uninformative with fewer than 4 tasks left.", wrap=True))
    relations = relations_display(data)
    if len(relations):
        blocks.append(writer.table(
            relations, "group_relations", "Relations between the difficulty groups.",
            "Welch's test between the task values of the two groups (the tasks are the samples), on each metric's "
            f"judged basis (net: net of its null); agree / contradict when p < {alpha:g} and the easier group's mean "
            "easiness is above / below the harder's; uninformative when either group keeps fewer than 2 tasks.",
            wrap=True))
    return blocks
