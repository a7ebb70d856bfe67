"""Beyond the paper: does each metric its conclusion proposes agree where PIC and POIC contradict?

Everything here is derived from the verdict artefact and the registry: the metrics of the family
:data:`~taskcomplexity.metrics.registry.BEYOND` are compared, relation by relation, with the primary
metrics (PIC, POIC).
"""

from __future__ import annotations

import pandas as pd

from taskcomplexity.metrics.registry import BEYOND
from taskcomplexity.report.data import StudyData
from taskcomplexity.report.html import Paragraph, Section
from taskcomplexity.report.writer import Writer
from taskcomplexity.verdict import by_relation

HOW_TO_COMPUTE = {
    "occupancy": "it needs a trained SAC actor for each task (SAC on: `make paper`, or `sac.enabled=true`)",
}
"""Per registry stage: what a metric of that stage needs, said when the report has no value of it."""


def _relation(data: StudyData, row) -> str:
    return f"{row['kind'].replace('_', ' ')}: {data.name(row['easier'])} < {data.name(row['harder'])}"


def open_question_sentences(data: StudyData) -> list[str]:
    """One sentence per proposed metric: its record against the known relations, and where PIC/POIC fail."""
    registry, verdict = data.registry, data.verdict["verdict"]
    proposed = [m for m in registry if m.family == BEYOND]
    primary = [m.name for m in registry if m.primary and (verdict["metric"] == m.name).any()]
    failing = verdict[verdict["metric"].isin(primary) & (verdict["outcome"] == "contradict")]
    failing = failing[["easier", "harder", "kind"]].drop_duplicates()
    sentences = []
    for metric in proposed:
        own = verdict[verdict["metric"] == metric.name]
        if own.empty:
            needs = HOW_TO_COMPUTE.get(metric.stage, "its stage did not run")
            sentences.append(f"{metric.label} was not computed for this report: {needs}.")
            continue
        agree, contradict = int((own["outcome"] == "agree").sum()), int((own["outcome"] == "contradict").sum())
        sentence = (f"{metric.label} agrees with {agree} and contradicts {contradict} of the {len(own)} known "
                    f"relations")
        if failing.empty:
            sentences.append(sentence + f"; {' and '.join(data.registry.label(m) for m in primary)} contradict none.")
            continue
        joined_rows = failing.merge(own, on=["easier", "harder", "kind"])
        rescued = joined_rows[joined_rows["outcome"] == "agree"]
        where = "; ".join(_relation(data, r) for _, r in rescued.iterrows())
        sentences.append(sentence + f"; of the {len(failing)} relations PIC or POIC contradicts, it agrees on "
                         f"{len(rescued)}" + (f" ({where})" if where else "") + ".")
    return sentences


def beyond_section(writer: Writer, data: StudyData) -> Section | None:
    """The answer to the paper's open question, one sentence per proposed metric (None: none is registered)."""
    proposed = [m for m in data.registry if m.family == BEYOND]
    if not proposed or data.verdict["verdict"].empty:
        return None
    blocks = [Paragraph(" ".join(open_question_sentences(data)))]
    blocks += [Paragraph(f"{m.label}: {'higher' if not m.higher_is_easier else 'lower'} = harder ({m.why}).")
               for m in proposed]
    verdict = data.verdict["verdict"]
    computed = [m.name for m in proposed if (verdict["metric"] == m.name).any()]
    compared = [m.name for m in data.registry if m.primary] + computed
    table = by_relation(verdict, compared)
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
    return Section("Beyond the paper: the metrics its conclusion proposes", tuple(blocks))
