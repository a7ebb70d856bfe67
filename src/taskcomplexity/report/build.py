"""Build the study report: tables, figures, the verdict, ``report.md`` and a self-contained ``index.html``.

:func:`build_report` reads the cached artefacts of every task (RWG returns, metrics, and optionally
the estimator diagnostics), joins the SAC learning curves when there are any, and writes::

    out_dir/index.html          one page, images embedded, opens offline
    out_dir/report.md           the same text in Markdown, figures linked
    out_dir/figures/*.png|pdf   every figure
    out_dir/tables/*.md|tex|csv every table

The page reads like a results section: the verdict first (generated from the numbers), then the
methods box, the random-policy results, the empirical (SAC) order, the estimator diagnostics, the
optional ablation, and the full verdict table.
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from taskcomplexity import metrics as est
from taskcomplexity.metrics.batches import SIGNIFICANCE_LEVEL
from taskcomplexity.pipeline.cache import Artefact
from taskcomplexity.pipeline.rwg_stage import load_returns
from taskcomplexity.pipeline.study import TaskMetrics, metrics_frame
from taskcomplexity.report import figures as fig
from taskcomplexity.report import sac_summary as sacs
from taskcomplexity.report import verdict as ver
from taskcomplexity.report.html import Document, FigureBlock, Paragraph, Section, TableBlock, write_html
from taskcomplexity.report.tables import ARM_LABELS, split_task_id, table1, task_sort_key, write_table

SYMBOLS = {"agree": "✓", "contradict": "✗", "not significant": "–", "undefined": "?"}
DIAGNOSTIC_FILES = ("null", "null_summary", "bins_sweep", "subsample_sweep", "estimators", "batches")


# Loading ---------------------------------------------------------------------------------------


@dataclass
class StudyData:
    """Everything the report reads, per task (task ids in table order)."""

    tasks: list[str]
    results: dict[str, TaskMetrics]
    metrics: pd.DataFrame
    policies: dict[str, pd.DataFrame]
    returns: dict[str, np.ndarray]
    bootstrap: dict[str, pd.DataFrame]
    batches: dict[str, pd.DataFrame]
    diagnostics: dict[str, dict[str, pd.DataFrame]] = field(default_factory=dict)
    diagnostics_config: dict = field(default_factory=dict)


def load_study(results: list[TaskMetrics], diagnostics: Mapping[str, Artefact] | None) -> StudyData:
    """Read every task's artefacts; tasks without a diagnostics artefact have no diagnostics."""
    ordered = sorted(results, key=lambda r: task_sort_key(r.task_id))
    tasks = [r.task_id for r in ordered]
    diagnostics = dict(diagnostics or {})
    loaded = {
        task: {name: pd.read_parquet(artefact.file(f"{name}.parquet")) for name in DIAGNOSTIC_FILES}
        for task, artefact in diagnostics.items()
        if task in tasks
    }
    config = next((a.manifest.get("config", {}) for t, a in diagnostics.items() if t in tasks), {})
    return StudyData(
        tasks=tasks,
        results={r.task_id: r for r in ordered},
        metrics=metrics_frame(ordered),
        policies={r.task_id: r.table("policies.parquet") for r in ordered},
        returns={r.task_id: load_returns(r.rwg) for r in ordered},
        bootstrap={r.task_id: r.table("bootstrap.parquet") for r in ordered},
        batches={r.task_id: r.table("batches.parquet") for r in ordered},
        diagnostics=loaded,
        diagnostics_config=config,
    )


# Formatting ------------------------------------------------------------------------------------


def _decimals(reference: float, digits: int = 3) -> int:
    """Decimals showing ``digits`` significant digits of a small ``reference``, else ``digits`` decimals."""
    if not np.isfinite(reference) or abs(reference) >= 0.1 or reference == 0:
        return digits
    return int(min(8, digits - 1 - np.floor(np.log10(abs(reference)))))


def _num(value: float, digits: int = 3, *, like: float | None = None) -> str:
    """A number for a table: 3 decimals, or 3 significant digits below 0.1 (decimals of ``like`` if given)."""
    if value is None or not np.isfinite(value):
        return "–"
    if abs(value) >= 1e5:
        return f"{value:.{digits}g}"
    return f"{value:.{_decimals(value if like is None else like, digits)}f}"


_SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _p(value: float) -> str:
    """A p-value to 2 significant digits, small ones as ``5.6×10⁻¹⁰`` (no break inside)."""
    if value is None or not np.isfinite(value):
        return "–"
    if value < 1e-10:
        return "<\u00a010⁻¹⁰"
    if value >= 1e-3:
        return f"{value:.2g}"
    mantissa, exponent = f"{value:.1e}".split("e")
    return f"{mantissa}×10{str(int(exponent)).translate(_SUPERSCRIPTS)}"


def _statistic(value: float) -> str:
    """A test statistic to 3 significant digits, without exponent notation, with a true minus sign."""
    text = f"{value:.0f}" if abs(value) >= 1000 else f"{value:.3g}"
    return text.replace("-", "−")


def _pm(mean: float, sd: float, digits: int = 3) -> str:
    """``mean ± sd`` with the same number of decimals on both sides."""
    if mean is None or not np.isfinite(mean):
        return "–"
    places = _decimals(mean, digits)
    return f"{mean:.{places}f} ± {sd:.{places}f}" if np.isfinite(sd) else f"{mean:.{places}f}"


SHORT_ARMS = {"one_link_1m0": "1-link 1.0", "one_link_1m65": "1-link 1.65", "two_link": "2-link",
              "two_link_obstacle": "2-link+obst."}


def _reward_arm(task: str) -> dict[str, str]:
    """Table columns naming a task; an entry that is not a task id (e.g. an ablation variant) keeps its name."""
    arm, reward = split_task_id(task)
    if arm not in ARM_LABELS:
        return {"Reward": "", "Arm": task}
    return {"Reward": reward, "Arm": ARM_LABELS[arm]}


def short_label(task: str) -> str:
    """Compact task name for matrix headers: ``two_link-sparse`` → ``2-link s`` (other names unchanged)."""
    arm, reward = split_task_id(task)
    return f"{SHORT_ARMS[arm]} {reward[:1]}" if arm in SHORT_ARMS else task


_LATEX = {
    "−": "$-$", "×": "$\\times$", "✓": "$\\surd$", "✗": "$\\times$", "Θ": "$\\Theta$", "λ": "$\\lambda$",
    "τ": "$\\tau$", "√": "$\\surd$", "ₙ": "$_n$", "′": "$'$", "·": "$\\cdot$", "\u00a0": "~",
    "<": "$<$", ">": "$>$", "|": "$|$",
}
_SUPERSCRIPT_RUN = re.compile("[⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+")


def latex_text(text: str) -> str:
    """Replace the report's non-ASCII symbols by LaTeX that compiles with pdflatex (``10⁻⁴`` → ``10$^{-4}$``)."""
    digits = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")
    text = _SUPERSCRIPT_RUN.sub(lambda m: "$^{" + m.group(0).translate(digits) + "}$", text)
    for symbol, macro in _LATEX.items():
        text = text.replace(symbol, macro)
    return text


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_") or "ablation"


# Tables ----------------------------------------------------------------------------------------


def interval_table(metrics: pd.DataFrame) -> pd.DataFrame:
    """Point estimate and bootstrap percentile 95 % interval of PIC and POIC, and λ*."""
    rows = []
    for _, r in metrics.iterrows():
        row = _reward_arm(r["task"])
        for m in ("pic", "poic"):
            row[f"{m.upper()}"] = _num(r[m])
            low, high = (_num(r[f"{m}_ci_{side}"], like=r[m]) for side in ("low", "high"))
            row[f"{m.upper()} 95 % interval"] = f"[{low}, {high}]"
        row["λ*"] = f"{r['temperature']:.3g}" + (" (boundary)" if bool(r["temperature_at_boundary"]) else "")
        rows.append(row)
    return pd.DataFrame(rows)


def statistics_table(metrics: pd.DataFrame) -> pd.DataFrame:
    """The random-policy statistics and entropies of every task."""
    rows = []
    for _, r in metrics.iterrows():
        rows.append(
            {
                **_reward_arm(r["task"]),
                "N": int(r["policies"]),
                "M": int(r["episodes"]),
                "r_min": _num(r["r_min"]),
                "r_max": _num(r["r_max"]),
                "r_mean": _num(r["r_mean"]),
                "score_R": _num(r["score"]),
                "variance": _num(r["variance"]),
                "H(R)": _num(r["h_r"]),
                "H(R|Θ)": _num(r["h_r_given_theta"]),
                "H(O)": _num(r["h_o"]),
                "H(O|Θ)": _num(r["h_o_given_theta"]),
            }
        )
    return pd.DataFrame(rows)


def welch_display(data: StudyData, metric: str, *, alpha: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(display matrix with short task names, tidy tests) of Welch's test on the batch estimates."""
    samples = {t: data.batches[t][metric].to_numpy() for t in data.tasks}
    tests = est.welch_matrix(samples, alpha=alpha)
    cells = tests.assign(cell=[("–" if not np.isfinite(p) else f"{_statistic(t)} ({_p(p)})")
                               for t, p in zip(tests["statistic"], tests["pvalue"], strict=True)])
    matrix = cells.pivot(index="task_a", columns="task_b", values="cell").reindex(index=data.tasks,
                                                                                  columns=data.tasks).fillna("")
    matrix = matrix.rename(index=short_label, columns=short_label)
    matrix.columns.name = None
    matrix.index.name = "row vs column"
    return matrix.reset_index(), tests


def verdict_matrix(verdict: pd.DataFrame, relations) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Relations × metrics of outcome symbols, and the tooltip text of every cell.

    Returns
    -------
    (matrix, titles) : pandas.DataFrame, pandas.DataFrame
        ``Known relation``, ``Kind`` and one column per metric label with ✓ (agree), ✗ (contradict),
        – (not significant) or ? (undefined); ``titles`` holds "value vs value, p = …" per cell.
    """
    relations = [r for r in relations if ((verdict["easier"] == r.easier) & (verdict["harder"] == r.harder)).any()]
    metrics = list(dict.fromkeys(verdict["metric"]))
    indexed = verdict.set_index(["metric", "easier", "harder"])
    rows, tips = [], []
    for r in relations:
        row = {"Known relation (easier < harder)": f"{short_label(r.easier)} < {short_label(r.harder)}",
               "Kind": ver.KIND_LABELS.get(r.kind, r.kind)}
        tip = dict.fromkeys(row, "")
        for metric in metrics:
            column = ver.short(metric)
            if (metric, r.easier, r.harder) in indexed.index:
                v = indexed.loc[(metric, r.easier, r.harder)]
                row[column] = SYMBOLS[v["outcome"]]
                tip[column] = (f"{v['outcome']}: {_num(v['value_easier'])} vs {_num(v['value_harder'])}, "
                               f"p = {_p(v['pvalue'])}")
            else:
                row[column], tip[column] = "", ""
        rows.append(row)
        tips.append(tip)
    return pd.DataFrame(rows), pd.DataFrame(tips)


def verdict_display(verdict: pd.DataFrame) -> pd.DataFrame:
    """The full verdict table, one row per (metric, relation), formatted."""
    return pd.DataFrame(
        {
            "Metric": verdict["label"],
            "Kind": verdict["kind"].map(lambda k: ver.KIND_LABELS.get(k, k)),
            "Easier task": verdict["easier"].map(short_label),
            "Harder task": verdict["harder"].map(short_label),
            "Value (easier)": [_num(a, like=max(abs(a), abs(b))) for a, b in zip(verdict["value_easier"],
                                                                                 verdict["value_harder"], strict=True)],
            "Value (harder)": [_num(b, like=max(abs(a), abs(b))) for a, b in zip(verdict["value_easier"],
                                                                                 verdict["value_harder"], strict=True)],
            "Outcome": verdict["outcome"],
            "p": verdict["pvalue"].map(_p),
            "Samples": [f"{a} vs {b}" for a, b in zip(verdict["samples_easier"], verdict["samples_harder"],
                                                      strict=True)],
        }
    )


def summary_display(summary: pd.DataFrame) -> pd.DataFrame:
    """The per-metric verdict summary, formatted."""
    if summary.empty:
        return pd.DataFrame(columns=["Metric", "Family", "Relations", "Agree", "Contradict", "Not significant"])
    table = pd.DataFrame(
        {
            "Metric": summary["label"],
            "Family": summary["family"],
            "Relations": summary["relations"],
            "Agree": summary["agreements"],
            "Contradict": summary["contradictions"],
            "Not significant": summary["not_significant"],
        }
    )
    if summary["undefined"].any():
        table["Undefined"] = summary["undefined"]
    for column in [c for c in summary.columns if c.startswith("kendall_tau_")]:
        table[f"τ {column.removeprefix('kendall_tau_')}"] = summary[column].map(lambda x: _num(x, 2))
    return table


def diagnostics_display(data: StudyData) -> pd.DataFrame:
    """Per task: every estimator of I(Θ; R), and PIC and POIC against their permutation null."""
    rows = []
    for task in data.tasks:
        if task not in data.diagnostics:
            continue
        e = data.diagnostics[task]["estimators"].iloc[0]
        z = data.diagnostics[task]["null_summary"].set_index("metric")["z"]
        rows.append(
            {
                **_reward_arm(task),
                "PIC": _num(e["pic"]),
                "PIC null": _pm(e["pic_null_mean"], e["pic_null_sd"]),
                "PIC − null (z)": f"{_num(e['pic_minus_null'], like=e['pic'])} ({_num(z.get('pic', np.nan), 2)})",
                "Miller–Madow": _num(e["pic_miller_madow"]),
                "kNN": _num(e["pic_knn"]),
                "POIC": _num(e["poic"]),
                "POIC − null (z)": f"{_num(e['poic_minus_null'], like=e['poic'])} ({_num(z.get('poic', np.nan), 2)})",
            }
        )
    return pd.DataFrame(rows)


def knn_sample(data: StudyData) -> str:
    """The k-NN subsample(s), "policies × episodes", for the caption."""
    return _joined(
        f"{int(d['estimators']['knn_policies'].iloc[0])} policies × {int(d['estimators']['knn_episodes'].iloc[0])} "
        "episodes" for d in data.diagnostics.values()
    )


def bins_display(data: StudyData) -> pd.DataFrame:
    """Histogram PIC (Miller–Madow in parentheses) per task and number of bins."""
    rows = []
    for task in data.tasks:
        if task not in data.diagnostics:
            continue
        sweep = data.diagnostics[task]["bins_sweep"]
        row = _reward_arm(task)
        for _, s in sweep.iterrows():
            row[f"B = {int(s['bins']):,}"] = f"{_num(s['pic'], 2)} ({_num(s['pic_miller_madow'], 2)})"
        rows.append(row)
    return pd.DataFrame(rows)


def survival_display(survival: pd.DataFrame) -> pd.DataFrame:
    """The survival table with task names and yes/no."""
    table = survival.copy()
    table.insert(0, "Known relation (easier < harder)",
                 [f"{short_label(a)} < {short_label(b)}" for a, b in zip(table.pop("easier"), table.pop("harder"),
                                                                          strict=True)])
    table["kind"] = table["kind"].map(lambda k: ver.KIND_LABELS.get(k, k))
    table["survives"] = table["survives"].map({True: "yes", False: "no"})
    return table.rename(columns={"kind": "Kind", "survives": "Survives"})


# The verdict -----------------------------------------------------------------------------------


def study_verdict(
    data: StudyData, sac_seeds: pd.DataFrame | None, study, *, alpha: float
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(verdict table, per-metric summary, tidy values) of every metric family present."""
    values = [ver.rwg_values(data.metrics)]
    samples = [ver.rwg_samples(data.batches, data.returns)]
    if data.diagnostics:
        values.append(ver.estimator_values({t: d["estimators"] for t, d in data.diagnostics.items()}))
        samples.append(ver.estimator_samples({t: d["batches"] for t, d in data.diagnostics.items()}))
    if sac_seeds is not None and not sac_seeds.empty:
        sac_values, sac_samples = ver.sac_values_and_samples(sac_seeds)
        values.append(sac_values)
        samples.append(sac_samples)
    values = pd.concat(values, ignore_index=True)
    samples = pd.concat(samples, ignore_index=True)
    table = ver.verdict_table(values, samples, alpha=alpha, relations=study.relations_among(data.tasks))
    return table, ver.summary_table(table, values, study.orders), values


# Methods ---------------------------------------------------------------------------------------


def _joined(values) -> str:
    unique = list(dict.fromkeys(str(v) for v in values))
    return ", ".join(unique)


def methods(data: StudyData, sac_curves: pd.DataFrame | None, *, alpha: float) -> tuple[tuple[str, str], ...]:
    """The methods box: sampling, estimators, tests, diagnostics, SAC and software, from the manifests."""
    requests = [data.results[t].request for t in data.tasks]
    metrics_config = data.results[data.tasks[0]].metrics.manifest.get("config", {})
    network = _joined(
        f"MLP {'×'.join(map(str, r.network.hidden))} {'with' if r.network.bias else 'without'} biases"
        for r in requests
    )
    prior = _joined(r.prior.kind + (f" (variance {r.prior.variance:g})" if r.prior.kind == "normal" else "")
                    for r in requests)
    items = [
        ("Tasks", f"{len(data.tasks)}: " + "; ".join(fig.task_label(t) for t in data.tasks)),
        ("Random policies", f"{network}; weight prior {prior}; deterministic actions"),
        ("Sampling", f"N = {_joined(r.settings.policies for r in requests)} policies × M = "
                     f"{_joined(r.settings.episodes for r in requests)} episodes per task, "
                     f"{_joined(r.task.max_steps for r in requests)} steps per episode, "
                     f"seed {_joined(r.settings.seed for r in requests)}, "
                     f"backend {_joined(r.backend for r in requests)}"
                     + ("; the obstacle's contacts from the batched contact model"
                        if any(r.models_contacts for r in requests) else "")),
        ("PIC", f"histogram with B = {int(metrics_config.get('bins', 0)):,} equal-width bins, nats"),
        ("POIC", "deterministic temperature search over λ ∈ "
                 f"[{', '.join(f'{x:g}' for x in metrics_config.get('temperature_range', []))}]"),
        ("Uncertainty", f"bootstrap of the policies, {metrics_config.get('resamples', '?')} resamples "
                        f"(seed {metrics_config.get('seed', '?')}), percentile 95 % intervals"),
        ("Significance", f"Welch's t-test, two-sided, on {metrics_config.get('batches', '?')} consecutive "
                         f"policy batches (SAC: on seeds); significant when p < {alpha:g}"),
        ("Directions", "every metric is read as higher = easier: PIC and POIC (the paper's claim) and the other "
                       "estimators of PIC's mutual information; score_R and the mean return (random policies "
                       "already do well); the variance (the spread of returns is the signal a search follows); "
                       "SAC's normalised final return and AUC (by definition of the empirical order)"),
    ]
    if data.diagnostics:
        c = data.diagnostics_config
        items.append(("Diagnostics", f"permutation null × {c.get('repeats', '?')} (seed {c.get('seed', '?')}); "
                                     f"bins sweep {_joined(c.get('bins_sweep', []))} (up to B); Miller–Madow; "
                                     f"k-NN MI (k = {c.get('knn_neighbors', '?')})"))
    else:
        items.append(("Diagnostics", "not computed"))
    if sac_curves is not None and not sac_curves.empty:
        seeds = sorted(sac_curves["seed"].unique().tolist())
        variants = _joined(sorted(sac_curves["variant"].unique()))
        budgets = sorted(sac_curves.groupby("task")["env_step"].max().unique())
        items.append(("SAC", f"variants {variants}; seeds {', '.join(map(str, seeds))}; budgets "
                             f"{_joined(f'{int(b):,}' for b in budgets)} env steps per seed"))
    else:
        items.append(("SAC", "not computed"))
    versions = {}
    for task in data.tasks:
        for artefact in (data.results[task].rwg, data.results[task].metrics):
            versions.update(artefact.manifest.get("versions", {}))
    items.append(("Software", ", ".join(f"{k} {v}" for k, v in sorted(versions.items()))))
    keys = ", ".join(f"{short_label(t)}: {data.results[t].metrics.key}" for t in data.tasks)
    items.append(("Metrics artefacts", keys))
    return tuple(items)


# Figures ---------------------------------------------------------------------------------------


class _Numbers:
    """Consecutive figure and table numbers in page order."""

    def __init__(self) -> None:
        self.figure = 0
        self.table = 0

    def next_figure(self) -> int:
        self.figure += 1
        return self.figure

    def next_table(self) -> int:
        self.table += 1
        return self.table


@dataclass
class _Writer:
    out_dir: Path
    numbers: _Numbers = field(default_factory=_Numbers)

    @property
    def figures(self) -> Path:
        return self.out_dir / "figures"

    @property
    def tables(self) -> Path:
        return self.out_dir / "tables"

    def figure(self, figures: list[tuple[object, str]], title: str, caption: str) -> FigureBlock:
        pngs, links = [], []
        for figure, name in figures:
            png, pdf = fig.save_figure(figure, self.figures, name)
            pngs.append(png)
            links.append(f"figures/{pdf.name}")
        return FigureBlock(self.numbers.next_figure(), title, caption, tuple(pngs), tuple(links))

    def table(self, table: pd.DataFrame, name: str, title: str, caption: str,
              titles: pd.DataFrame | None = None, *, wrap: bool = False,
              files: tuple[pd.DataFrame, str] | None = None) -> TableBlock:
        """Write ``table`` (or ``files``: a table and caption for the files only) and return its block."""
        file_table, file_caption = files if files is not None else (table, caption)
        paths = write_table(file_table, self.tables, name, caption=f"{title} {file_caption}")
        for path in paths:
            if path.suffix == ".tex":
                path.write_text(latex_text(path.read_text(encoding="utf-8")), encoding="utf-8")
        return TableBlock(self.numbers.next_table(), title, caption, table.astype(str).replace("nan", "–"),
                          tuple(f"tables/{p.name}" for p in paths), titles, wrap=wrap)


def _rwg_section(writer: _Writer, data: StudyData, *, alpha: float) -> Section:
    subsampled = [t for t in data.tasks if data.returns[t].size > fig.MAX_EPISODE_DOTS]
    trios = fig.rwg_trios_figure(data.policies, returns=data.returns)
    dots = (
        f"For {', '.join(fig.task_label(t) for t in subsampled)} a fixed random subset of "
        f"{fig.MAX_EPISODE_DOTS:,} episode returns is drawn (of N·M) to keep the figure legible. "
        if subsampled else "Every episode return is drawn. "
    )
    blocks = [
        Paragraph("Each task was sampled with random-weight guessing: random policies drawn from the weight "
                  "prior, each run for M episodes. The figures show how the returns spread over policies; the "
                  "tables give the information-theoretic metrics of the paper with their uncertainty."),
        writer.figure(
            [(trios, "rwg_trios")], "Random-weight guessing statistics per task.",
            "One row per task. Left: histogram of the min–max scaled mean return Mₙ′ of every policy "
            "(log scale); a mass at 0 with a thin tail to 1 means good policies are rare. Middle: Mₙ "
            "against its rank Rₙ (black) with every episode return S[n, e] as a faint red dot at its "
            "policy's rank; the vertical spread of the dots is the within-policy noise that H(R|Θ) "
            "measures. " + dots
            + "Right: the standard deviation √Vₙ of each policy's returns against its mean.",
        ),
        writer.table(table1(data.metrics, digits=4).reset_index(), "table1_pic_poic",
                     "PIC and POIC of random policies.", "Bootstrap mean ± sd (nats), as Table 1 of the paper."),
        writer.table(interval_table(data.metrics), "bootstrap_intervals", "Bootstrap intervals.",
                     "Point estimate on the whole sample and percentile 95 % interval of the bootstrap (nats), "
                     "and the POIC temperature λ* (flagged when on a boundary of the search range)."),
    ]
    points = data.metrics[["task", "pic", "poic", "pic_ci_low", "pic_ci_high", "poic_ci_low", "poic_ci_high"]]
    blocks.append(writer.figure(
        [(fig.bootstrap_figure(data.bootstrap, points), "bootstrap")], "Bootstrap distributions of PIC and POIC.",
        "Violins: the bootstrap draws of each task (resampling policies); black diamond: the point estimate; "
        "black bar: the percentile 95 % interval. Overlapping violins are pairs the data cannot order. A point "
        "estimate outside its own violin is the histogram estimator's bias at work: a resample repeats "
        "policies, which removes distinct returns and lowers H(R).",
    ))
    for metric in ("pic", "poic"):
        matrix, tests = welch_display(data, metric, alpha=alpha)
        block = writer.table(
            matrix, f"welch_{metric}", f"Welch's t-tests of {metric.upper()}.",
            f"Statistic (two-sided p-value) of row minus column, on the estimates of "
            f"{len(next(iter(data.batches.values())))} consecutive policy batches; significant when p < {alpha:g}.",
            wrap=True,
        )
        tests.to_csv(writer.tables / f"welch_{metric}_tidy.csv", index=False)
        blocks.append(block)
    blocks.append(writer.figure(
        [(fig.score_scatter_figure(data.metrics), "score_scatter")], "Normalised score against every metric.",
        "Each point is a task (circle: dense, triangle: sparse). Panel titles give Pearson's r and its p-value "
        f"across the {len(data.tasks)} tasks; with so few points only strong correlations are meaningful.",
    ))
    blocks.append(writer.table(statistics_table(data.metrics), "rwg_statistics", "Random-policy statistics.",
                               "Worst policy mean r_min, best return r_max and mean return r_mean (sum of "
                               "rewards), normalised score score_R, the variance baseline, and the entropies "
                               "behind PIC and POIC (nats)."))
    return Section("Random policies: PIC, POIC and the random-weight guessing statistics", tuple(blocks))


def _sac_section(writer: _Writer, sac_curves: pd.DataFrame | None, per_seed: pd.DataFrame | None) -> Section:
    if sac_curves is None or per_seed is None or per_seed.empty:
        return Section("Empirical difficulty: SAC", (
            Paragraph("SAC curves were not computed for this report, so the known complexity order is checked "
                      "against the random-policy metrics only. Run the SAC stage and rebuild the report to add "
                      "the empirical order."),
        ))
    summary = sacs.sac_summary(per_seed)
    seeds = int(summary["seeds"].max())
    return Section("Empirical difficulty: SAC", (
        writer.figure(
            [(fig.sac_curves_figure(sac_curves), "sac_curves")], "SAC learning curves.",
            f"Mean evaluation return across seeds (up to {seeds}) against environment steps on a log axis; the "
            "band is the 95 % t-interval of the mean across seeds (absent with one seed). Solid: SAC; dashed: "
            "SAC + HER. Evaluations at step 0 are not drawn on the log axis. An easier task rises earlier "
            "and higher.",
        ),
        writer.table(
            sacs.format_sac_summary(summary), "sac_summary", "SAC summary.",
            "Mean ± sd across seeds of the final return (mean of the last 5 evaluations, sum of rewards), the "
            "same normalised to [worst random policy mean, best return seen], the area under the normalised "
            "curve (its mean over training) and the env steps to cover 90 % of the improvement from the first "
            "evaluation to the final return.",
        ),
    ))


def _diagnostics_section(writer: _Writer, data: StudyData, survival: pd.DataFrame) -> Section:
    if not data.diagnostics:
        return Section("Can the PIC estimate be trusted?", (
            Paragraph("The estimator diagnostics (permutation null, bins and subsample sweeps, Miller–Madow and "
                      "nearest-neighbour estimates) were not computed for this report."),
        ))
    tasks = [t for t in data.tasks if t in data.diagnostics]
    d = data.diagnostics
    blocks = [
        Paragraph("With continuous returns and many bins, almost every episode lands in its own bin, so the "
                  "histogram PIC approaches ln(occupied bins) − ln M whatever the policies do. The diagnostics "
                  "below measure how much of each task's PIC is this bias: the same estimator on returns "
                  "permuted across policies (true MI = 0), its dependence on B, N and M, and two other "
                  "estimators of the same mutual information."),
        writer.figure(
            [(fig.bins_sweep_figure({t: d[t]["bins_sweep"] for t in tasks},
                                    {t: d[t]["subsample_sweep"] for t in tasks}), "diagnostics_bins")],
            "PIC depends on the estimator's settings.",
            "Left: histogram PIC (solid) and its Miller–Madow correction (dotted) against the number of bins B. "
            "Middle and right: histogram PIC at the report's B on nested random subsets of policies and of "
            "episodes. A trustworthy estimate would be flat; a curve that keeps rising with B or N reflects "
            "bin occupancy rather than information.",
        ),
        writer.figure(
            [(fig.null_figure({t: d[t]["null"] for t in tasks}, {t: d[t]["null_summary"] for t in tasks}),
              "diagnostics_null")],
            "Observed PIC and POIC against their permutation null.",
            "Grey ticks: the estimator on returns shuffled across policies (true MI = 0); grey square and bar: "
            "their mean ± sd; coloured ring: the observed value. Only the distance between the ring and the null "
            "is evidence of information about the policy.",
        ),
        writer.table(diagnostics_display(data), "diagnostics_estimators", "Estimators of I(Θ; R).",
                     "Histogram PIC, its permutation null (mean ± sd), PIC minus the null (z-score in null "
                     "standard deviations); the Miller–Madow estimate and the k-nearest-neighbour estimate (on "
                     f"{knn_sample(data)} per task); POIC minus its null (z-score). All in nats."),
        writer.table(bins_display(data), "diagnostics_bins", "PIC against the number of bins.",
                     "Histogram PIC (Miller–Madow in parentheses), nats."),
    ]
    if not survival.empty:
        blocks.append(writer.table(
            survival_display(survival), "verdict_survival", "Does each verdict survive a change of estimator?",
            "Outcome of each known relation under the histogram PIC and three other estimators of the same "
            "mutual information (each tested with Welch's t-test on the same policy batches); 'yes' when all "
            "four agree.",
        ))
    return Section("Can the PIC estimate be trusted?", tuple(blocks))


def _ablation_section(writer: _Writer, ablation: Mapping) -> Section:
    groups = ablation if all(isinstance(v, Mapping) for v in ablation.values()) else {"": ablation}
    blocks = []
    for title, variants in groups.items():
        resolved = {name: (load_returns(v.rwg) if isinstance(v, TaskMetrics) else v) for name, v in variants.items()}
        blocks.append(writer.figure(
            [(fig.ablation_figure(resolved, title=fig.task_label(title) if title else ""),
              f"ablation_{_slug(title)}")],
            f"Ablation{': ' + fig.task_label(title) if title else ''}.",
            "The random-weight guessing trio of several samplers of the same task, overlaid: histogram of "
            "the scaled policy means (log scale), the mean return against the rank as a fraction of N, and "
            "√Vₙ against Mₙ. Variants: " + ", ".join(map(str, variants)) + ".",
        ))
    return Section("Ablation: the random-policy sampler", tuple(blocks))


# Markdown --------------------------------------------------------------------------------------


def render_markdown(document: Document) -> str:
    """``report.md``: the same text, figures linked (PNG) and tables inline."""
    lines = [f"# {document.title}", "", f"*{document.subtitle}*", "", "## The verdict", "",
             " ".join(document.headline), ""]

    def block(b) -> list[str]:
        if isinstance(b, Paragraph):
            return [b.text, ""]
        if isinstance(b, FigureBlock):
            images = [f"![Figure {b.number}]({p.parent.name}/{p.name})" for p in b.images]
            return [*images, "", f"**Figure {b.number}. {b.title}** {b.caption}", ""]
        return [f"**Table {b.number}. {b.title}** {b.caption}", "", b.table.to_markdown(index=False), ""]

    for b in document.headline_blocks:
        lines += block(b)
    lines += ["## Methods", ""] + [f"- **{k}**: {v}" for k, v in document.methods] + [""]
    for i, section in enumerate(document.sections, start=1):
        lines += [f"## {i}. {section.title}", ""]
        for b in section.blocks:
            lines += block(b)
    return "\n".join(lines)


def _remove_earlier_build(writer: _Writer) -> None:
    """Delete the figure and table files of an earlier build, so that no stale file sits beside the page."""
    for directory, suffixes in ((writer.figures, {".png", ".pdf"}), (writer.tables, {".md", ".tex", ".csv"})):
        if directory.is_dir():
            for path in directory.iterdir():
                if path.is_file() and path.suffix in suffixes:
                    path.unlink()


# The report ------------------------------------------------------------------------------------


def build_report(
    results: list[TaskMetrics],
    *,
    study,
    diagnostics: dict[str, Artefact] | None,
    sac_curves: pd.DataFrame | None,
    out_dir: Path,
    title: str,
    ablation: dict | None = None,
    alpha: float = SIGNIFICANCE_LEVEL,
) -> Path:
    """Write the study's report and return the path of its ``index.html``.

    Parameters
    ----------
    results : list of TaskMetrics
        Every task's RWG and metrics artefacts (:func:`~taskcomplexity.pipeline.study.study_metrics`).
    study : taskcomplexity.study.Study
        The study: its relations and orders are what the verdict judges.
    diagnostics : dict of task id to Artefact, optional
        Diagnostics artefacts (:mod:`~taskcomplexity.pipeline.diagnostics_stage`); None leaves the
        diagnostics section and the other estimators out of the verdict.
    sac_curves : pandas.DataFrame, optional
        Tidy SAC curves (``task``, ``variant``, ``seed``, ``env_step``, ``eval/return_mean``, …);
        None: the SAC section says the curves were not computed.
    out_dir : pathlib.Path
        Output directory (created); ``index.html``, ``report.md``, ``figures/``, ``tables/``. Figure
        and table files of an earlier build in ``figures/`` and ``tables/`` are replaced.
    title : str
        Page title.
    ablation : dict, optional
        Overlaid RWG trios: ``{label: returns (N, M) | policy table | TaskMetrics}`` for one figure,
        or ``{task or title: {label: …}}`` for one figure per entry.
    alpha : float, default 0.005
        Significance cut-off of every test.

    Returns
    -------
    pathlib.Path
        ``out_dir / "index.html"``.
    """
    if len(results) < 1:
        raise ValueError("results must hold at least one task's artefacts, got none")
    out_dir = Path(out_dir)
    writer = _Writer(out_dir)
    _remove_earlier_build(writer)
    data = load_study(results, diagnostics)

    per_seed = None
    if sac_curves is not None and not sac_curves.empty:
        bounds = {t: (float(r["r_min"]), float(r["r_max"])) for t, r in data.metrics.set_index("task").iterrows()}
        per_seed = sacs.seed_summary(sac_curves, rwg_bounds=bounds)
        writer.tables.mkdir(parents=True, exist_ok=True)
        per_seed.to_csv(writer.tables / "sac_per_seed.csv", index=False)

    verdict, summary, values = study_verdict(data, per_seed, study, alpha=alpha)
    survival = ver.survival_table(verdict)
    sentences = ver.headline(verdict, summary, alpha=alpha)
    matrix, tips = verdict_matrix(verdict, study.relations)
    words = matrix.replace({mark: outcome for outcome, mark in SYMBOLS.items()})
    headline_blocks = (
        writer.table(matrix, "verdict_matrix", "Verdict by known relation.",
                     "✓ the metric orders the pair as known and the difference is significant; ✗ it orders them "
                     "the other way, significantly; – not significant (or untested); ? undefined. Hover a cell "
                     "for the values and p-value; the full verdict table in the appendix lists them.", tips,
                     files=(words, "Outcome of every metric on every known relation (significant at "
                                   f"p < {alpha:g}, Welch's t-test); empty where the metric was not computed.")),
        writer.table(summary_display(summary), "verdict_summary", "Verdict per metric.",
                     "Counts of outcomes over the known relations, and Kendall's τ between the known order and "
                     "the metric's order within each reward type (+1: exactly as known, −1: reversed). Every "
                     "metric is read as higher = easier (the SAC metrics by definition; see the methods)."),
    )
    sections = [
        _rwg_section(writer, data, alpha=alpha),
        _sac_section(writer, sac_curves, per_seed),
        _diagnostics_section(writer, data, survival),
    ]
    if ablation:
        sections.append(_ablation_section(writer, ablation))
    full = writer.table(verdict_display(verdict), "verdict", "The full verdict.",
                        "Every (metric, known relation): the two values, the outcome and the p-value of "
                        "Welch's t-test, with the number of samples tested on each side (batches or seeds). Task "
                        "names: arm and link length, d = dense, s = sparse rewards.")
    values.to_csv(writer.tables / "verdict_values.csv", index=False)
    verdict.to_csv(writer.tables / "verdict_tidy.csv", index=False)
    sections.append(Section("Appendix: the full verdict table", (full,)))

    n = _joined(int(v) for v in data.metrics["policies"])
    m = _joined(int(v) for v in data.metrics["episodes"])
    subtitle = (f"{len(data.tasks)} tasks, N = {n} random policies × M = {m} episodes each; "
                f"generated {dt.datetime.now().strftime('%Y-%m-%d %H:%M')}")
    document = Document(title, subtitle, tuple(sentences), headline_blocks,
                        methods(data, sac_curves, alpha=alpha), tuple(sections))
    (out_dir / "report.md").write_text(render_markdown(document), encoding="utf-8")
    return write_html(document, out_dir / "index.html")
