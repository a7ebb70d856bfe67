"""The report's sections, in page order: random policies, SAC, estimator diagnostics, ablation, appendix."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from taskcomplexity.report import figures as fig
from taskcomplexity.report.budget import next_budget, shown_size
from taskcomplexity.report.data import StudyData, return_matrix
from taskcomplexity.report.format import and_list, joined, num, of_total, plural, slug
from taskcomplexity.report.groups import group_blocks
from taskcomplexity.report.html import FigureBlock, Paragraph, Section, TableBlock
from taskcomplexity.report.outcomes import legend as outcome_legend
from taskcomplexity.report.sac_summary import format_sac_summary
from taskcomplexity.report.tables import (
    bins_display,
    diagnostics_display,
    interval_table,
    statistics_table,
    table1,
    welch_display,
)
from taskcomplexity.report.verdict_tables import (
    correlation_display,
    headline_metrics,
    outcome_words,
    published_values_display,
    reasons_shown,
    reference_table,
    replication_display,
    summary_display,
    survival_tables,
    verdict_display,
    verdict_matrix,
)
from taskcomplexity.report.writer import Writer, left_out, panels_left_out
from taskcomplexity.verdict.references import CONFIDENCE, reference_label
from taskcomplexity.verdict.replication import FINDING_ONLY, FINDING_ONLY_MEANING, MEANINGS

SCORE = "score"
"""The metric on the vertical axes of the score scatter (when registered)."""


def _axis(label: str, unit: str) -> str:
    return f"{label} ({unit})" if unit else label


def _uncorrelated(side: str, pairs: int, tasks: int, named: str) -> str:
    """Why a panel of the score scatter has no Pearson r (:func:`~taskcomplexity.report.figures.correlation_gap`),
    said of its metric."""
    if side == "tasks":
        return (f"finite together with {named} on {of_total(pairs, tasks, 'task')}"
                + (f"; a correlation needs {fig.MIN_CORRELATED}" if pairs else ""))
    where = "every task" if pairs == tasks else f"each of the {pairs} tasks where both are finite"
    return f"the same on {where}" if side == "x" else f"{named} is the same on {where}"


def scatter_block(writer: Writer, table: pd.DataFrame, styles, *, y: tuple[str, str], named: str,
                  panels: list[tuple[str, str]], file: str, title: str, what: str, caption: str,
                  after: str = "") -> FigureBlock | Paragraph:
    """The score scatter of ``table`` (one row per task) against ``y``, or the line saying why it is left out.

    A panel whose metric has no Pearson r with ``y`` is dropped and named in the caption; without any panel
    left, the figure is left out. ``named``: ``y`` in a sentence; ``what``: the figure in a sentence; the
    caption is ``caption`` + " across N tasks" + ``after``.
    """
    n, target = len(table), table[y[0]].to_numpy(dtype=float)
    correlated = fig.correlated_panels(table, y[0], panels)
    gaps: dict[str, list[str]] = {}
    for column, label in panels:
        if column in correlated.gaps:
            gaps.setdefault(_uncorrelated(*correlated.gaps[column], n, named), []).append(label)
    if not correlated.shown:
        finite = int(np.isfinite(target).sum())
        if n < fig.MIN_CORRELATED:
            why = f"this report compares {plural(n, 'task')}, and a correlation needs at least {fig.MIN_CORRELATED}"
        elif finite < fig.MIN_CORRELATED:
            why = (f"{named} is finite on {of_total(finite, n, 'task')}, and a correlation needs at least "
                   f"{fig.MIN_CORRELATED}")
        elif np.ptp(target[np.isfinite(target)]) == 0:
            where = "every task" if finite == n else f"each of the {finite} tasks where it is finite"
            why = f"{named} is the same on {where}, so there is nothing to correlate"
        else:
            why = f"no metric has a correlation with {named}: " + "; ".join(
                f"{and_list(labels)} ({reason})" for reason, labels in gaps.items())
        return left_out(what, why)
    fewer = any(correlated.pairs[c] < n for c, _ in correlated.shown)
    across = f" across {plural(n, 'task')}" + (
        " (a title ending in (n = k): across only the k tasks where both values are finite)" if fewer else "")
    return writer.figure([(fig.score_scatter_figure(table, styles, y=y, panels=panels), file)], title,
                         caption + across + after + panels_left_out(gaps))


def published_blocks(writer: Writer, data: StudyData) -> list:
    """The study's published tables with ours beside them, and its published correlations beside ours."""
    published = data.study.published
    if published is None or not published.tables:
        return []
    scale = (f"N = {published.policies:,} policies × M = {published.episodes:,} episodes, B = {published.bins:,} "
             f"bins")
    blocks = []
    for name, table in published.tables.items():
        if any(t in table.values for t in data.tasks):
            blocks.append(writer.table(
                published_values_display(data, name), f"published_{name}",
                f"Ours beside {published.source}, {table.source}.",
                f"Each cell: ours (published). Theirs are at {scale}; ours at this report's scale and on this "
                "study's simulators, so levels compare loosely and the order of the tasks strictly. Ours are "
                "whole-sample estimates; Score(A) and Score(R) use our random policies' r_min, r_max and r_mean.",
                wrap=True))
    if len(data.verdict["replications"]):
        blocks.append(writer.table(
            replication_display(data), "replications", f"Published correlations beside ours ({published.source}).",
            "Pearson r (two-sided p) across tasks on each metric's easiness (a published r on a value is turned to "
            "easiness: the sign flips where lower is easier). Our interval: 2.5–97.5 % percentiles of r over the "
            "bootstrap resamples of the policies, with the reference scores held at their whole-sample values. "
            "Informative tasks only: the tasks whose value exceeds its permutation null and sits below its "
            "ceiling. Net of the null: each value minus the mean of its permutation null. Ours holds when p < "
            f"{1 - CONFIDENCE:g} and its interval is clear of 0 on the published side. Outcomes: "
            + "; ".join(f"{name}: {meaning}" for name, meaning in shown_meanings().items()) + ".", wrap=True))
    return blocks


def shown_meanings() -> dict[str, str]:
    """Every outcome a published correlation is shown with, in order, with what it means."""
    meanings = dict(MEANINGS)
    shown = list(meanings.items())
    shown.insert(list(meanings).index("reproduced") + 1, (FINDING_ONLY, FINDING_ONLY_MEANING))
    return dict(shown)


def verdict_blocks(writer: Writer, data: StudyData, *, alpha: float) -> tuple:
    """The verdict box's tables: the relation × metric matrix and the per-metric summary."""
    blocks = group_blocks(writer, data, alpha=alpha)
    defined: set[str] = set()
    if len(data.verdict["verdict"]):
        blocks.append(headline_matrix(writer, data, alpha=alpha, defined=defined))
    caption = ("Counts of outcomes over the known relations" if len(data.verdict["verdict"]) else
               "The study gives no relation, so nothing is counted")
    caption += ("; Kendall's τ between each known order of the study and the metric's order (+1: exactly as "
                "known, −1: reversed)" if data.study.orders else "")
    references = data.verdict["references"]
    named = joined(reference_label(n) for n in dict.fromkeys(references["reference"]))
    caption += (f"; Pearson r (p) of the metric's easiness with {named} across tasks (higher = easier)"
                if len(references) else "")
    caption += "." + definitions(data, data.verdict["summary"]["metric"], defined)
    blocks.append(writer.table(summary_display(data), "verdict_summary", "Verdict per metric.", caption))
    if len(references):
        algorithm = ("Score(A) = (A_avg − r_min)/(max(r_max, A_max) − r_min) and Score(R) = (r_mean − r_min)/"
                     "(max(r_max, A_max) − r_min), with r_min the worst policy mean, r_max the best episode return "
                     "and A_max, A_avg the study's algorithm scores (Furuta et al. 2021). "
                     if data.study.algorithm_scores else "")
        cited = (f"The reference score: {data.study.reference_source}. " if data.study.reference_source else "")
        blocks.append(writer.table(
            reference_table(data), "reference_scores", "Metrics and reference scores per task.",
            "Point estimates on the whole sample (nats for the entropies and PIC/POIC, returns for r_mean and "
            "variance) beside the reference scores. " + algorithm + cited))
        blocks.append(writer.table(
            correlation_display(data), "reference_correlations", f"Correlation with {named}.",
            "Pearson r (two-sided p) and Spearman ρ across tasks between each reference score and each metric's "
            "easiness (its value, negated when lower is easier) or each entropy as it is. With a handful of "
            "tasks only |r| near 1 is evidence."))
        blocks += published_blocks(writer, data)
        first = references["reference"].iloc[0]
        scored = data.metrics.merge(references[references["reference"] == first][["task", "value"]]
                                    .rename(columns={"value": first}), on="task", how="left")
        named = reference_label(first)
        blocks.append(scatter_block(
            writer, scored, data.styles, y=(first, named), named=named, panels=metric_panels(data, exclude=()),
            file="reference_scatter", title=f"{named} against every metric.",
            what=f"the figure of {named} against every metric",
            caption="Each point is a task; panel titles give Pearson's r and its p-value",
            after=" on the metric's value as it is (the table above uses its easiness, which differs in sign only "
                  "for a metric where lower is easier)."))
    return tuple(blocks)


def definitions(data: StudyData, metrics, defined: set[str]) -> str:
    """" Defined: score_R = …; variance = …." for the ``metrics`` (names) with a registry definition not yet in
    ``defined``, which it then holds (empty when there is none): each metric is defined where the page first names
    it."""
    registry = data.registry
    new = [m for m in dict.fromkeys(metrics) if m in registry and registry[m].definition and m not in defined]
    defined.update(new)
    if not new:
        return ""
    return " Defined: " + "; ".join(f"{registry.label(m)} = {registry[m].definition}" for m in new) + "."


def headline_matrix(writer: Writer, data: StudyData, *, alpha: float, defined: set[str] | None = None) -> TableBlock:
    """The verdict box's relation × metric matrix: the primary metrics, each family's most agreeing metric and
    the most contradicting one (:func:`~taskcomplexity.report.verdict_tables.headline_metrics`), narrow enough
    for the page."""
    chosen, representatives, contradicting = headline_metrics(data)
    matrix, tips = verdict_matrix(data, chosen)
    registry = data.registry
    primary = [m for m in chosen if m in registry and registry[m].primary]
    parts = [f"the primary metrics ({joined(registry.label(m) for m in primary)})"] if primary else []
    if representatives:
        parts.append("the metric of each family that agrees most often with the known relations, net of "
                     "contradictions (" + "; ".join(f"{family}: {registry.label(m)}"
                                                    for family, m in representatives.items()) + ")")
    if contradicting is not None:
        parts.append(f"the metric that contradicts them most often ({registry.label(contradicting)})")
    shown = "Columns: " + "; ".join(parts)
    left = len(dict.fromkeys(data.verdict["verdict"]["metric"])) - len(chosen)
    appendix = (f"; the full matrix of all {plural(len(chosen) + left, 'metric')} is in the appendix"
                if left else "")
    outcomes = data.verdict["verdict"].loc[data.verdict["verdict"]["metric"].isin(chosen), "outcome"]
    return writer.table(
        matrix, "verdict_headline", "Verdict by known relation.",
        f"{shown}{appendix}. {outcome_legend(outcomes, reasons_shown(data, chosen))}. Hover a cell for the values, "
        "the p-value and the reason of ○ "
        f"(Welch's test, significant at p < {alpha:g})." + definitions(data, chosen, set() if defined is None
                                                                      else defined), tips,
        files=(outcome_words(matrix), "Outcome of the primary metrics, each family's most agreeing metric and the "
                                      "most contradicting one on every known relation (significant at p < "
                                      f"{alpha:g}, Welch's t-test)."),
    )


def metric_panels(data: StudyData, *, exclude: tuple[str, ...]) -> list[tuple[str, str]]:
    """(column, axis label) of every metrics-stage metric and shown detail the metrics table holds."""
    panels = [(d.name, _axis(d.label, d.unit)) for m in data.registry.of_stage("metrics") if m.name not in exclude
              for d in ((m,) + tuple(x for x in m.details if x.shown))]
    return [(name, label) for name, label in panels if name in data.metrics.columns]


def rwg_section(writer: Writer, data: StudyData, *, alpha: float) -> Section:
    """Random-weight guessing: the trio figure, Table 1, intervals, bootstrap, Welch matrices, scatter, statistics."""
    registry = data.registry
    subsampled = [t for t in data.tasks if data.returns[t].size > fig.MAX_EPISODE_DOTS]
    dots = (f"For {', '.join(data.name(t) for t in subsampled)} a fixed random subset of "
            f"{fig.MAX_EPISODE_DOTS:,} episode returns is drawn (of N·M) to keep the figure legible. "
            if subsampled else "Every episode return is drawn. ")
    bootstrapped = [m for m in registry.of_stage("metrics") if m.bootstrapped]
    names = joined(m.label for m in bootstrapped)
    blocks = [
        Paragraph("Each task was sampled with random-weight guessing: random policies drawn from the weight "
                  "prior, each run for M episodes. The figures show how the returns spread over policies; the "
                  "tables give the information-theoretic metrics of the paper with their uncertainty."),
        writer.figure(
            [(fig.rwg_trios_figure(data.policies, data.styles, returns=data.returns), "rwg_trios")],
            "Random-weight guessing statistics per task.",
            "One row per task. Left: histogram of the min–max scaled mean return Mₙ′ of every policy "
            "(log scale); a mass at 0 with a thin tail to 1 means good policies are rare. Middle: Mₙ "
            "against its rank Rₙ (black) with every episode return S[n, e] as a faint red dot at its "
            "policy's rank; the vertical spread of the dots is the within-policy noise that H(R|Θ) "
            "measures. " + dots + "Right: the standard deviation √Vₙ of each policy's returns against its mean.",
        ),
    ]
    if bootstrapped:
        blocks += [
            writer.table(table1(data), "table1", f"{names} of random policies.",
                         f"Bootstrap mean ± sd ({joined(m.unit for m in bootstrapped)}), as Table 1 of the paper. "
                         + table1_caveats(data, bootstrapped)),
            writer.table(interval_table(data), "bootstrap_intervals", "Bootstrap intervals.",
                         "Point estimate on the whole sample and percentile 95 % interval of the bootstrap, and "
                         "the POIC temperature λ* (flagged when on a boundary of the search range)."),
            bootstrap_block(writer, data, bootstrapped),
        ]
    welch = data.verdict["welch"]
    for metric in [m for m in registry if m.primary and (welch["metric"] == m.name).any()]:
        matrix, tests = welch_display(data, metric.name)
        batches = data.verdict["samples"]
        sizes = joined(batches[batches["metric"] == metric.name].groupby("task").size())
        blocks.append(writer.table(
            matrix, f"welch_{metric.name}", f"Welch's t-tests of {metric.label}.",
            f"Statistic (two-sided p-value) of row minus column, on the estimates of {sizes} consecutive policy "
            f"batches; significant when p < {alpha:g}.", wrap=True,
        ))
        writer.data(tests, f"welch_{metric.name}_tidy")
    if SCORE in registry and len(data.tasks) >= 1:
        named = f"the normalised score {registry[SCORE].label}"
        blocks.append(scatter_block(
            writer, data.metrics, data.styles, y=(SCORE, named[4:]), named=named,
            panels=metric_panels(data, exclude=(SCORE,)), file="score_scatter",
            title="Normalised score against every metric.", what=f"the figure of {named} against every metric",
            caption="Each point is a task (marker: its study group). Panel titles give Pearson's r and its p-value",
            after="; with so few points only strong correlations are meaningful."))
    blocks.append(writer.table(statistics_table(data), "rwg_statistics", "Random-policy statistics.",
                               "Worst policy mean r_min, best return r_max (sum of rewards), the metrics of the "
                               "metrics stage without a bootstrap, and the entropies behind the bootstrapped "
                               "ones (nats)."))
    return Section("Random policies: the metrics of random-weight guessing", tuple(blocks))


def bootstrap_block(writer: Writer, data: StudyData, bootstrapped) -> FigureBlock | Paragraph:
    """The bootstrap violins of the metrics with a finite draw, or the line saying why there are none."""
    names = joined(m.label for m in bootstrapped)
    panels = [(m.name, _axis(m.label, m.unit)) for m in bootstrapped]
    drawn = {name for name, _ in fig.drawn_draws(data.bootstrap, panels)}
    empty = [m.label for m in bootstrapped if m.name not in drawn]
    if not drawn:
        return left_out(f"the figure of the bootstrap distributions of {names}",
                        f"no task has a finite bootstrap draw of {and_list(empty)}")
    return writer.figure(
        [(fig.bootstrap_figure(data.bootstrap, data.metrics, data.styles, panels), "bootstrap")],
        f"Bootstrap distributions of {joined(m.label for m in bootstrapped if m.name in drawn)}.",
        "Violins: the bootstrap draws of each task (resampling policies); black diamond: the point "
        "estimate; black bar: the percentile 95 % interval. Overlapping violins are pairs the data cannot "
        "order. A point estimate outside its own violin is the histogram estimator's bias at work: a "
        "resample repeats policies, which removes distinct returns and lowers H(R)."
        + panels_left_out({"no task has a finite bootstrap draw": empty}),
    )


NO_SAC_BUDGET = "the study gives no task a SAC budget (sac_steps)"
"""Why a study has no SAC reference, or trains SAC for the run's ``sac.total_steps``."""
NO_SAC_REFERENCE = (f"{NO_SAC_BUDGET} and this run no sac.total_steps, so it has no SAC reference: give its tasks "
                    "sac_steps, or add sac.total_steps=<env steps> sac.enabled=true to this run's command to train "
                    "every task for that many steps")
"""What the report says of SAC for a study without SAC budgets whose run set no ``sac.total_steps``."""


def sac_way(data: StudyData, sac_curves: pd.DataFrame | None) -> str:
    """How this study gets its SAC curves, as the report advises it (empty when the report cannot say).

    The run's own command with ``sac.enabled=true`` (``curves.attrs["sac_command"]``, its overrides kept), noting
    that a study without SAC budgets then trains every task for the run's ``sac.total_steps``; or, for such a study
    whose run set none, that it has no SAC reference and what would give it one.
    """
    command = (sac_curves.attrs if sac_curves is not None else {}).get("sac_command")
    if command:
        return f"`{command}`" + ("" if data.study.has_sac_budgets else
                                 f"; {NO_SAC_BUDGET}, so SAC trains every task for this run's sac.total_steps")
    if sac_curves is None and data.study.kind != "variants" and not data.study.has_sac_budgets:
        return NO_SAC_REFERENCE
    return ""


def sac_section(writer: Writer, data: StudyData, sac_curves: pd.DataFrame | None) -> Section:
    """The empirical order: SAC learning curves and their summary (or why there are none)."""
    title = "Empirical difficulty: SAC"
    attrs = sac_curves.attrs if sac_curves is not None else {}
    command, missing = attrs.get("sac_command"), attrs.get("sac_missing") or []
    how = (f"SAC was not trained in this run (sac.enabled=false). Compute the "
           f"curves with {sac_way(data, sac_curves)}; this report's command then shows them from the cache. ")
    if sac_curves is None or sac_curves.empty or data.sac_per_seed is None or data.sac_per_seed.empty:
        skipped = attrs.get("sac_skipped") or {}
        why = ("SAC was skipped for " + "; ".join(f"{data.name(t)} ({r})" for t, r in skipped.items()) + ". "
               if skipped else "")
        if command:
            why += how + "Until then, "
        elif sac_way(data, sac_curves) == NO_SAC_REFERENCE:
            why += NO_SAC_REFERENCE[:1].upper() + NO_SAC_REFERENCE[1:] + ". So "
        elif not skipped:
            why += "SAC curves were not computed for this report, so "
        return Section(title, (Paragraph(why + "the known complexity order is checked against the random-policy "
                                         "metrics only."),))
    note = ()
    if command and missing:
        note = (Paragraph(f"Curves of {', '.join(data.name(t) for t in missing)} are not in the cache yet. " + how),)
    return Section(title, (
        sac_curves_block(writer, data, sac_curves),
        writer.table(
            format_sac_summary(data), "sac_summary", "SAC summary.",
            "Mean ± sd across seeds of the final return (mean of the last 5 evaluations, sum of rewards), the "
            "same normalised to [worst random policy mean, best return seen], the area under the normalised "
            "curve (its mean over training) and the env steps to cover 90 % of the improvement from the first "
            "evaluation to the final return.",
        ),
        *note,
    ))


def _no_curve(curves: pd.DataFrame, tasks: list[str], whose: str) -> str:
    """Why ``tasks`` have no SAC curve to draw (:func:`~taskcomplexity.report.figures.drawable_curves`)."""
    runs = curves[curves["task"].isin(tasks)]
    if runs.empty:
        return f"no SAC run of {whose} is in the curves"
    if not np.isfinite(runs["eval/return_mean"].to_numpy(dtype=float)).any():
        return f"no SAC evaluation of {whose} has a finite return"
    return (f"every SAC evaluation of {whose} with a finite return is at step 0, which the log axis of environment "
            "steps cannot show")


def sac_curves_block(writer: Writer, data: StudyData, sac_curves: pd.DataFrame) -> FigureBlock | Paragraph:
    """The SAC learning curves (one panel per study group with a curve), or the line saying why there are none."""
    groups = list(dict.fromkeys(s.group for s in data.styles.values()))
    drawn = fig.sac_groups(sac_curves, data.styles)
    if not drawn:
        return left_out("the figure of the SAC learning curves", _no_curve(sac_curves, data.tasks, "the study's tasks"))
    gaps: dict[str, list[str]] = {}
    for group in (g for g in groups if g not in drawn):
        members = [t for t, s in data.styles.items() if s.group == group]
        gaps.setdefault(_no_curve(sac_curves, members, "its tasks"), []).append(
            f"the {group} group" if group is not None else "the tasks without a group")
    seeds = int(data.sac_per_seed.groupby(["task", "variant"]).size().max())
    grouped = "one panel per study group; " if any(s.group for s in data.styles.values()) else ""
    return writer.figure(
        [(fig.sac_curves_figure(sac_curves, data.styles), "sac_curves")], "SAC learning curves.",
        f"Mean evaluation return across seeds (up to {seeds}) against environment steps on a log axis, "
        f"{grouped}the band is the 95 % t-interval of the mean across seeds (absent with one seed). Solid: "
        "SAC; dashed: SAC + HER. Evaluations at step 0 are not drawn on the log axis. An easier task rises "
        "earlier and higher." + panels_left_out(gaps),
    )


def table1_caveats(data: StudyData, bootstrapped) -> str:
    """What Table 1's numbers hold besides information: the null's share of each value, and how far the bootstrap
    mean sits from the whole-sample value (a resample repeats policies, which lowers a plug-in entropy)."""
    words = []
    if any(m.information is not None and m.information.null for m in bootstrapped):
        words.append("A null share is the part of the whole-sample value that its permutation null gives (returns "
                     "shuffled across policies, no information): the estimator's bias, from the verdict's "
                     "information check.")
    worst = None
    for m in bootstrapped:
        for _, row in data.metrics.iterrows():
            point, mean, sd = row.get(m.name), row.get(f"{m.name}_mean"), row.get(f"{m.name}_sd")
            if all(v is not None and np.isfinite(v) for v in (point, mean, sd)) and abs(point - mean) > 2 * sd:
                gap = abs(point - mean)
                if worst is None or gap > worst[0]:
                    worst = (gap, m, row["task"], point, mean)
    if worst is not None:
        gap, m, task, point, mean = worst
        words.append(f"At this N the bootstrap mean is biased: it sits more than 2 sd from the whole-sample value "
                     f"(most for {m.label} of {data.name(task)}: {num(mean)} against {num(point)}), because a "
                     "resample repeats policies; the bootstrap intervals below give the whole-sample values.")
    return " ".join(words)


def diagnostics_section(writer: Writer, data: StudyData) -> Section:
    """How much of each task's PIC is estimator bias: sweeps, the permutation null, other estimators."""
    title = "Can the PIC estimate be trusted?"
    if not data.diagnostics:
        return Section(title, (
            Paragraph("The estimator diagnostics (permutation null, bins and subsample sweeps, Miller–Madow and "
                      "nearest-neighbour estimates) were not computed for this report."),
        ))
    tasks = [t for t in data.tasks if t in data.diagnostics]
    d = data.diagnostics
    styles = {t: data.styles[t] for t in tasks}
    knn = joined(f"{plural(d[t]['estimators']['knn_policies'].iloc[0], 'policy', 'policies')} × "
                 f"{plural(d[t]['estimators']['knn_episodes'].iloc[0], 'episode')}"
                 for t in tasks if "knn_policies" in d[t]["estimators"].columns)
    others = joined(m.label for m in data.registry.of_stage("diagnostics"))
    blocks = [
        Paragraph("With continuous returns and many bins, almost every episode lands in its own bin, so the "
                  "histogram PIC approaches ln(occupied bins) − ln M whatever the policies do. The diagnostics "
                  "below measure how much of each task's PIC is this bias: the same estimator on returns "
                  "permuted across policies (true MI = 0), its dependence on B, N and M, and other estimators "
                  f"of the same mutual information ({others})."),
        writer.figure(
            [(fig.bins_sweep_figure({t: d[t]["bins_sweep"] for t in tasks},
                                    {t: d[t]["subsample_sweep"] for t in tasks}, styles), "diagnostics_bins")],
            "PIC depends on the estimator's settings.",
            "Left: histogram PIC (solid) and its Miller–Madow correction (dotted) against the number of bins B. "
            "Middle and right: histogram PIC at the report's B on nested random subsets of policies and of "
            "episodes. A trustworthy estimate would be flat; a curve that keeps rising with B or N reflects "
            "bin occupancy rather than information.",
        ),
        null_block(writer, data, tasks),
        writer.table(diagnostics_display(data), "diagnostics_estimators", "Estimators of I(Θ; R).",
                     "Histogram PIC and its permutation null (mean ± sd); the other registered estimators "
                     + (f"(the k-nearest-neighbour one on {knn} per task)" if knn else "")
                     + "; PIC minus its null in null standard deviations (z); POIC minus its null (z). All in nats."),
        writer.table(bins_display(data), "diagnostics_bins", "PIC against the number of bins.",
                     "Histogram PIC (Miller–Madow in parentheses), nats."),
    ]
    for quantity, table in survival_tables(data).items():
        compared = list(table.columns[2:-1])
        blocks.append(writer.table(
            table, f"verdict_survival_{slug(quantity)}" if len(survival_tables(data)) > 1 else "verdict_survival",
            "Does each verdict survive a change of estimator?",
            f"Outcome of each known relation under every estimator of {quantity} ({', '.join(compared)}), each "
            "tested with Welch's t-test on the same policy batches. Survives: 'yes' when at least two estimators "
            "are informative and all of those reach the same outcome, 'no' when they differ (an uninformative "
            "estimator measures its bias and is left out of the comparison).",
        ))
    return Section(title, tuple(blocks))


def null_block(writer: Writer, data: StudyData, tasks: list[str]) -> FigureBlock | Paragraph:
    """Every estimator with a finite value against its permutation null, or the line saying why there is none."""
    d, labels = data.diagnostics, {m.name: m.label for m in data.registry}
    nulls, summaries = {t: d[t]["null"] for t in tasks}, {t: d[t]["null_summary"] for t in tasks}
    found = fig.null_estimators(nulls, summaries)
    empty = [labels.get(m, m) for m, finite in found.items() if not finite]
    what = "the figure of every estimator of I(Θ; R), and POIC, against its permutation null"
    if not found:
        return left_out(what, "the diagnostics artefacts hold no permutation null of any estimator")
    if len(empty) == len(found):
        return left_out(what, f"no task has a finite observed value or null draw of {and_list(empty)}")
    return writer.figure(
        [(fig.null_figure(nulls, summaries, {t: data.styles[t] for t in tasks}, labels), "diagnostics_null")],
        "Every estimator of I(Θ; R), and POIC, against its permutation null.",
        "Grey ticks: the estimator on returns shuffled across policies (true MI = 0); grey square and bar: "
        "their mean ± sd; coloured ring: the observed value. Only the distance between the ring and the null "
        "is evidence of information about the policy."
        + panels_left_out({"no task has a finite observed value or null draw": empty}),
    )


def ablation_section(writer: Writer, ablation: Mapping) -> Section:
    """Overlaid RWG trios of the variants of a task (a study of kind ``variants``)."""
    groups = ablation if all(isinstance(v, Mapping) for v in ablation.values()) else {"": ablation}
    blocks = []
    for title, variants in groups.items():
        resolved = {name: (return_matrix(v.rwg) if hasattr(v, "rwg") else v) for name, v in variants.items()}
        if not resolved:
            blocks.append(left_out(f"the ablation figure{' of ' + str(title) if title else ''}",
                                   "it has no variant to draw"))
            continue
        blocks.append(writer.figure(
            [(fig.ablation_figure(resolved, title=str(title)), f"ablation_{slug(str(title))}")],
            f"Ablation{': ' + str(title) if title else ''}.",
            "The random-weight guessing trio of several samplers of the same task, overlaid: histogram of "
            "the scaled policy means (log scale), the mean return against the rank as a fraction of N, and "
            "√Vₙ against Mₙ. Variants: " + ", ".join(map(str, variants)) + ".",
        ))
    return Section("Ablation: the random-policy sampler", tuple(blocks))


def appendix_section(writer: Writer, data: StudyData) -> Section:
    """The full verdict table (and its tidy data)."""
    verdict = data.verdict["verdict"]
    writer.data(verdict.assign(label=verdict["metric"].map(data.registry.label)), "verdict_tidy")
    writer.data(data.verdict["values"], "verdict_values")
    if verdict.empty:
        return Section("Appendix: the full verdict table", (
            Paragraph("The study gives no relation, so there is no verdict table. Its metrics per task are in "
                      "tables/verdict_values.csv."),))
    matrix, tips = verdict_matrix(data)
    whole = writer.table(
        matrix, "verdict_matrix", "Verdict by known relation, every metric.",
        f"{outcome_legend(verdict['outcome'], reasons_shown(data, verdict['metric']))}. Hover a cell for the values, "
        "the p-value and the reason of ○; the table below "
        "lists them.", tips,
        files=(outcome_words(matrix), "Outcome of every metric on every known relation (Welch's t-test)."))
    budget = next_budget(data)
    recommended = ""
    if budget is not None and budget.changes:
        held = f" at B = {budget.bins:,}" if budget.bins is not None else ""
        recommended = (f" The headline's next budget, N = {shown_size(budget.policies)} × M = "
                       f"{shown_size(budget.episodes)}{held}, is the largest of these sizes of the primary metrics' "
                       "relations.")
    full = writer.table(verdict_display(data), "verdict", "The full verdict.",
                        "Every (metric, known relation): the two values, the outcome and the p-value of Welch's "
                        "t-test, with the number of samples tested on each side (batches or seeds), the share "
                        "of the difference that is the difference of the two tasks' permutation nulls, and what "
                        "would resolve a relation left open: the N at which Welch's test would resolve a test not "
                        "significant (at this M and B), or the M at which the nulls' share of a difference that is "
                        "mostly theirs falls to one half (at this B; a binned estimator's); the headline states "
                        "the assumptions of both." + recommended, wrap=True)
    return Section("Appendix: the full verdict table", (whole, full))

