"""Build a study's report from its artefacts: ``index.html``, ``report.md``, ``figures/``, ``tables/``.

:func:`build_report` reads the cached artefacts (RWG returns, metrics, diagnostics, the verdict) and
the SAC curves when there are any, and writes::

    out_dir/index.html          one page, images embedded, opens offline
    out_dir/report.md           the same text in Markdown, figures linked
    out_dir/figures/*.png|pdf   every figure
    out_dir/tables/*.md|tex|csv every table, written once (and tidy CSVs of the verdict)
    out_dir/summary.json        title, budget, headline: for the index (:mod:`taskcomplexity.report.runs`)

The page reads like a results section: the verdict first (generated from the verdict artefact), then
the methods box, the random-policy results, the empirical (SAC) order, the estimator diagnostics, the
optional ablation, and the full verdict table. Everything about a task (name, colour, group, order)
comes from the study; everything about a metric from the registry.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL
from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Registry
from taskcomplexity.report import sections
from taskcomplexity.report.beyond import beyond_section
from taskcomplexity.report.budget import next_budget
from taskcomplexity.report.data import StudyData, load_study_data
from taskcomplexity.report.format import and_list, joined, of_total, plural
from taskcomplexity.report.headline import headline
from taskcomplexity.report.html import Document, write_html
from taskcomplexity.report.markdown import render_markdown
from taskcomplexity.report.methods import methods
from taskcomplexity.report.runs import earlier_recommendations, write_summary
from taskcomplexity.report.writer import Writer
from taskcomplexity.study_data import Study


def scale_banner(data) -> str | None:
    """The line under the title on the study's scale (None for ablations, and at the published scale).

    A study with a ``published:`` block is compared with it: a warning when its N, M or B differ. A study
    without one is compared with nothing published: one plain sentence gives its N, M and B and what the
    information check found of the primary metrics at that scale.
    """
    if data.study.kind == "variants":
        return None
    published = data.study.published
    bins = int(data.results[data.tasks[0]].metrics.manifest.get("config", {}).get("bins", 0))
    scales = {(int(p), int(e)) for p, e in zip(data.metrics["policies"], data.metrics["episodes"], strict=True)}
    here = "; ".join(f"N = {n:,}, M = {m:,}" for n, m in sorted(scales)) + f", B = {bins:,}"
    if published is None:
        return (f"This study has no published table to compare with (its study file has no published: block); "
                f"its metrics are at {here}." + information_found(data))
    if all(not published.differs(n, m, bins) for n, m in scales):
        return None
    return (f"These numbers are at {here}, not at the scale of {published.source} (N = {published.policies:,}, "
            f"M = {published.episodes:,}, B = {published.bins:,}). PIC's histogram estimator depends on N, M and B, "
            f"so its values here are not comparable with that table; study.policies={published.policies} "
            f"study.episodes={published.episodes} metrics.bins={published.bins} on this study's command compute them "
            "at that scale.")


def information_found(data) -> str:
    """" At this scale, the information check finds PIC informative on 1 of the 2 tasks and POIC on both."
    (empty without an information check of a primary metric)."""
    checked = data.verdict.get("information")
    if checked is None or checked.empty:
        return ""
    parts = []
    for metric in (m for m in data.registry if m.primary):
        rows = checked[checked["metric"] == metric.name]
        if len(rows):
            found = of_total(int(rows["informative"].astype(bool).sum()), len(rows), "task")
            parts.append(f"{metric.label} {'informative on' if parts == [] else 'on'} {found}")
    if not parts:
        return ""
    return " At this scale, the information check finds " + and_list(parts) + "."


def build_report(
    results: Sequence[Any],
    *,
    study: Study,
    verdict: Any,
    diagnostics: Mapping[str, Any] | None,
    sac_curves: pd.DataFrame | None,
    out_dir: Path,
    title: str,
    ablation: Mapping | None = None,
    alpha: float = SIGNIFICANCE_LEVEL,
    registry: Registry = DEFAULT_REGISTRY,
    further: Mapping[str, Mapping[str, Any]] | None = None,
    missing: Mapping[str, str] | None = None,
) -> Path:
    """Write the study's report and return the path of its ``index.html``.

    Parameters
    ----------
    results : sequence of per-task results
        Each with ``task_id`` (the study id), ``request``, and the ``rwg`` and ``metrics`` artefacts
        (:class:`~taskcomplexity.stages.task_artefacts.TaskMetrics`).
    study : Study
        Names, groups, colours and order of the tasks; the relations and orders the verdict judged.
    verdict : artefact
        The verdict stage's artefact of these results.
    diagnostics : mapping of task id to artefact, optional
        Diagnostics artefacts; None leaves the diagnostics section out.
    sac_curves : pandas.DataFrame, optional
        Tidy SAC curves (``task``, ``variant``, ``seed``, ``env_step``, ``eval/return_mean``, …) for the
        curves figure; None: the SAC section says the curves were not computed.
    out_dir : pathlib.Path
        Output directory (created); figure and table files of an earlier build are replaced.
    title : str
        Page title.
    ablation : mapping, optional
        Overlaid RWG trios: ``{label: returns (N, M) | policy table | task results}`` for one figure,
        or ``{title: {label: …}}`` for one figure per entry.
    alpha : float, default 0.005
        Significance cut-off (for the wording; the verdict artefact holds the tests).
    registry : Registry
        The metrics' labels, units, directions and families.
    further : mapping of stage to mapping of task id to artefact, optional
        The artefacts of the stages built on SAC's trained actor; the learning-path ones give the
        learning-path figure.
    missing : mapping of stage to str, optional
        What each stage beyond the paper needs, said of its metrics when none of their values was computed
        (:attr:`taskcomplexity.stages.stage.Stage.missing`).

    Returns
    -------
    pathlib.Path
        ``out_dir / "index.html"``.
    """
    if len(results) < 1:
        raise ValueError("results must hold at least one task's artefacts, got none")
    writer = Writer(Path(out_dir))
    writer.remove_earlier_build()
    data = load_study_data(results, study, verdict, registry=registry, diagnostics=diagnostics)
    if data.sac_per_seed is not None:
        writer.data(data.sac_per_seed, "sac_per_seed")
    boxed = sections.verdict_blocks(writer, data, alpha=alpha)  # first on the page, so numbered first
    page_sections = [
        sections.rwg_section(writer, data, alpha=alpha),
        sections.sac_section(writer, data, sac_curves),
        sections.diagnostics_section(writer, data),
    ]
    paths = {t: pd.read_parquet(a.file("path.parquet")) for t, a in (further or {}).get("learning_path", {}).items()}
    beyond = beyond_section(writer, data, paths, missing, sac=sections.sac_way(data, sac_curves))
    if beyond is not None:
        page_sections.append(beyond)
    if ablation:
        page_sections.append(sections.ablation_section(writer, ablation))
    page_sections.append(sections.appendix_section(writer, data))
    n = joined(int(v) for v in data.metrics["policies"])
    m = joined(int(v) for v in data.metrics["episodes"])
    subtitle = (f"{plural(len(data.tasks), 'task')}, N = {n} random policies × M = {m} episodes each; "
                f"generated {dt.datetime.now().strftime('%Y-%m-%d %H:%M')}")
    earlier = earlier_recommendations(writer.out_dir)
    document = Document(title, subtitle, tuple(headline(data, alpha=alpha, earlier=earlier)), boxed,
                        methods(data, sac_curves, alpha=alpha), tuple(page_sections), banner=scale_banner(data))
    (writer.out_dir / "report.md").write_text(render_markdown(document), encoding="utf-8")
    write_summary(writer.out_dir, title=title, headline=document.headline, tasks=len(data.tasks), policies=n,
                  episodes=m, bins=int(data.results[data.tasks[0]].metrics.manifest.get("config", {}).get("bins", 0)),
                  sac=sac_curves is not None and not sac_curves.empty, next_budget=_recommended(data))
    return write_html(document, writer.out_dir / "index.html")


def _recommended(data: StudyData) -> dict | None:
    """The next budget the headline recommends, as ``summary.json`` keeps it (None when it recommends none)."""
    budget = next_budget(data)
    return budget.record() if budget is not None and budget.changes and budget.sized else None
