"""The verdict in words, generated from the verdict artefact: one or two sentences, then the details."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd

from taskcomplexity.report.budget import Recommendation, budget_sentences, recheck_sentences
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import and_list, naming, num, of_total, plural, pvalue
from taskcomplexity.report.groups import group_sentences
from taskcomplexity.report.verdict_tables import survival_tables
from taskcomplexity.verdict.judge import SURVIVAL
from taskcomplexity.verdict.references import CONFIDENCE, on_values, reference_label
from taskcomplexity.verdict.replication import shown_outcome


def _count(summary: pd.DataFrame, metric: str) -> dict[str, int]:
    row = summary.set_index("metric").loc[metric]
    return {"agree": int(row["agreements"]), "contradict": int(row["contradictions"]),
            "uninformative": int(row.get("uninformative", 0)), "undefined": int(row.get("undefined", 0))}


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


def headline(data: StudyData, *, alpha: float, earlier: Sequence[Recommendation] = ()) -> list[str]:
    """Plain-text sentences; the first one or two are the headline.

    When a primary metric's verdicts rest on values without information (its permutation null, its
    ceiling), that comes first, before any count of agreements.

    Parameters
    ----------
    data : StudyData
        The study's artefacts (its verdict tables, registry and names).
    alpha : float
        The significance cut-off used (for the wording).
    earlier : sequence of Recommendation, optional
        The next budgets earlier reports of this study recommended, newest first: the one this run reaches is
        re-checked (:func:`~taskcomplexity.report.budget.recheck_sentences`).
    """
    verdict, summary, registry = data.verdict["verdict"], data.verdict["summary"], data.registry
    grouped = group_sentences(data, alpha=alpha)
    if verdict.empty:
        correlated = replication_sentences(data) + reference_sentences(data)
        if grouped:
            return grouped + information_sentences(data) + correlated
        if correlated:
            return correlated + ["The study gives no relation (easier, harder, kind) to judge, so there is no "
                                 "verdict by relation."]
        return [f"The study gives no relation to judge between its {plural(len(data.tasks), 'task')}, so there is "
                "no verdict: the page shows the metrics of each task. Add relations (easier, harder, kind) to the "
                "study file to judge them."]
    sentences = grouped + information_sentences(data)
    primary = [m.name for m in registry if m.primary and m.name in set(summary["metric"])]
    if primary:
        sentences.append(primary_sentence(summary, verdict, primary, label=registry.label, alpha=alpha))
    sentences.append(best_measure_sentence(data))
    sac = summary[summary["metric"].map(lambda m: m in registry and registry[m].stage == "sac")]
    if sac.empty:
        sentences.append("SAC curves were not computed, so no empirical (training) order is checked.")
    else:
        first = sac.iloc[0]
        judged = int(first["relations"]) - int(first["undefined"])
        sentences.append(f"The empirical order of training ({registry.label(first['metric'])}) agrees with "
                         f"{int(first['agreements'])} of the {plural(judged, 'relation')} it could judge.")
    sentences += recheck_sentences(data, earlier) + resolve_sentences(data)
    sentences += replication_sentences(data) + reference_sentences(data)
    sentences += [survival_sentence(quantity, table) for quantity, table in survival_tables(data).items()]
    return sentences


SIGNIFICANT = ("agree", "contradict")
"""The outcomes of a significant verdict."""


def _verb(count: int, one: str, many: str) -> str:
    return one if count == 1 else many


def primary_sentence(summary: pd.DataFrame, verdict: pd.DataFrame, primary: list[str], *,
                     label: Callable[[str], str], alpha: float) -> str:
    """How the primary metrics fare against the known relations, with the count of each other outcome.

    Parameters
    ----------
    summary, verdict : pandas.DataFrame
        The verdict artefact's per-metric counts and its metric × relation outcomes.
    primary : list of str
        The primary metrics (each in ``summary``), in order.
    label : callable
        A metric's display label.
    alpha : float
        The significance cut-off used (for the wording).
    """
    relations = verdict[["easier", "harder"]].drop_duplicates().shape[0]
    known = ("Against the known complexity relation" if relations == 1
             else f"Against the {relations} known complexity relations")
    test = f"Welch's test, p < {alpha:g}"
    chosen = verdict[verdict["metric"].isin(primary)]
    rest = {o: int((chosen["outcome"] == o).sum()) for o in ("not significant", "undefined")}
    if relations > 1 and len(chosen) and sum(rest.values()) == len(chosen):
        (first, n), *others = [(o, n) for o, n in rest.items() if n]
        counts = f"{n} {_verb(n, 'is', 'are')} {first}" + "".join(f" and {k} {o}" for o, k in others)
        return (f"{known}, none of the {len(chosen)} verdicts of {and_list(label(m) for m in primary)} is "
                f"significant ({test}): {counts}.")
    parts = []
    for m in primary:
        counts = _count(summary, m)
        if counts["uninformative"] == relations:
            parts.append(f"{label(m)} is uninformative on {'it' if relations == 1 else 'every one'}")
            continue
        if relations == 1:
            word = ("agrees with it" if counts["agree"] else "contradicts it" if counts["contradict"]
                    else "is undefined on it" if counts["undefined"] else "is not significant on it")
            parts.append(f"{label(m)} {word}")
            continue
        part = f"{label(m)} agrees with {counts['agree']} and contradicts {counts['contradict']}"
        if counts["uninformative"]:
            part += f" and is uninformative on {counts['uninformative']}"
        parts.append(part)
    other = sum(rest.values())
    if relations == 1 or not other:
        tail = ""
    elif all(rest.values()):
        tail = (f"; of the other {other} verdicts, {rest['not significant']} "
                f"{_verb(rest['not significant'], 'is', 'are')} not significant and {rest['undefined']} undefined")
    else:
        outcome = next(o for o, n in rest.items() if n)
        tail = (f"; the other verdict is {outcome}" if other == 1
                else f"; the other {other} verdicts are {outcome}")
    # the test is cited with its cut-off only where a verdict reached it, or to say that none did
    if chosen["outcome"].isin(SIGNIFICANT).any():
        cited = f" ({test}{tail})"
    elif (chosen["outcome"] == "not significant").any():
        cited = f" (none significant at p < {alpha:g}, Welch's test{tail})"
    else:
        cited = f" ({tail.removeprefix('; ')})" if tail else ""
    return f"{known}, " + "; ".join(parts) + f"{cited}."


def best_measure_sentence(data: StudyData) -> str:
    """Which measures agree with the known relations most often, among those on one scale across tasks (a raw
    mean return in each task's own reward units is never promoted), and which contradict them most often."""
    registry = data.registry
    return measure_sentence(data.verdict["summary"], data.verdict["verdict"], label=registry.label, name=data.name,
                            comparable=lambda m: m not in registry or registry[m].comparable_across_tasks)


def _share(group: pd.DataFrame, column: str) -> str:
    """"(9 of 10)", "(9 of 10 each)" for a tie, "(9 each)" for a tie over different numbers of relations."""
    count, totals = int(group[column].iloc[0]), set(group["relations"].astype(int))
    each = " each" if len(group) > 1 else ""
    return f"({count} of {totals.pop()}{each})" if len(totals) == 1 else f"({count}{each})"


def _who(group: pd.DataFrame, everyone: int) -> tuple[str, str]:
    """The subject naming a tied group of measures (and its trailing example), "both"/"all 8" when it is
    every one of ``everyone`` measures."""
    if len(group) == everyone > 1:
        return ("both" if everyone == 2 else f"all {everyone}"), ""
    return naming(group["label"], "measure")


def measure_sentence(summary: pd.DataFrame, verdict: pd.DataFrame, *, label: Callable[[str], str],
                     name: Callable[[str], str], comparable: Callable[[str], bool]) -> str:
    """Which measures agree with the known relations most often and which contradict them most often.

    Every measure tied at the top is named: the most agreements net of contradictions, then the most
    agreements; and at the bottom: the most contradictions, then the fewest net agreements. More than
    three tied measures are counted, with two of them as the example.

    Parameters
    ----------
    summary, verdict : pandas.DataFrame
        The verdict artefact's per-metric counts and its metric × relation outcomes.
    label, name : callable
        A metric's display label; a task's display name.
    comparable : callable
        Whether a metric is on one scale across tasks (only those are ranked).
    """
    chosen = summary[summary["metric"].map(comparable)]
    left_out = len(summary) - len(chosen)
    if chosen.empty:
        return (f"No measure is on one scale across tasks ({plural(left_out, 'measure')} in each task's own reward "
                "units), so none is ranked against the known relations.")
    scored = chosen.assign(net=chosen["agreements"] - chosen["contradictions"], label=chosen["metric"].map(label))
    top = scored[scored["net"] == scored["net"].max()]
    top = top[top["agreements"] == top["agreements"].max()]
    bottom = scored[scored["contradictions"] == scored["contradictions"].max()]
    bottom = bottom[bottom["net"] == bottom["net"].min()]
    them = "it" if int(bottom["relations"].max()) == 1 else "them"
    if int(bottom["contradictions"].iloc[0]) > 0:
        first = bottom.iloc[0]
        example = verdict[(verdict["metric"] == first["metric"]) & (verdict["outcome"] == "contradict")].iloc[0]
        subject, eg = _who(bottom, len(scored))
        often = "" if them == "it" else (" equally often " if len(bottom) == len(scored) > 1
                                          else " most often ") + _share(bottom, "contradictions")
        who = "it" if len(bottom) == 1 else first["label"]
        contradiction = (f"{subject} {_verb(len(bottom), 'contradicts', 'contradict')} {them}{often}{eg}"
                         f"{'; ' if eg else ': '}for example, {who} rates {name(example['harder'])} easier than "
                         f"{name(example['easier'])}")
    else:
        contradiction = f"no measure contradicts {them} significantly"
    among = (f"Of the {plural(len(chosen), 'measure')} on one scale across tasks"
             + (f" ({left_out} in each task's own reward units left out)" if left_out else ""))
    agreements = int(top["agreements"].iloc[0])
    if int(scored["agreements"].max()) == 0:
        return f"{among}, none agrees significantly with any known relation; {contradiction}."
    if agreements == 0:
        return f"{among}, none agrees with the known relations more often than it contradicts them; {contradiction}."
    subject, eg = _who(top, len(scored))
    agree = _verb(len(top), "agrees", "agree")
    totals = set(top["relations"].astype(int))
    if totals == {1}:
        return f"{among}, {subject} {agree} with the known relation{eg}; {contradiction}."
    if len(top) == len(scored) > 1:
        words = ("agree with every known relation" if totals == {agreements}
                 else f"agree with the known relations equally often {_share(top, 'agreements')}")
        return f"{among}, {subject} {words}; {contradiction}."
    return (f"{among}, {subject} {agree} with the known relations most often {_share(top, 'agreements')}{eg}; "
            f"{contradiction}.")


def survival_sentence(quantity: str, table: pd.DataFrame) -> str:
    """Whether the significant verdicts on a quantity survive a change of estimator.

    The table's ``Survives`` column (:func:`~taskcomplexity.verdict.judge.survival`) decides: only relations
    with a significant verdict from an informative estimator count, an uninformative estimator is left out
    of the comparison (and named), so a relation survives when every informative estimator, at least two of
    them, reaches the same outcome.

    Parameters
    ----------
    quantity : str
        The quantity's label (e.g. I(Θ; R)).
    table : pandas.DataFrame
        One of :func:`~taskcomplexity.report.verdict_tables.survival_tables`: the relation, its kind, one
        column of outcomes per estimator.
    """
    estimators = list(table.columns[2:-1])
    outcomes, survives = table[estimators].astype(str), table["Survives"]
    total = len(table)
    yes, no, one, _ = SURVIVAL
    significant = int(survives.isin((yes, no, one)).sum())
    kept, alone = int((survives == yes).sum()), int((survives == one).sum())
    blank = {e: int(n) for e, n in (outcomes == "uninformative").sum().items() if n}
    if blank:
        left = (and_list(blank) if total == 1
                else and_list(f"{e} on {of_total(n, total, 'relation')}" for e, n in blank.items()))
        listed = f"{', '.join(estimators)}; left out where uninformative: {left}"
    else:
        listed = ", ".join(estimators)
    if significant == 0:
        which = "the known relation" if total == 1 else f"any of the {total} known relations"
        return (f"No informative estimator gives a significant verdict on {quantity} for {which}, so no verdict "
                f"is tested against a change of estimator ({listed}).")
    unchecked = (f"; {'it has' if significant == 1 else f'{alone} have' if alone > 1 else '1 has'} no other "
                 "informative estimator to change to" if alone else "")
    if total == 1:
        verb = "has no other informative estimator to change to" if alone else (
            "survives" if kept else "does not survive")
        change = "" if alone else " a change of estimator"
        return f"The significant verdict on {quantity} {verb}{change} ({listed})."
    if kept == significant:
        survive = "it survives" if kept == 1 else "both survive" if kept == 2 else "all survive"
    else:
        survive = f"{'none' if kept == 0 else kept} {_verb(max(kept, 1), 'survives', 'survive')}"
    counted = of_total(significant, total, "relation")
    return (f"{counted[0].upper()}{counted[1:]} {_verb(significant, 'has', 'have')} a significant verdict on "
            f"{quantity}; of those, {survive} a change of estimator ({listed}){unchecked}.")


def resolve_sentences(data: StudyData) -> list[str]:
    """What more sampling would settle: the next budget (:func:`~taskcomplexity.report.budget.budget_sentences`,
    the same numbers as the full verdict table's last column), then, for a primary metric checked against its
    nulls, the outcomes of the measure net of those nulls on the relations whose difference is mostly the nulls'."""
    verdict, registry = data.verdict["verdict"], data.registry
    sentences = budget_sentences(data)
    for metric in (m for m in registry if m.primary):
        check = metric.information
        if check is None or not check.null or check.net_of_null:
            continue
        mine = verdict[verdict["metric"] == metric.name]
        mostly = mine[(mine["outcome"] == "uninformative") & mine["informative_easier"].astype(bool)
                      & mine["informative_harder"].astype(bool)]
        if not mostly.empty:
            sentence = _net_sentence(metric, mostly, verdict, registry)
            if sentence:
                sentences.append(sentence)
    return sentences


_OUTCOME_VERBS = {"agree": "agrees on", "contradict": "contradicts on", "not significant": "is not significant on",
                  "uninformative": "is uninformative on", "undefined": "is undefined on"}


def _net_sentence(metric, mostly: pd.DataFrame, verdict: pd.DataFrame, registry) -> str:
    """How the measure net of ``metric``'s nulls fares on the relations whose difference is mostly the nulls'
    (``mostly``: rows of ``metric``); empty without such a measure or its rows."""
    net = next((m for m in registry if m.information is not None and m.information.net_of_null
                and m.information.null == metric.information.null), None)
    if net is None:
        return ""
    pairs = set(zip(mostly["easier"], mostly["harder"], strict=True))
    among = np.array([(e, h) in pairs for e, h in zip(verdict["easier"], verdict["harder"], strict=True)], dtype=bool)
    rows = verdict[(verdict["metric"] == net.name).to_numpy() & among]
    if rows.empty:
        return ""
    counts = rows["outcome"].value_counts()
    said = and_list(f"{verb} {counts[outcome]}" for outcome, verb in _OUTCOME_VERBS.items() if counts.get(outcome, 0))
    return (f"On the {plural(len(pairs), 'relation')} where {metric.label}'s difference is mostly the nulls', "
            f"{net.label}, net of its nulls, {said} of them.")


def _scale(data: StudyData) -> tuple[int, int] | None:
    """(N, M) of the study's tasks when they share one (None otherwise)."""
    scales = {(int(p), int(e)) for p, e in zip(data.metrics["policies"], data.metrics["episodes"], strict=True)}
    return scales.pop() if len(scales) == 1 else None


def replication_sentences(data: StudyData) -> list[str]:
    """One sentence per primary metric whose correlation with a reference score the study's published table prints
    (the table's first reference): the published r, ours with its bootstrap interval, on the tasks where the metric
    carries information and net of its null, and the outcome (:mod:`taskcomplexity.verdict.replication`)."""
    table = data.verdict.get("replications")
    if table is None or table.empty:
        return []
    primary = [m.name for m in data.registry if m.primary]
    scale = _scale(data)
    sentences = []
    for _, rows in table.groupby("table", sort=False):
        first = rows[(rows["reference"] == rows["reference"].iloc[0]) & rows["quantity"].isin(primary)]
        for _, r in first.iterrows():
            label = data.registry.label(r["metric"])
            ours = f"here r = {num(r['pearson_r'], 2)} ("
            if np.isfinite(r["pearson_low"]):
                ours += (f"{CONFIDENCE * 100:.0f} % interval over resampled policies {num(r['pearson_low'], 2)} to "
                         f"{num(r['pearson_high'], 2)}; ")
            ours += f"p = {pvalue(r['pearson_p'])}) across {plural(int(r['tasks']), 'task')}"
            if np.isfinite(r["informative_tasks"]):
                k = int(r["informative_tasks"])
                ours += (f", r = {num(r['informative_r'], 2)} on the {plural(k, 'task')} where {label} carries "
                         "information" if np.isfinite(r["informative_r"]) else
                         f"; {label} carries information on {of_total(k, int(r['tasks']), 'task')}")
            if np.isfinite(r["net_r"]):
                ours += f", r = {num(r['net_r'], 2)}" + (
                    f" ({num(r['net_low'], 2)} to {num(r['net_high'], 2)})" if np.isfinite(r["net_low"]) else "") + \
                    " net of its null"
            budget = f" at N = {scale[0]:,} × M = {scale[1]:,}" if scale else ""
            sentences.append(
                f"{label} against {reference_label(r['reference'])}: {data.study.published.source} prints r = "
                f"{num(r['published_r'], 3)} (p = {pvalue(r['published_p'])}); {ours}. {shown_outcome(r).capitalize()}"
                f"{budget}: {r['why']}{_level(r)}.")
    return sentences


def _level(r) -> str:
    """Where the published r lies against our intervals, when the outcome is reproduced (the same sign and
    significance need not be the same level; outside both, the outcome shown is the finding's only): "" otherwise
    or without an interval."""
    if r["outcome"] != "reproduced" or not np.isfinite(r["pearson_low"]):
        return ""
    inside = r["pearson_low"] <= r["published_r"] <= r["pearson_high"]
    clause = f"; the published r lies {'inside' if inside else 'outside'} our interval over resampled policies"
    if np.isfinite(r.get("tasks_low", np.nan)):
        across = r["tasks_low"] <= r["published_r"] <= r["tasks_high"]
        clause += (f" and {'inside' if across else 'outside'} Fisher's interval across the tasks "
                   f"({num(r['tasks_low'], 2)} to {num(r['tasks_high'], 2)})")
    return clause


def reference_sentences(data: StudyData) -> list[str]:
    """One sentence per reference score: the primary metrics' Pearson r with it, and the measure most
    correlated with it (from the verdict's ``correlations``)."""
    correlated, registry = on_values(data.verdict["correlations"]), data.registry
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
