"""Beyond the paper: does each metric its conclusion proposes agree where PIC and POIC do not?

Everything here is derived from the verdict artefact and the registry: the metrics of the family
:data:`~taskcomplexity.metrics.registry.BEYOND` are compared, relation by relation, with the primary
metrics (PIC, POIC). The relations left open are those no primary metric agrees with: one contradicts it,
or each is uninformative (its value measures the estimator: the information check) or not significant.
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from taskcomplexity.metrics.registry import BEYOND
from taskcomplexity.report import figures as fig
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.format import MISSING, and_list, mean_sd, of_total
from taskcomplexity.report.html import FigureBlock, Paragraph, Section
from taskcomplexity.report.methods import direction
from taskcomplexity.report.writer import Writer, left_out, panels_left_out
from taskcomplexity.verdict import by_relation

NOT_RUN = "its stage did not run"
"""What the report says of a metric none of whose values was computed, when its stage's record says nothing
(:attr:`taskcomplexity.stages.stage.Stage.missing`)."""


def _relation(data: StudyData, row) -> str:
    return f"{row['kind'].replace('_', ' ')}: {data.name(row['easier'])} < {data.name(row['harder'])}"


RELATION = ["easier", "harder", "kind"]
"""The columns that name a known relation in the verdict table."""

VERB = {"contradict": "contradicts", "agree": "agrees"}
"""An outcome as a verb after a metric's name; the others read as they are ("PIC uninformative")."""


def left_open(verdict: pd.DataFrame, primary: list[str]) -> pd.DataFrame:
    """The known relations no primary metric agrees with, in the verdict's order.

    ``verdict``: the verdict table (one row per metric and relation, ``outcome`` among
    :data:`~taskcomplexity.verdict.OUTCOMES`). Returns one row per such relation: ``easier``, ``harder``,
    ``kind`` and, per primary metric, its outcome there (column named by the metric).
    """
    outcomes = verdict[verdict["metric"].isin(primary)].pivot_table(
        index=RELATION, columns="metric", values="outcome", aggfunc="first", sort=False)
    relations = verdict[RELATION].drop_duplicates().merge(outcomes.reset_index(), on=RELATION, how="left")
    agreed = (relations[[m for m in primary if m in relations]] == "agree").any(axis=1)
    return relations[~agreed].reset_index(drop=True)


SAC_ADVICE = " (SAC on: "
"""Where a stage's record starts its general advice on running SAC, which the report replaces with this study's
way to SAC (:func:`taskcomplexity.report.sections.sac_way`)."""


def open_question_sentences(data: StudyData, missing: Mapping[str, str] | None = None, *, sac: str = "") -> list[str]:
    """Where PIC and POIC leave the known relations open, then one sentence per proposed metric.

    ``missing``: stage → what it needs, said of a metric of that stage none of whose values was computed. ``sac``:
    this study's way to SAC's curves (its own command), said in place of a stage's general advice on running SAC.
    """
    registry, verdict = data.registry, data.verdict["verdict"]
    proposed = [m for m in registry if m.family == BEYOND]
    primary = [m.name for m in registry if m.primary and (verdict["metric"] == m.name).any()]
    names = " and ".join(registry.label(m) for m in primary)
    relations = verdict[RELATION].drop_duplicates()
    unanswered = left_open(verdict, primary)
    known = "known relation"
    if unanswered.empty:
        computed = any((verdict["metric"] == m.name).any() for m in proposed)
        sentences = [f"{names} leave no {known} open (one of them agrees with each), so no proposed metric has "
                     "a relation to settle" + ("; their own records follow." if computed else ".")]
    else:
        listed = "; ".join(
            _relation(data, r) + " (" + ", ".join(f"{registry.label(m)} {VERB.get(r[m], r[m])}" for m in primary
                                                  if isinstance(r.get(m), str)) + ")"
            for _, r in unanswered.iterrows())
        leave = "leaves" if len(primary) == 1 else "leave"
        none = {1: "it does not agree", 2: "neither agrees"}.get(len(primary), "none of them agrees")
        sentences = [f"{names} {leave} {of_total(len(unanswered), len(relations), known)} open ({none}): {listed}."]
    absent: dict[str, list[str]] = {}  # what a stage needs → the proposed metrics it would have computed
    for metric in proposed:
        if not (verdict["metric"] == metric.name).any():
            needs = (missing or {}).get(metric.stage) or NOT_RUN
            if sac and SAC_ADVICE in needs:
                needs = needs.split(SAC_ADVICE, 1)[0] + f" (SAC: {sac})"
            absent.setdefault(needs, []).append(metric.label)
    for needs, labels in absent.items():
        listed = and_list(labels)
        verb = "was" if len(labels) == 1 else "were"
        if len(labels) > 1 and needs.startswith("it needs"):  # the stages' records speak of one metric
            needs = "they need" + needs[len("it needs"):]
        sentences.append(f"{listed[:1].upper()}{listed[1:]} {verb} not computed for this report: {needs}.")
    for metric in proposed:
        own = verdict[verdict["metric"] == metric.name]
        label = metric.label[:1].upper() + metric.label[1:]
        if own.empty:
            continue
        agree, contradict = int((own["outcome"] == "agree").sum()), int((own["outcome"] == "contradict").sum())
        if len(own) == 1:
            sentence = f"{label} on the one {known}: {own['outcome'].iloc[0]}"
        else:
            sentence = f"{label} agrees with {of_total(agree, len(own), known)} and contradicts {contradict}"
        if not unanswered.empty:
            answered = unanswered[RELATION].merge(own, on=RELATION)
            answered = answered[answered["outcome"] == "agree"]
            where = "; ".join(_relation(data, r) for _, r in answered.iterrows())
            share = of_total(len(answered), len(unanswered), "such relation")
            sentence += f"; of those left open it agrees with {share}" + (f" ({where})" if where else "")
        sentences.append(sentence + ".")
    return sentences


def proposed_values(data: StudyData, metrics: list[str]) -> pd.DataFrame:
    """One row per task: each metric's value on the whole sample ± the sd of its batch estimates.

    Both come from the verdict artefact (``values``, ``samples``: the estimates Welch's tests compare); a
    metric without a value for a task shows as missing.
    """
    values, samples = data.verdict["values"], data.verdict["samples"]
    rows = []
    for task in data.tasks:
        row = {"Task": data.name(task)}
        for metric in metrics:
            value = values[(values["task"] == task) & (values["metric"] == metric)]["value"]
            batch = samples[(samples["task"] == task) & (samples["metric"] == metric)]["value"]
            sd = batch.std(ddof=1) if len(batch) > 1 else float("nan")
            row[data.registry.label(metric)] = mean_sd(float(value.iloc[0]), sd) if len(value) else MISSING
        rows.append(row)
    return pd.DataFrame(rows)


def beyond_section(writer: Writer, data: StudyData, paths: Mapping[str, pd.DataFrame] | None = None,
                   missing: Mapping[str, str] | None = None, *, sac: str = "") -> Section | None:
    """The answer to the paper's open question, one sentence per proposed metric (None: none is registered).

    ``paths``: task id → the ``path.parquet`` of its learning-path artefact (its figure; none: no figure).
    ``missing``, ``sac``: what each stage needs, and this study's way to SAC (:func:`open_question_sentences`).
    """
    proposed = [m for m in data.registry if m.family == BEYOND]
    if not proposed or data.verdict["verdict"].empty:
        return None
    blocks = [Paragraph(" ".join(open_question_sentences(data, missing, sac=sac)))]
    verdict = data.verdict["verdict"]
    computed = [m.name for m in proposed if (verdict["metric"] == m.name).any()]
    blocks += [Paragraph(f"{m.label}: {direction(m)} ({m.why}).") for m in proposed if m.name in computed]
    compared = [m.name for m in data.registry if m.primary] + computed
    table = by_relation(verdict, compared)
    if computed:
        blocks.append(writer.table(
            proposed_values(data, compared), "beyond_the_paper_values", "The proposed metrics on each task.",
            "Value on the whole sample ± the standard deviation of its estimates on the policy batches that "
            "Welch's tests compare (not a bootstrap sd; the stages' artefacts hold the bootstrap). PIC and "
            "POIC beside them for comparison; each metric's direction is stated above."))
    if computed and not table.empty:
        shown = table.drop(columns=["survives"]).assign(
            easier=table["easier"].map(data.name), harder=table["harder"].map(data.name),
            kind=table["kind"].str.replace("_", " "))
        shown = shown.rename(columns={"easier": "Easier", "harder": "Harder", "kind": "Kind",
                                      **{m: data.registry.label(m) for m in compared}})
        blocks.append(writer.table(pd.DataFrame(shown), "beyond_the_paper",
                                   "The proposed metrics beside PIC and POIC, relation by relation.",
                                   "Outcome of Welch's test on each known relation (agree, contradict, not "
                                   "significant; empty: not computed)."))
    if paths:
        blocks.append(learning_path_block(writer, data, paths))
    return Section("Beyond the paper: the metrics its conclusion proposes", tuple(blocks))


def learning_path_block(writer: Writer, data: StudyData, paths: Mapping[str, pd.DataFrame]) -> FigureBlock | Paragraph:
    """PIC and POIC along SAC's learning path (the panels with a finite value), or the line saying why not."""
    shown = {t: paths[t] for t in data.tasks if t in paths}
    drawn = fig.drawn_paths(shown)
    empty = [label for column, label in fig.PATH_PANELS if (column, label) not in drawn]
    why = "no task's learning path has a finite value"
    if not drawn:
        return left_out("the figure of PIC and POIC along SAC's learning path", f"{why} of {and_list(empty)}")
    return writer.figure(
        [(fig.learning_path_figure(shown, {t: data.styles[t] for t in shown}), "learning_path")],
        f"{' and '.join(label for _, label in drawn)} along SAC's learning path.",
        "At each snapshot of the trained SAC actor θ_k (step 0 and every checkpoint), the histogram PIC and "
        "POIC of policies θ_k + σε (ε ~ N(0, I) over every actor parameter), each run for M episodes on the "
        "task's RWG backend; dotted: the mean over the path, the learning-path metric."
        + panels_left_out({why: empty}))
