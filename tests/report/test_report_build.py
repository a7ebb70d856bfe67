"""End to end: a smoke-size study of the seven tasks through the real stages into a complete report.

One module-scoped study (N = 20 policies × M = 8 episodes per task) is built with the real RWG, metrics,
diagnostics and verdict stages, plus synthetic SAC curves; the tests read what ``build_report`` wrote and
compare it with the artefacts.

The report as a reader sees it, from the same build: the page in headless Chromium at 1400 px, every figure's axes
in matplotlib. Chromium opens the page with a script appended that writes, for every table, whether its box needs
a horizontal scrollbar (``scrollWidth > clientWidth``) into the DOM, which ``--dump-dom`` prints. The figures are
read as the report saved them: every axis that labels its ticks shows at least 2 labelled ticks inside its view
limits, and no two of them overlap. The page's test is skipped only when no Chromium is installed (CI installs it:
``.ci/run``).
"""

from __future__ import annotations

import base64
import re
import shutil
import subprocess
from contextlib import contextmanager
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report import writer
from taskcomplexity.report.build import build_report
from taskcomplexity.report.figures import paper_style
from taskcomplexity.report.format import mean_sd
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest, load_returns
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.spec import task_from_id
from taskcomplexity.verdict import OUTCOMES

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
RELATIONS, TASKS = SEVEN_TASKS.relations, SEVEN_TASKS.ids

FIGURES = ("rwg_trios", "bootstrap", "score_scatter", "sac_curves", "diagnostics_bins", "diagnostics_null",
           "ablation_1_link_l_1_0_m_dense")
TABLES = ("verdict_headline", "table1", "bootstrap_intervals", "welch_pic", "welch_poic", "rwg_statistics", "sac_summary",
          "verdict_summary", "diagnostics_estimators", "diagnostics_bins", "verdict_survival", "verdict_matrix",
          "verdict")

CHROMIUM = next((path for name in ("chromium", "chromium-browser", "google-chrome") if (path := shutil.which(name))),
                None)
WIDTH = 1400
"""The window width the report is read at, in CSS pixels."""

MEASURE = """<script>
window.addEventListener("load", () => {
  const rows = [...document.querySelectorAll("div.table")].map(block => {
    const box = block.querySelector(".scroll");
    return `${block.id} ${box.scrollWidth} ${box.clientWidth}`;
  });
  const out = document.createElement("pre");
  out.id = "measured";
  out.textContent = rows.join("\\n");
  document.body.append(out);
});
</script>"""


@contextmanager
def saved_figures():
    """Every figure the report saves, by file name, as it was saved."""
    saved = {}
    save_figure = writer.save_figure

    def save(figure, directory, name):
        paths = save_figure(figure, directory, name)
        saved[name] = figure
        return paths

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(writer, "save_figure", save)
        yield saved


def synthetic_curves(tasks, seeds=(0, 1, 2)) -> pd.DataFrame:
    """Plausible SAC curves: exponential approach to a plateau, slower for harder tasks, HER on sparse tasks."""
    rng = np.random.default_rng(0)
    rows = []
    for rank, task in enumerate(tasks):
        sparse = task.endswith("sparse")
        for variant in ("sac", "sac+her") if sparse else ("sac",):
            for seed in seeds:
                for step in range(0, 20_001, 1000):
                    learned = 1 - np.exp(-step / (2000.0 * (rank + 1)))
                    value = (-50 + 45 * learned if sparse else -30 + 28 * learned) + rng.normal(0, 0.5)
                    rows.append({"task": task, "variant": variant, "seed": seed, "env_step": step,
                                 "eval/return_mean": value, "eval/return_std": 1.0, "eval/success_rate": learned,
                                 "train/episode_return": value - 1, "time/seconds": step / 1000})
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def study(tmp_path_factory, run_stages):
    root = tmp_path_factory.mktemp("study")
    requests = [RWGRequest(task_from_id(t), NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=8, seed=0))
                for t in TASKS]
    return root, run_stages(root, SEVEN_TASKS, requests, sac_curves=synthetic_curves(TASKS))


@pytest.fixture(scope="module")
def built(study):
    """The report's page and the figures it saved, by file name."""
    root, found = study
    returns = load_returns(found["results"][0].rwg)
    ablation = {"1-link, L = 1.0 m, dense": {"normal prior": returns, "halved returns": returns / 2}}
    with saved_figures() as figures:
        index = build_report(found["results"], study=SEVEN_TASKS, verdict=found["verdict"],
                             diagnostics=found["diagnostics"], sac_curves=synthetic_curves(TASKS),
                             out_dir=root / "report", title="Smoke study", ablation=ablation)
    return index, figures


@pytest.fixture(scope="module")
def report(built):
    return built[0]


class PageParser(HTMLParser):
    """Collects every URL-bearing attribute, the tags used, and the text."""

    def __init__(self):
        super().__init__()
        self.urls: list[tuple[str, str, str]] = []
        self.tags: set[str] = set()
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.add(tag)
        for name, value in attrs:
            if name in ("src", "href", "data", "poster", "srcset", "action"):
                self.urls.append((tag, name, value or ""))

    def handle_data(self, data):
        self.text.append(data)


def parse(index: Path) -> PageParser:
    parser = PageParser()
    parser.feed(index.read_text(encoding="utf-8"))
    return parser


def test_every_figure_is_written_as_png_and_pdf(report):
    for name in FIGURES:
        for suffix in (".png", ".pdf"):
            path = report.parent / "figures" / f"{name}{suffix}"
            assert path.is_file() and path.stat().st_size > 1000, path


def test_every_table_is_written_as_markdown_latex_and_csv(report):
    for name in TABLES:
        for suffix in (".md", ".tex", ".csv"):
            path = report.parent / "tables" / f"{name}{suffix}"
            assert path.is_file() and path.stat().st_size > 0, path
    assert (report.parent / "report.md").stat().st_size > 0


def test_latex_tables_compile_with_pdflatex_defaults(report):
    # pdflatex with utf8 input knows the en dash; every other symbol must have become a LaTeX command.
    for path in (report.parent / "tables").glob("*.tex"):
        text = path.read_text(encoding="utf-8")
        assert set(text) - set(map(chr, range(128))) <= {"–"}, path.name
        assert "<" not in text.replace("$<$", "") and "|" not in text.replace("$|$", ""), path.name


def test_the_page_embeds_its_images_and_links_only_to_files_that_exist(report):
    page = parse(report)
    assert not page.tags & {"script", "link", "iframe", "object", "embed"}
    images = [value for tag, name, value in page.urls if tag == "img"]
    assert len(images) == len(FIGURES)
    for value in images:
        assert value.startswith("data:image/png;base64,")
        assert base64.b64decode(value.split(",", 1)[1])[:4] == b"\x89PNG"
    links = [value for tag, name, value in page.urls if tag != "img"]
    assert links
    for value in links:
        assert "://" not in value and not value.startswith("/")
        assert (report.parent / value).is_file(), value
    assert "url(" not in report.read_text(encoding="utf-8")  # no external fonts or images in the style sheet


def test_the_page_opens_with_the_verdict_then_the_methods(report):
    html = report.read_text(encoding="utf-8")
    assert html.index('class="verdict"') < html.index('class="methods"') < html.index("<h2>1.")
    text = " ".join(parse(report).text)
    assert f"Against the {len(RELATIONS)} known complexity relations, PIC " in text
    assert "SAC curves were not computed" not in text


def test_the_methods_say_where_the_returns_were_computed(report, study):
    # Computed by the fixture's process (no scheduler): one process, every task, and the CPU its records hold.
    import socket

    text = " ".join(parse(report).text)
    records = [r for result in study[1]["results"] for r in result.rwg.manifest["jobs"]]
    [(scheduler, job, node)] = {(r["scheduler"], r["job"], r["node"]) for r in records}
    assert scheduler == "local" and job.startswith("pid ") and node == socket.gethostname()
    cpu = sum(r["cpu_seconds"] for r in records)
    assert (f"Where the RWG ran 1 process ({job}) on {node} (every task); {cpu:,.1f} CPU-s of RWG in all, as the "
            "jobs recorded it") in text


def test_at_smoke_size_the_headline_opens_with_what_pic_measures(report, study):
    # N = 20, M = 8 at B = 1000: nearly every return has its own bin, so PIC is what shuffled returns give.
    verdict = pd.read_parquet(study[1]["verdict"].file("verdict.parquet"))
    assert (verdict.loc[verdict["metric"] == "pic", "outcome"] == "uninformative").all()
    headline = (report.parent / "report.md").read_text(encoding="utf-8").split("## The verdict", 1)[1].strip()
    assert headline.startswith("PIC equals its permutation null on all 7 tasks")
    assert "measures the estimator, not the tasks" in headline.split(". ")[0]
    assert "PIC is uninformative on every one" in headline


def test_figures_and_tables_are_numbered_in_page_order(report):
    text = " ".join(parse(report).text)
    for kind, count in (("Figure", len(FIGURES)), ("Table", len(TABLES))):
        numbers = [int(n) for n in pd.Series(text).str.findall(rf"{kind} (\d+)\.").iloc[0]]
        assert numbers == list(range(1, count + 1)), kind


def test_the_verdict_has_a_row_for_every_relation_and_metric(report, study):
    verdict = pd.read_parquet(study[1]["verdict"].file("verdict.parquet"))
    judged = [m for m in DEFAULT_REGISTRY if m.stage in ("metrics", "diagnostics", "sac")]  # synthetic curves: no actor
    assert len(verdict) == len(judged) * len(RELATIONS)
    assert list(dict.fromkeys(verdict["metric"])) == [m.name for m in judged]
    shown = pd.read_csv(report.parent / "tables" / "verdict.csv")
    for metric in judged:
        rows = shown[shown["Metric"] == metric.label]
        assert len(rows) == len(RELATIONS), metric.name
        assert len(set(zip(rows["Easier task"], rows["Harder task"], strict=True))) == len(RELATIONS), metric.name
    # SAC + HER ran on the sparse tasks only: it judges the relations between two sparse tasks, the rest are
    # undefined (no value for a dense task).
    her = verdict[verdict["metric"] == "sac_her_final"]
    sparse = [r for r in RELATIONS if r.easier.endswith("sparse") and r.harder.endswith("sparse")]
    assert (her["outcome"] != "undefined").sum() == len(sparse)
    assert set(verdict["outcome"]) <= set(OUTCOMES)


def test_the_report_shows_the_numbers_of_the_artefacts(report, study, table1_metric_columns):
    found = study[1]
    table1 = pd.read_csv(report.parent / "tables" / "table1.csv")
    assert table1_metric_columns[:4] == ["PIC", "PIC null share", "POIC", "POIC null share"]
    assert list(table1.columns) == ["Group", "Task", *table1_metric_columns]
    assert table1["Task"].tolist()[:2] == ["1-link, L = 1.0 m", "1-link, L = 1.65 m"]
    assert table1["Group"].tolist() == ["dense"] * 4 + ["sparse"] * 3
    checked = pd.read_parquet(found["verdict"].file("information.parquet")).set_index(["metric", "task"])
    for row, result in zip(table1.itertuples(index=False), found["results"], strict=True):
        metrics = result.table("metrics.parquet").iloc[0]
        assert row.PIC == mean_sd(metrics["pic_mean"], metrics["pic_sd"])
        assert row.POIC == mean_sd(metrics["poic_mean"], metrics["poic_sd"])
        # the null's share of the value: its null mean over the whole-sample value, from the diagnostics
        null = pd.read_parquet(found["diagnostics"][result.task_id].file("null.parquet"))
        share = null["pic"].mean() / metrics["pic"]
        assert checked.loc[("pic", result.task_id), "null_share"] == pytest.approx(share)
        assert row[3] == f"{100 * share:.1f} %"
    tidy = pd.read_csv(report.parent / "tables" / "verdict_tidy.csv", float_precision="round_trip")
    artefact = pd.read_parquet(found["verdict"].file("verdict.parquet"))
    assert tidy["outcome"].tolist() == artefact["outcome"].tolist()
    np.testing.assert_array_equal(tidy["value_easier"].to_numpy(), artefact["value_easier"].to_numpy())
    welch = pd.read_csv(report.parent / "tables" / "welch_pic_tidy.csv", float_precision="round_trip")
    stored = pd.read_parquet(found["verdict"].file("welch.parquet"))
    np.testing.assert_array_equal(welch["pvalue"].to_numpy(), stored.loc[stored["metric"] == "pic", "pvalue"].to_numpy())
    summary = pd.read_csv(report.parent / "tables" / "verdict_summary.csv").set_index("Metric")
    counts = pd.read_parquet(found["verdict"].file("summary.parquet")).set_index("metric")
    assert summary.loc["PIC", "Agree"] == counts.loc["pic", "agreements"]
    assert summary.loc["SAC+HER final", "Undefined"] == counts.loc["sac_her_final", "undefined"] == 7


def test_relations_and_kinds_are_named_as_the_study_writes_them(report):
    matrix = pd.read_csv(report.parent / "tables" / "verdict_matrix.csv")
    assert matrix.iloc[0, 0] == "1-link, L = 1.0 m, dense < 1-link, L = 1.65 m, dense"
    assert set(matrix["Kind"]) == {"link length", "degrees of freedom", "reward", "obstacle"}
    text = " ".join(parse(report).text)
    assert "one_link" not in text.replace("one_link_1m0", "")  # no raw ids on the page, except artefact keys


def test_the_markdown_report_links_existing_figures(report):
    text = (report.parent / "report.md").read_text(encoding="utf-8")
    linked = [line.split("](", 1)[1].rstrip(")") for line in text.splitlines() if line.startswith("![")]
    assert len(linked) == len(FIGURES)
    assert all((report.parent / path).is_file() for path in linked)


def test_without_sac_curves_or_diagnostics_the_page_says_so(study, run_stages, tmp_path):
    _, found = study
    requests = [r.request for r in found["results"][:2]]
    two = run_stages(tmp_path, SEVEN_TASKS, requests, diagnostics=False)
    index = build_report(two["results"], study=SEVEN_TASKS, verdict=two["verdict"], diagnostics=None, sac_curves=None,
                         out_dir=tmp_path / "report", title="Two tasks")
    text = " ".join(parse(index).text)
    assert "SAC curves were not computed" in text
    assert "diagnostics" in text and "were not computed for this report" in text
    assert not (tmp_path / "report" / "figures" / "sac_curves.png").exists()
    verdict = pd.read_csv(tmp_path / "report" / "tables" / "verdict.csv")
    assert set(verdict["Metric"]) == {m.label for m in DEFAULT_REGISTRY.of_stage("metrics")}
    assert len(verdict) == len(DEFAULT_REGISTRY.of_stage("metrics"))  # one relation between the two tasks


def test_the_headline_matrix_shows_the_primary_metrics_each_familys_best_and_the_worst_metric(report, study):
    verdict = pd.read_parquet(study[1]["verdict"].file("verdict.parquet"))
    headline = pd.read_csv(report.parent / "tables" / "verdict_headline.csv")
    expected = {m.name for m in DEFAULT_REGISTRY if m.primary}
    best, worst = {}, None  # family -> (net, agreements, -position, name); (contradictions, -net, -position, name)
    for position, metric in enumerate(DEFAULT_REGISTRY):
        own = verdict[verdict["metric"] == metric.name]
        if own.empty or (own["outcome"] == "undefined").all() or not metric.comparable_across_tasks:
            continue  # as the headline: a raw return in task units is never ranked
        agree, contradict = (own["outcome"] == "agree").sum(), (own["outcome"] == "contradict").sum()
        if not metric.primary and agree:  # a family's best agrees at least once
            best[metric.family] = max(best.get(metric.family, (-99, 0, 0, "")),
                                      (agree - contradict, agree, -position, metric.name))
        if contradict:
            worst = max(worst or (0, 0, 0, ""), (contradict, contradict - agree, -position, metric.name))
    expected |= {b[-1] for b in best.values()} | ({worst[-1]} if worst else set())
    assert "beyond the paper" not in best  # no actor, no primitives: no "beyond" family
    expected = [m.short for m in DEFAULT_REGISTRY if m.name in expected]
    assert 2 <= len(expected) <= 7
    assert list(headline.columns) == ["Known relation (easier < harder)", "Kind", *expected]
    assert len(headline) == len(RELATIONS)
    # the appendix keeps every metric
    full = pd.read_csv(report.parent / "tables" / "verdict_matrix.csv")
    assert len(full.columns) == 2 + verdict["metric"].nunique() > len(headline.columns)
    html = report.read_text(encoding="utf-8")
    box = html[html.index('class="verdict"'):html.index('class="methods"')]
    first = box[box.index("<table"):box.index("</table>")]
    assert first.count("<th ") == len(headline.columns)  # the box's matrix is the narrow one…
    assert "verdict_matrix.csv" not in box and "verdict_headline.csv" in box  # …and the full one is elsewhere
    assert html.index("verdict_matrix.csv") > html.index("Appendix")


def test_a_metric_whose_label_does_not_say_what_it_is_is_defined_in_the_verdict_box(report):
    import html as html_lib

    page = html_lib.unescape(report.read_text(encoding="utf-8"))
    verdict, methods = page.index('<section class="verdict">'), page.index('<aside class="methods">')
    defined = [m for m in DEFAULT_REGISTRY if m.definition and re.search(rf"\b{re.escape(m.label)}\b", page)]
    assert {"variance", "r_mean", "score"} <= {m.name for m in defined}
    for metric in defined:
        definition = page.index(f"{metric.label} = {metric.definition}")
        assert verdict < definition < methods, metric.name  # in the verdict box, before the page shows its values
        assert not re.search(rf"\b{re.escape(metric.label)}\b", page[:verdict]), metric.name
        assert page.count(f"{metric.label} = {metric.definition}") == 1, metric.name  # defined once


# As a reader sees it ------------------------------------------------------------------------------------------


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium to render the page (CI installs it: apt-get install chromium)")
def test_no_table_needs_a_horizontal_scrollbar_at_1400_px(report):
    index = report
    probe = index.with_name("probe.html")
    probe.write_text(index.read_text(encoding="utf-8").replace("</body>", MEASURE + "</body>"), encoding="utf-8")
    dom = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", f"--window-size={WIDTH},2000",
                          "--dump-dom", probe.as_uri()], capture_output=True, text=True, timeout=120)
    measured = re.search(r'<pre id="measured">(.*?)</pre>', dom.stdout, re.S)
    assert measured, f"Chromium printed no measurement: {dom.stderr[-2000:]}"
    widths = {table: (int(scroll), int(client)) for table, scroll, client in
              (line.split() for line in measured.group(1).splitlines())}
    assert len(widths) >= 10, widths  # every table of the page was measured
    clipped = {table: w for table, w in widths.items() if w[0] > w[1]}
    assert not clipped, f"tables wider than their box at {WIDTH} px (scrollWidth, clientWidth): {clipped}"


def shows_labels(axis) -> bool:
    """An axis meant to label its ticks: not switched off, nor a shared axis whose labels its neighbour shows."""
    sides = ("labelbottom", "labeltop") if axis.axis_name == "x" else ("labelleft", "labelright")
    parameters = axis.get_tick_params(which="major")
    return axis.axes.axison and axis.get_visible() and any(parameters.get(side, False) for side in sides)


def labels_in_view(axis) -> list:
    """The labelled ticks of ``axis`` within its view limits, as last drawn."""
    low, high = sorted(axis.get_view_interval())
    slack = 1e-9 * (high - low)
    at = 0 if axis.axis_name == "x" else 1
    return [label for label in axis.get_ticklabels(which="both")
            if label.get_visible() and label.get_text().strip() and low - slack <= label.get_position()[at] <= high + slack]


def test_every_axis_has_two_labelled_ticks_and_no_labels_overlap(built):
    _, figures = built
    assert len(figures) >= 7
    problems = []
    with paper_style():
        for name, figure in figures.items():
            figure.draw_without_rendering()
            for number, ax in enumerate(figure.axes):
                for axis in (ax.xaxis, ax.yaxis):
                    if not shows_labels(axis):
                        continue
                    labels = labels_in_view(axis)
                    where = f"{name}, axes {number} ({ax.get_title() or ax.get_title(loc='left')!r}), {axis.axis_name}"
                    texts = [label.get_text() for label in labels]
                    if len(labels) < 2:
                        problems.append(f"{where}: labels {texts}")
                    boxes = sorted((label.get_window_extent() for label in labels),
                                   key=lambda box: box.x0 if axis.axis_name == "x" else box.y0)
                    # consecutive labels along the axis: the next one starts after this one ends (no tolerance)
                    ends = [(a.x1, b.x0) if axis.axis_name == "x" else (a.y1, b.y0) for a, b in zip(boxes, boxes[1:], strict=False)]
                    if any(end > start for end, start in ends):
                        problems.append(f"{where}: overlapping labels {texts}")
    assert not problems, "\n".join(problems)
