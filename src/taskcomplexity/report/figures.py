"""The report's figures (seaborn on matplotlib), each saved as PNG and PDF.

Every function builds a :class:`matplotlib.figure.Figure` without pyplot (no global figure
registry, no backend switch, safe in workers) and returns it; :func:`save_figure` writes it. Tasks
are drawn with their study styles (:func:`taskcomplexity.report.labels.task_styles`): one colour per
task in every figure, one marker per study group, names from the study's labels, study order.

Units: returns are "return (sum of rewards)", entropies and mutual informations "nats".

A figure draws only the panels with something to show (a Pearson r, a finite value, a curve); with none it
raises ValueError, and the report puts one line saying why in its place
(:func:`taskcomplexity.report.writer.left_out`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pandas as pd
import scipy.stats
import seaborn as sns
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from taskcomplexity.metrics import policy_statistics
from taskcomplexity.report.labels import GROUP_COLOURS, TaskStyle
from taskcomplexity.verdict.references import correlation

RETURN_UNIT = "sum of rewards"
RETURN_LABEL = f"return ({RETURN_UNIT})"
DPI = 150
WIDTH = 7.0
"""Figure width in inches: a two-column paper's text width."""

MAX_EPISODE_DOTS = 200_000
"""Above this many episode returns, the Mₙ-versus-rank panel draws a fixed random subset of them."""

VARIANT_STYLES = {"sac": "-", "sac+her": "--"}

LEGEND_BELOW = -0.24
"""Top of a panel's legend placed under it, in axes fractions: below the tick labels and the axis label."""

_RC = {
    "font.size": 8,
    "axes.titlesize": 8.5,
    "axes.labelsize": 8,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "legend.fontsize": 7,
    "legend.title_fontsize": 7.5,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.linewidth": 0.6,
    "lines.linewidth": 1.2,
    "savefig.bbox": "tight",
    "savefig.pad_inches": 0.03,
    # set_layout_engine(None) means no engine only while these are off (a matplotlibrc may turn them on)
    "figure.autolayout": False,
    "figure.constrained_layout.use": False,
}


@contextmanager
def paper_style():
    """Paper-size fonts and thin axes, restored afterwards (no global state leaks)."""
    with mpl.rc_context(), sns.axes_style("ticks"):
        mpl.rcParams.update(_RC)
        yield


def save_figure(figure: Figure, directory: Path, name: str) -> list[Path]:
    """Write ``name.png`` (150 dpi) and ``name.pdf`` under ``directory``, their ticks made legible first
    (:func:`legible_ticks`); return both paths.

    Both files share the last layout (:func:`legible_ticks`) and its bounding box: with no layout engine and a given
    box, ``savefig`` draws each file once, where a layout engine or ``bbox_inches="tight"`` would make it draw the
    figure once more before (about two fifths of the time to save a figure: bench/bench_report.py).
    """
    directory.mkdir(parents=True, exist_ok=True)
    paths = [directory / f"{name}.png", directory / f"{name}.pdf"]
    with paper_style():
        figure.set_dpi(DPI)   # laid out as the PNG is drawn
        canvas = FigureCanvasAgg(figure)   # the renderer that lays out, measures and draws the PNG
        legible_ticks(figure)
        pad = mpl.rcParams["savefig.pad_inches"]
        box = figure.get_tightbbox(canvas.get_renderer()).padded(pad)   # inches
        engine = figure.get_layout_engine()
        figure.set_layout_engine(None)   # no engine: paper_style turns the rc's automatic layouts off
        try:
            for path in paths:
                figure.savefig(path, dpi=DPI, bbox_inches=box,
                               metadata={"CreationDate": None} if path.suffix == ".pdf" else None)
        finally:
            figure.set_layout_engine(engine)
    return paths


def shown_tick_labels(axis, which: str = "both") -> list:
    """The tick labels ``axis`` (an Axes' ``xaxis`` or ``yaxis``) shows as it stands: visible, with text, at a
    tick within the view limits; ``which``: "major", "minor" or "both"."""
    low, high = sorted(axis.get_view_interval())
    slack = (high - low) * 1e-9
    coordinate = 0 if axis.axis_name == "x" else 1
    return [label for label in axis.get_ticklabels(which=which)
            if label.get_visible() and label.get_text().strip()
            and low - slack <= label.get_position()[coordinate] <= high + slack]


def shows_tick_labels(axis) -> bool:
    """Whether ``axis`` is meant to label its ticks (not an axis switched off, or a shared one whose labels are
    left to its neighbour)."""
    if not axis.axes.axison or not axis.get_visible():
        return False
    sides = ("labelbottom", "labeltop") if axis.axis_name == "x" else ("labelleft", "labelright")
    parameters = axis.get_tick_params(which="major")
    return any(parameters.get(side, False) for side in sides)


def overlapping(labels: Sequence, *, gap: float = 2.0) -> bool:
    """Whether two of the tick ``labels`` of one axis overlap, or come closer than ``gap`` points, on the canvas
    at the figure's current layout."""
    if not labels:
        return False
    pad = gap * labels[0].figure.dpi / 72
    boxes = [label.get_window_extent() for label in labels]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            if a.x0 < b.x1 + pad and b.x0 < a.x1 + pad and a.y0 < b.y1 + pad and b.y0 < a.y1 + pad:
                return True
    return False


def legible_ticks(figure: Figure, *, attempts: int = 4) -> Figure:
    """Give every labelled axis of ``figure`` at least 2 labelled ticks and no two labels that overlap.

    An axis with fewer than 2 labels in view gets more ticks: a log axis its 1-2-5 ticks (a count axis up to 8
    shows 1, 2, 5), a linear one at least 2 from its locator. An axis whose labels overlap gets fewer: first its
    minor labels go, then a linear axis asks its locator for fewer bins and a log axis drops its 2s and 5s, then
    decades. Fixed ticks (category names, the sizes of a sweep) are left as drawn. The figure is laid out again
    after each change, up to ``attempts`` times, and once more after the last one, so that its last layout is of the
    figure as it stands; returns ``figure``.

    Laying out is what a draw does first (its layout engine places the axes); the rest of a draw, every artist
    walked through, is not needed to read the ticks: an axis computes its ticks and their labels when they are read,
    and a label measures itself with the figure's renderer.
    """
    for _ in range(attempts):
        lay_out(figure)
        changed = False
        for ax in figure.axes:
            for axis in (ax.xaxis, ax.yaxis):
                if shows_tick_labels(axis):
                    labels = shown_tick_labels(axis)
                    if len(labels) < 2:
                        changed |= _more_ticks(axis)
                    elif overlapping(labels):
                        changed |= _fewer_ticks(axis, len(labels))
        if not changed:
            return figure
    lay_out(figure)
    return figure


def lay_out(figure: Figure) -> None:
    """Place the axes of ``figure`` as its layout engine does at the start of a draw (none: they stay), without
    drawing: as ``Figure.draw`` does, a layout the engine cannot fit (``ValueError``) leaves them where they are."""
    engine = figure.get_layout_engine()
    if figure.axes and engine is not None:
        with suppress(ValueError):
            engine.execute(figure)


def _more_ticks(axis) -> bool:
    locator = axis.get_major_locator()
    if axis.get_scale() == "log" and isinstance(locator, mpl.ticker.LogLocator):
        axis.set_major_locator(mpl.ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        if isinstance(axis.get_major_formatter(), mpl.ticker.LogFormatter):
            axis.set_major_formatter(mpl.ticker.FuncFormatter(lambda value, _: f"{value:g}"))
        axis.set_minor_formatter(mpl.ticker.NullFormatter())
        return True
    if isinstance(locator, mpl.ticker.MaxNLocator):
        locator.set_params(min_n_ticks=3)
        return True
    return False


def _fewer_ticks(axis, shown: int) -> bool:
    if shown_tick_labels(axis, "minor"):
        axis.set_minor_formatter(mpl.ticker.NullFormatter())
        return True
    locator = axis.get_major_locator()
    if isinstance(locator, mpl.ticker.LogLocator):
        axis.set_major_locator(mpl.ticker.LogLocator(base=10, numticks=max(2, shown // 2 + 1)))
        return True
    if isinstance(locator, mpl.ticker.MaxNLocator) and shown > 2:
        locator.set_params(nbins=max(1, shown - 2), min_n_ticks=2)
        return True
    return False


def _figure(rows: int, columns: int, height: float, **kwargs) -> tuple[Figure, np.ndarray]:
    figure = Figure(figsize=(WIDTH, height), layout="constrained")
    axes = figure.subplots(rows, columns, squeeze=False, **kwargs)
    return figure, axes


def step_label(value: float) -> str:
    """An environment-step count as an axis shows it: "0", "80", "500", "2k", "12.5k", "0.5M", "1M"."""
    size = abs(value)
    if size < 1000:
        return f"{value:.0f}" if float(value).is_integer() else f"{value:g}"
    if size < 100_000:
        return f"{value / 1000:.3g}k"
    return f"{value / 1e6:.3g}M"


def step_axis(axis, *, log: bool = False) -> None:
    """Readable environment-step ticks on ``axis`` (an Axes' ``xaxis``): :func:`step_label` at whole steps;
    on a log axis the decades, and the minor ticks too when the axis spans less than a decade."""
    if log:
        def minor(value: float, _) -> str:
            low, high = axis.get_view_interval()
            return step_label(value) if high < 10 * max(low, 1e-9) else ""

        axis.set_major_locator(mpl.ticker.LogLocator(base=10, numticks=8))
        axis.set_minor_formatter(mpl.ticker.FuncFormatter(minor))
    else:
        axis.set_major_locator(mpl.ticker.MaxNLocator(nbins=5, integer=True, steps=[1, 2, 2.5, 5, 10]))
    axis.set_major_formatter(mpl.ticker.FuncFormatter(lambda value, _: step_label(value)))


# (a) The RWG trio -----------------------------------------------------------------------------


def episode_dots(returns: np.ndarray, ranks: np.ndarray, *, max_dots: int = MAX_EPISODE_DOTS):
    """Coordinates of the episode returns in the Mₙ-versus-rank panel.

    Parameters
    ----------
    returns : numpy.ndarray, shape (N, M)
        Episode returns S[n, e].
    ranks : numpy.ndarray, shape (N,)
        Rank Rₙ of each policy (1 = lowest mean).
    max_dots : int
        Above this many returns, a fixed (seed 0) uniform subset of this size is drawn.

    Returns
    -------
    (x, y) : numpy.ndarray, numpy.ndarray
        The rank of each dot's policy (not its sampling index) and its return.
    """
    n_policies, n_episodes = returns.shape
    x = np.repeat(ranks, n_episodes)
    y = returns.ravel()
    if y.size > max_dots:
        chosen = np.sort(np.random.default_rng(0).choice(y.size, size=max_dots, replace=False))
        x, y = x[chosen], y[chosen]
    return x, y


def draw_rwg_trio(
    axes: np.ndarray,
    policies: pd.DataFrame,
    *,
    returns: np.ndarray | None,
    colour: str,
    max_dots: int = MAX_EPISODE_DOTS,
) -> None:
    """Draw the three RWG panels of one task into ``axes`` (3 axes).

    Parameters
    ----------
    axes : array of 3 matplotlib Axes
        Histogram of scaled Mₙ; Mₙ versus rank; √Vₙ versus Mₙ.
    policies : pandas.DataFrame
        :func:`~taskcomplexity.metrics.policy_statistics` (``mean``, ``std``, ``rank``, ``scaled_mean``).
    returns : numpy.ndarray, shape (N, M), optional
        Episode returns, drawn as faint red dots at their policy's rank.
    colour : str
        The task's colour.
    max_dots : int
        Subsampling threshold of the episode dots.
    """
    histogram, ranked, spread = axes
    histogram.hist(policies["scaled_mean"], bins=50, range=(0, 1), color=colour, edgecolor="white", linewidth=0.3)
    _log_counts(histogram)
    histogram.set_xlabel("scaled mean return Mₙ′ (min–max)")
    histogram.set_ylabel("policies (log scale)")

    if returns is not None:
        x, y = episode_dots(returns, policies["rank"].to_numpy(), max_dots=max_dots)
        ranked.scatter(x, y, s=_dot_size(x.size), color="#d62728", alpha=_dot_alpha(x.size), linewidths=0,
                       rasterized=True)
    ordered = policies.sort_values("rank")
    ranked.plot(ordered["rank"], ordered["mean"], color="black", linewidth=1.2)
    ranked.set_xlabel("policy rank Rₙ (1 = lowest Mₙ)")
    ranked.set_ylabel(RETURN_LABEL)

    spread.scatter(policies["mean"], policies["std"], s=_dot_size(len(policies)) * 3, color=colour,
                   alpha=min(0.9, _dot_alpha(len(policies)) * 4), linewidths=0, rasterized=True)
    spread.set_xlabel(f"mean return Mₙ ({RETURN_UNIT})")
    spread.set_ylabel(f"sd √Vₙ ({RETURN_UNIT})")


def _dot_alpha(count: int) -> float:
    """Opacity of ``count`` overlapping dots: faint when there are many, visible when there are few."""
    return float(np.clip(3000.0 / max(count, 1), 0.03, 0.7))


def _dot_size(count: int) -> float:
    return float(np.clip(2000.0 / max(count, 1), 0.8, 6.0))


def _log_counts(ax) -> None:
    """Log-scale count axis with plain tick labels (1, 10, 100) and empty bins left out; counts below 10 get the
    ticks 1, 2, 5 at once (the decades alone would label only 1, and :func:`legible_ticks` would draw the figure
    again to add them)."""
    ax.set_yscale("log")
    ax.set_ylim(bottom=0.7)
    if ax.dataLim.y1 < 10:
        ax.yaxis.set_major_locator(mpl.ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(mpl.ticker.FuncFormatter(lambda value, _: f"{value:g}"))
    ax.yaxis.set_minor_formatter(mpl.ticker.NullFormatter())


def rwg_trio_figure(
    title: str,
    policies: pd.DataFrame,
    *,
    returns: np.ndarray | None = None,
    colour: str = "#1f5aa6",
    max_dots: int = MAX_EPISODE_DOTS,
) -> Figure:
    """Figure (a): the RWG trio of one task (histogram of scaled Mₙ; Mₙ vs rank; √Vₙ vs Mₙ)."""
    with paper_style():
        figure, axes = _figure(1, 3, 2.2)
        draw_rwg_trio(axes[0], policies, returns=returns, colour=colour, max_dots=max_dots)
        figure.suptitle(title, fontsize=9, fontweight="bold")
    return figure


def rwg_trios_figure(
    policies: Mapping[str, pd.DataFrame],
    styles: Mapping[str, TaskStyle],
    *,
    returns: Mapping[str, np.ndarray] | None = None,
    max_dots: int = MAX_EPISODE_DOTS,
) -> Figure:
    """Figure (a) for a study: one row of the RWG trio per task, in study order, task colours.

    Parameters
    ----------
    policies : mapping of task id to pandas.DataFrame
        Each task's policy statistics.
    styles : mapping of task id to TaskStyle
        Names and colours, in study order.
    returns : mapping of task id to numpy.ndarray (N, M), optional
        Each task's returns, for the episode dots.
    max_dots : int
        Subsampling threshold of the episode dots, per task.
    """
    tasks = [t for t in styles if t in policies]
    with paper_style():
        figure, axes = _figure(len(tasks), 3, 1.75 * len(tasks) + 0.2)
        for row, task in zip(axes, tasks, strict=True):
            style = styles[task]
            draw_rwg_trio(row, policies[task], returns=(returns or {}).get(task), colour=style.colour,
                          max_dots=max_dots)
            row[0].set_title(style.name, loc="left", fontweight="bold", color=style.colour)
        for row in axes[:-1]:
            for ax in row:
                ax.set_xlabel("")
    return figure


# (b) Normalised score versus the metrics ------------------------------------------------------


def pearson(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Pearson r and its two-sided p-value; NaN when fewer than 3 finite pairs or a constant side."""
    keep = np.isfinite(x) & np.isfinite(y)
    return correlation(scipy.stats.pearsonr, x[keep], y[keep])


MIN_CORRELATED = 3
"""Tasks a correlation needs: with fewer finite pairs, Pearson's r is undefined (:func:`pearson`)."""


def correlation_gap(x: np.ndarray, y: np.ndarray) -> tuple[str, int] | None:
    """Why :func:`pearson` of ``x`` and ``y`` is undefined (None: it is defined), with the count of finite pairs.

    ``("tasks", k)``: only k < :data:`MIN_CORRELATED` pairs are finite; ``("x", k)`` or ``("y", k)``: that
    side is the same on all k finite pairs.
    """
    keep = np.isfinite(x) & np.isfinite(y)
    pairs = int(keep.sum())
    if pairs < MIN_CORRELATED:
        return "tasks", pairs
    for side, values in (("x", x), ("y", y)):
        if np.ptp(values[keep]) == 0:
            return side, pairs
    return None


@dataclass(frozen=True)
class Correlated:
    """Which panels of :func:`score_scatter_figure` have a Pearson r.

    Attributes
    ----------
    shown : list of (column, axis label)
        The panels with an r, in order.
    pairs : dict of column to int
        Tasks with both values finite, per panel (shown or not).
    gaps : dict of column to (str, int)
        Why each other panel has no r (:func:`correlation_gap`).
    """

    shown: list[tuple[str, str]]
    pairs: dict[str, int]
    gaps: dict[str, tuple[str, int]]


def correlated_panels(metrics: pd.DataFrame, y: str, panels: Sequence[tuple[str, str]]) -> Correlated:
    """The panels of ``metrics`` (one row per task) whose column has a Pearson r with column ``y``."""
    target = metrics[y].to_numpy(dtype=float)
    shown, pairs, gaps = [], {}, {}
    for column, label in panels:
        values = metrics[column].to_numpy(dtype=float)
        pairs[column] = int((np.isfinite(values) & np.isfinite(target)).sum())
        gap = correlation_gap(values, target)
        if gap is None:
            shown.append((column, label))
        else:
            gaps[column] = gap
    return Correlated(shown, pairs, gaps)


MAX_TASK_LEGEND = 16
"""Above this many tasks a figure's legend names the groups (marker and colour of the first task of each), not the
tasks: 50 names would cover the panels."""


def legend_handles(styles: Mapping[str, TaskStyle]) -> tuple[list, str]:
    """The legend of a figure of ``styles``' tasks, and its title: a handle per task, or per group above
    :data:`MAX_TASK_LEGEND` tasks (none when the tasks have no groups)."""
    def handle(style: TaskStyle, label: str):
        return mpl.lines.Line2D([], [], linestyle="", marker=style.marker, markerfacecolor=style.colour,
                                markeredgecolor="black", markeredgewidth=0.4, markersize=6, label=label)

    if len(styles) <= MAX_TASK_LEGEND:
        return [handle(style, style.name) for style in styles.values()], "task"
    first = {}
    for style in styles.values():
        if style.group is not None:
            first.setdefault(style.group, style)

    def rank(group: str) -> int:  # ordered difficulty groups (their colours) first, easiest first
        colour = first[group].colour
        return GROUP_COLOURS.index(colour) if colour in GROUP_COLOURS else len(GROUP_COLOURS)

    return [handle(first[group], group.replace("_", " ")) for group in sorted(first, key=rank)], "group"


def score_scatter_figure(
    metrics: pd.DataFrame,
    styles: Mapping[str, TaskStyle],
    *,
    y: tuple[str, str],
    panels: Sequence[tuple[str, str]],
) -> Figure:
    """Figure (b): a score versus every metric across tasks, Pearson r and p per panel.

    Parameters
    ----------
    metrics : pandas.DataFrame
        One row per task with ``task``, the ``y`` column and the columns of ``panels``.
    styles : mapping of task id to TaskStyle
        Colours, markers and names.
    y : (column, axis label)
        The score on the vertical axes (e.g. the normalised score score_R).
    panels : sequence of (column, axis label)
        One panel per metric, in order; a legend of the tasks fills the next free panel. A panel without a
        Pearson r (:func:`correlated_panels`: fewer than 3 tasks with both values, or a side the same on all of
        them) is left out; a title ends in "(n = k)" when only k of the tasks have both values.

    Raises
    ------
    ValueError
        When no panel has a Pearson r: there is nothing to show.
    """
    chosen = metrics[metrics["task"].isin(list(styles))]
    correlated = correlated_panels(chosen, y[0], panels)
    if not correlated.shown:
        raise ValueError(f"no panel has a Pearson r with {y[0]} across {len(chosen)} tasks: nothing to show")
    panels = correlated.shown
    columns = 4
    legend_panel = len(panels) % columns != 0  # a free panel holds the legend, else it goes below
    rows = max(1, -(-len(panels) // columns))
    with paper_style():
        figure, axes = _figure(rows, columns, 1.95 * rows + (0 if legend_panel else 0.6), sharey=True)
        for ax, (column, axis_label) in zip(axes.flat, panels, strict=False):
            for _, row in chosen.iterrows():
                style = styles[row["task"]]
                ax.scatter(row[column], row[y[0]], color=style.colour, s=28, marker=style.marker,
                           edgecolors="black", linewidths=0.4, zorder=3)
            r, p = pearson(chosen[column].to_numpy(dtype=float), chosen[y[0]].to_numpy(dtype=float))
            pairs = correlated.pairs[column]
            ax.set_title(f"r = {r:.2f}, p = {p:.2g}" + (f" (n = {pairs})" if pairs < len(chosen) else ""))
            ax.set_xlabel(axis_label.replace(" (", "\n(") if len(axis_label) > 22 else axis_label)
            ax.xaxis.set_major_locator(mpl.ticker.MaxNLocator(nbins=4))
            ax.margins(0.12)
        for ax in axes[:, 0]:
            ax.set_ylabel(y[1])
        for ax in list(axes.flat)[len(panels):]:
            ax.axis("off")
        handles, title = legend_handles(styles)
        if legend_panel and handles:
            list(axes.flat)[len(panels)].legend(handles=handles, loc="center", frameon=False, title=title)
        elif handles:
            figure.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 4), frameon=False)
    return figure


# (c) Bootstrap distributions ------------------------------------------------------------------


def drawn_draws(draws: Mapping[str, pd.DataFrame], metrics: Sequence[tuple[str, str]]) -> list[tuple[str, str]]:
    """The metrics of ``metrics`` with a finite bootstrap draw on some task (the panels of :func:`bootstrap_figure`)."""
    return [(metric, label) for metric, label in metrics
            if any(metric in table and np.isfinite(table[metric].to_numpy(dtype=float)).any()
                   for table in draws.values())]


def bootstrap_figure(
    draws: Mapping[str, pd.DataFrame],
    points: pd.DataFrame,
    styles: Mapping[str, TaskStyle],
    metrics: Sequence[tuple[str, str]],
) -> Figure:
    """Figure (c): bootstrap distributions of each bootstrapped metric per task.

    Parameters
    ----------
    draws : mapping of task id to pandas.DataFrame
        The metrics stage's ``bootstrap.parquet`` (one column per metric, one row per resample).
    points : pandas.DataFrame
        One row per task: ``task``, and per metric its point estimate and ``<metric>_ci_low``,
        ``<metric>_ci_high`` (percentile 95 % interval).
    styles : mapping of task id to TaskStyle
        Names and colours, in study order.
    metrics : sequence of (column, axis label)
        One panel per metric with a finite draw on some task (:func:`drawn_draws`); the others are left out.

    Raises
    ------
    ValueError
        When no metric has a finite draw: there is nothing to show.
    """
    tasks = [t for t in styles if t in draws]
    metrics = drawn_draws({t: draws[t] for t in tasks}, metrics)
    if not metrics:
        raise ValueError("no bootstrapped metric has a finite draw on any task: nothing to show")
    names = [m for m, _ in metrics]
    tidy = pd.concat([draws[t].reindex(columns=names).assign(task=styles[t].name) for t in tasks], ignore_index=True)
    colours = {styles[t].name: styles[t].colour for t in tasks}
    indexed = points.set_index("task")
    with paper_style():
        figure, axes = _figure(1, len(metrics), 0.36 * len(tasks) + 0.9, sharey=True)
        for ax, (metric, axis_label) in zip(axes[0], metrics, strict=True):
            sns.violinplot(data=tidy, x=metric, y="task", hue="task", palette=colours, order=list(colours),
                           legend=False, inner=None, cut=0, density_norm="width", linewidth=0.5, ax=ax)
            for position, task in enumerate(tasks):
                row = indexed.loc[task]
                ax.plot([row[f"{metric}_ci_low"], row[f"{metric}_ci_high"]], [position, position],
                        color="black", linewidth=1.0)
                ax.plot(row[metric], position, marker="D", color="black", markersize=3.5)
            ax.set_xlabel(axis_label)
            ax.xaxis.set_major_locator(mpl.ticker.MaxNLocator(nbins=5))
            ax.set_ylabel("")
            ax.grid(axis="x", linewidth=0.3, alpha=0.5)
    return figure


# (d) SAC learning curves ----------------------------------------------------------------------


def seed_band(values: pd.DataFrame, column: str) -> pd.DataFrame:
    """Mean across seeds and the 95 % t-interval of that mean at every env step.

    Parameters
    ----------
    values : pandas.DataFrame
        Rows of one (task, variant): ``env_step``, ``seed`` and ``column``.

    Returns
    -------
    pandas.DataFrame
        ``env_step``, ``mean``, ``low``, ``high``, ``seeds``; the interval is NaN with one seed.
    """
    grouped = values.groupby("env_step")[column]
    table = pd.DataFrame({"mean": grouped.mean(), "sd": grouped.std(ddof=1), "seeds": grouped.count()})
    half = scipy.stats.t.ppf(0.975, np.maximum(table["seeds"] - 1, 1)) * table["sd"] / np.sqrt(table["seeds"])
    half = half.where(table["seeds"] >= 2)
    return table.assign(low=table["mean"] - half, high=table["mean"] + half).reset_index()


def drawable_curves(curves: pd.DataFrame) -> pd.DataFrame:
    """The evaluations :func:`sac_curves_figure` can draw: a finite return, after step 0 (the axis is log)."""
    returns = curves["eval/return_mean"].to_numpy(dtype=float)
    return curves[np.isfinite(returns) & (curves["env_step"].to_numpy() > 0)]


def sac_groups(curves: pd.DataFrame, styles: Mapping[str, TaskStyle]) -> list[str | None]:
    """The study groups (None: a study without groups) with a curve to draw, in study order."""
    drawn = set(drawable_curves(curves)["task"])
    return list(dict.fromkeys(s.group for t, s in styles.items() if t in drawn))


def sac_curves_figure(curves: pd.DataFrame, styles: Mapping[str, TaskStyle]) -> Figure:
    """Figure (d): SAC evaluation return against env steps, one panel per study group, log x.

    Lines are the mean across seeds of ``eval/return_mean``; bands are the 95 % t-interval of that
    mean (seeds ≥ 2). Evaluations at step 0 cannot be drawn on a log axis and are left out. Solid
    lines are SAC, dashed SAC + HER. A study without groups gets one panel; a group none of whose tasks
    has a curve to draw (:func:`drawable_curves`) gets none.

    Raises
    ------
    ValueError
        When no task has a curve to draw: there is nothing to show.
    """
    table = drawable_curves(curves)
    groups = sac_groups(curves, styles)
    if not groups:
        raise ValueError("no SAC evaluation after step 0 has a finite return: nothing to show")
    with paper_style():
        tasks_per_panel = max(sum(1 for s in styles.values() if s.group == g) for g in groups)
        figure, axes = _figure(1, len(groups), 2.8 + 0.14 * tasks_per_panel)  # legend rows: ≤ 2 variants, 2 columns
        for ax, group in zip(axes[0], groups, strict=True):
            members = [t for t, s in styles.items() if s.group == group]
            drawn = 0
            for task in members:
                style = styles[task]
                for variant in sorted(table.loc[table["task"] == task, "variant"].unique()):
                    run = table[(table["task"] == task) & (table["variant"] == variant)]
                    band = seed_band(run, "eval/return_mean")
                    name = (style.label if group is not None else style.name) + (
                        " + HER" if variant == "sac+her" else "")
                    ax.plot(band["env_step"], band["mean"], color=style.colour, label=name,
                            linestyle=VARIANT_STYLES.get(variant, ":"))
                    ax.fill_between(band["env_step"], band["low"], band["high"], color=style.colour, alpha=0.2,
                                    linewidth=0)
                    drawn += 1
            ax.set_xscale("log")
            step_axis(ax.xaxis, log=True)
            if group is not None:
                ax.set_title(group)
            ax.set_xlabel("environment steps (log scale)")
            ax.set_ylabel(f"evaluation {RETURN_LABEL}")
            if drawn:  # below the panel, under its axis label: never over the curves
                ax.legend(frameon=False, loc="upper center", bbox_to_anchor=(0.5, LEGEND_BELOW), ncol=2)
    return figure


PATH_PANELS = (("pic", "PIC"), ("poic", "POIC"))
"""The panels of :func:`learning_path_figure`: (column of ``path.parquet``, label)."""


def drawn_paths(paths: Mapping[str, pd.DataFrame]) -> list[tuple[str, str]]:
    """The panels of :data:`PATH_PANELS` with a finite value on some task's path."""
    return [(column, label) for column, label in PATH_PANELS
            if any(column in path and np.isfinite(path[column].to_numpy(dtype=float)).any()
                   for path in paths.values())]


def learning_path_figure(paths: Mapping[str, pd.DataFrame], styles: Mapping[str, TaskStyle]) -> Figure:
    """PIC_k and POIC_k around SAC's actor snapshots against the snapshot's env steps, one line per task.

    ``paths``: task id → ``path.parquet`` of its learning-path artefact (``step``, ``pic``, ``poic``).
    Left panel PIC_k, right panel POIC_k (nats); the dotted line is each task's path mean, the metric. A
    panel without a finite value on any path (:func:`drawn_paths`) is left out.

    Raises
    ------
    ValueError
        When neither panel has a finite value: there is nothing to show.
    """
    panels = drawn_paths(paths)
    if not panels:
        raise ValueError("no learning path has a finite PIC or POIC: nothing to show")
    with paper_style():
        figure, axes = _figure(1, len(panels), 3.3)
        for ax, (column, label) in zip(axes[0], panels, strict=True):
            for task, path in paths.items():
                style = styles[task]
                ax.plot(path["step"], path[column], marker=style.marker, markersize=3, color=style.colour,
                        label=style.name)
                ax.axhline(path[column].mean(), color=style.colour, linestyle=":", linewidth=0.8)
            step_axis(ax.xaxis)
            ax.set_xlabel("SAC environment steps at the snapshot")
            ax.set_ylabel(f"{label}ₖ around the actor (nats)")
            ax.set_title(f"learning-path {label}")
        figure.legend(*axes[0][0].get_legend_handles_labels(), loc="outside lower center", ncol=4, frameon=False)
    return figure


# (e) Estimator diagnostics --------------------------------------------------------------------


def bins_sweep_figure(
    bins_sweeps: Mapping[str, pd.DataFrame], subsamples: Mapping[str, pd.DataFrame], styles: Mapping[str, TaskStyle]
) -> Figure:
    """Figure (e1): histogram PIC against the number of bins, of policies and of episodes.

    Parameters
    ----------
    bins_sweeps : mapping of task id to pandas.DataFrame
        ``bins_sweep.parquet`` (``bins``, ``pic``, ``pic_miller_madow``).
    subsamples : mapping of task id to pandas.DataFrame
        ``subsample_sweep.parquet`` (``policies``, ``episodes``, ``pic``).
    styles : mapping of task id to TaskStyle
        Names, colours and markers, in study order.
    """
    tasks = [t for t in styles if t in bins_sweeps]
    with paper_style():
        figure, axes = _figure(1, 3, 2.6, sharey=True)
        for task in tasks:
            sweep, sub = bins_sweeps[task], subsamples[task]
            colour, marker = styles[task].colour, styles[task].marker
            axes[0, 0].plot(sweep["bins"], sweep["pic"], color=colour, marker=marker, markersize=3,
                            label=styles[task].name)
            axes[0, 0].plot(sweep["bins"], sweep["pic_miller_madow"], color=colour, linestyle=":", linewidth=1.0)
            by_policies = sub[sub["episodes"] == sub["episodes"].max()]
            axes[0, 1].plot(by_policies["policies"], by_policies["pic"], color=colour, marker=marker, markersize=3)
            by_episodes = sub[sub["policies"] == sub["policies"].max()]
            axes[0, 2].plot(by_episodes["episodes"], by_episodes["pic"], color=colour, marker=marker, markersize=3)
        labels = ("bins B (log scale)", "policies N (log scale), all episodes", "episodes M (log scale), all policies")
        sizes = (
            sorted({int(b) for t in tasks for b in bins_sweeps[t]["bins"]}),
            sorted({int(n) for t in tasks for n in subsamples[t]["policies"]}),
            sorted({int(m) for t in tasks for m in subsamples[t]["episodes"]}),
        )
        for ax, xlabel, ticks in zip(axes[0], labels, sizes, strict=True):
            ax.set_xscale("log")
            ax.set_xticks(ticks, [f"{t:,}" for t in ticks])
            ax.xaxis.set_minor_locator(mpl.ticker.NullLocator())
            ax.set_xlabel(xlabel)
            ax.grid(linewidth=0.3, alpha=0.5)
        axes[0, 0].set_ylabel("PIC (nats)")
        axes[0, 0].set_title("solid: histogram, dotted: Miller–Madow")
        axes[0, 1].set_title("histogram PIC vs policies")
        axes[0, 2].set_title("histogram PIC vs episodes")
        figure.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside lower center", ncol=4, frameon=False)
    return figure


def null_estimators(nulls: Mapping[str, pd.DataFrame], summaries: Mapping[str, pd.DataFrame]) -> dict[str, bool]:
    """Every estimator the diagnostics ran a null of (in the order of the summaries), and whether it has a finite
    observed value or null draw on some task: the panels of :func:`null_figure`."""
    estimators = dict.fromkeys(m for summary in summaries.values() for m in summary["metric"])
    for metric in estimators:
        finite = False
        for task, summary in summaries.items():
            observed = summary.loc[summary["metric"] == metric, "observed"].to_numpy(dtype=float)
            draws = nulls[task][metric].to_numpy(dtype=float) if metric in nulls.get(task, {}) else np.array([])
            finite = finite or bool(np.isfinite(observed).any() or np.isfinite(draws).any())
        estimators[metric] = finite
    return estimators


def null_figure(
    nulls: Mapping[str, pd.DataFrame], summaries: Mapping[str, pd.DataFrame], styles: Mapping[str, TaskStyle],
    labels: Mapping[str, str] | None = None,
) -> Figure:
    """Figure (e2): each estimator's observed value on each task against its permutation null.

    One panel per estimator the diagnostics stage ran a null of (two per row) with a finite value on some task
    (:func:`null_estimators`); the observed value is an open ring, so that a null lying on top of it stays
    visible.

    Parameters
    ----------
    nulls : mapping of task id to pandas.DataFrame
        ``null.parquet`` (one column per estimator, one row per permutation).
    summaries : mapping of task id to pandas.DataFrame
        ``null_summary.parquet`` (``metric``, ``observed``, ``null_mean``, ``null_sd``).
    styles : mapping of task id to TaskStyle
        Names and colours, in study order.
    labels : mapping of estimator name to its display name, optional
        Axis labels (the name itself when absent).

    Raises
    ------
    ValueError
        When no estimator has a finite value on any task: there is nothing to show.
    """
    labels = labels or {}
    tasks = [t for t in styles if t in nulls]
    found = null_estimators({t: nulls[t] for t in tasks}, {t: summaries[t] for t in tasks})
    metrics = [m for m, finite in found.items() if finite]
    if not metrics:
        raise ValueError("no estimator has a finite observed value or null draw on any task: nothing to show")
    columns = min(2, len(metrics))
    rows = -(-len(metrics) // columns)
    with paper_style():
        figure, axes = _figure(rows, columns, rows * (0.32 * len(tasks) + 1.0), sharey=True)
        for ax, metric in zip(axes.flat, metrics, strict=False):
            first = True  # the first task drawn in the panel names the legend's entries
            for position, task in enumerate(tasks):
                if metric not in nulls[task] or not (summaries[task]["metric"] == metric).any():
                    continue
                draws = nulls[task][metric].to_numpy()
                row = summaries[task].set_index("metric").loc[metric]
                ax.scatter(draws, np.full(draws.size, position), s=8, color="0.6", marker="|", linewidths=0.8,
                           label="permutation null" if first else None, zorder=2)
                ax.errorbar(row["null_mean"], position, xerr=row["null_sd"], color="0.3", capsize=2,
                            linewidth=0.8, marker="s", markersize=3,
                            label="null mean ± sd" if first else None, zorder=3)
                ax.scatter(row["observed"], position, s=60, facecolors="none", edgecolors=styles[task].colour,
                           linewidths=1.6, label="observed" if first else None, zorder=4)
                first = False
            ax.set_xlabel(f"{labels.get(metric, metric)} (nats)")
            ax.xaxis.set_major_locator(mpl.ticker.MaxNLocator(nbins=5))
            ax.grid(axis="x", linewidth=0.3, alpha=0.5)
        for ax in axes.flat[len(metrics):]:
            ax.set_visible(False)
        for ax in axes[:, 0]:
            ax.set_yticks(range(len(tasks)), [styles[t].name for t in tasks])
        axes[0, 0].invert_yaxis()  # the axes share y: invert once, first task on top
        axes[0, -1].legend(frameon=False, loc="best")
    return figure


# (f) Ablation: overlaid RWG trios -------------------------------------------------------------


def _as_policies(data: object) -> tuple[pd.DataFrame, np.ndarray | None]:
    if isinstance(data, pd.DataFrame):
        return data, None
    returns = np.asarray(data, dtype=np.float64)
    return policy_statistics(returns), returns


def ablation_figure(variants: Mapping[str, object], *, title: str = "") -> Figure:
    """Figure (f): the RWG trios of several variants of one task, overlaid.

    Parameters
    ----------
    variants : mapping of label to numpy.ndarray (N, M) or pandas.DataFrame
        Per variant (e.g. a network or prior), its return matrix or its policy table
        (:func:`~taskcomplexity.metrics.policy_statistics`). Variants may differ in N: ranks are
        shown as a fraction of N.
    title : str
        Figure title (e.g. the task).

    Raises
    ------
    ValueError
        Without a variant: there is nothing to show.
    """
    if not variants:
        raise ValueError("the ablation has no variant: nothing to show")
    colours = sns.color_palette("colorblind", max(len(variants), 1)).as_hex()
    with paper_style():
        figure, axes = _figure(1, 3, 2.5)
        histogram, ranked, spread = axes[0]
        for colour, (name, data) in zip(colours, variants.items(), strict=False):
            policies, _ = _as_policies(data)
            histogram.hist(policies["scaled_mean"], bins=50, range=(0, 1), histtype="step", color=colour,
                           linewidth=1.0, label=name)
            ordered = policies.sort_values("rank")
            ranked.plot(ordered["rank"] / len(ordered), ordered["mean"], color=colour, linewidth=1.2)
            spread.scatter(policies["mean"], policies["std"], s=_dot_size(len(policies)) * 2, color=colour,
                           alpha=min(0.8, _dot_alpha(len(policies)) * 3), linewidths=0, rasterized=True)
        _log_counts(histogram)
        histogram.set_xlabel("scaled mean return Mₙ′ (min–max)")
        histogram.set_ylabel("policies (log scale)")
        ranked.set_xlabel("policy rank Rₙ / N")
        ranked.set_ylabel("mean return Mₙ")  # units on the right panel's axes: the label must fit 2.5 in
        spread.set_xlabel(f"mean return Mₙ ({RETURN_UNIT})")
        spread.set_ylabel(f"sd √Vₙ ({RETURN_UNIT})")
        figure.legend(*histogram.get_legend_handles_labels(), loc="outside lower center",
                      ncol=min(len(variants), 6), frameon=False)
        if title:
            figure.suptitle(title, fontsize=9, fontweight="bold")
    return figure
