"""A study's report as a reader sees it: the page in headless Chromium at 1400 px, every figure's axes in matplotlib.

The seven-task study at smoke size (N = 20 policies × M = 8 episodes, synthetic SAC curves, an ablation) is built
once, as in ``test_report_build.py``. Chromium opens the page with a script appended that writes, for every table,
whether its box needs a horizontal scrollbar (``scrollWidth > clientWidth``) into the DOM, which ``--dump-dom``
prints. The figures are read as the report saved them: every axis that labels its ticks shows at least 2 labels
inside its view limits, and no two of them overlap. Skipped only when no Chromium is installed (CI installs it:
``.ci/run``). About 20 s on the 2-core development machine, the study's stages most of it.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from contextlib import contextmanager

import pytest
from test_report_build import synthetic_curves

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report import writer
from taskcomplexity.report.build import build_report
from taskcomplexity.report.figures import paper_style
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest, load_returns
from taskcomplexity.study_data import load_study_file
from taskcomplexity.tasks.spec import task_from_id

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
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


@pytest.fixture(scope="module")
def report(tmp_path_factory, run_stages):
    """The page of the seven-task smoke study and the figures it saved."""
    root = tmp_path_factory.mktemp("screenshots")
    tasks = SEVEN_TASKS.ids
    requests = [RWGRequest(task_from_id(t), NetworkSpec(), PriorSpec(), RWGSettings(policies=20, episodes=8, seed=0))
                for t in tasks]
    found = run_stages(root, SEVEN_TASKS, requests, sac_curves=synthetic_curves(tasks))
    returns = load_returns(found["results"][0].rwg)
    ablation = {"1-link, L = 1.0 m, dense": {"normal prior": returns, "halved returns": returns / 2}}
    with saved_figures() as figures:
        index = build_report(found["results"], study=SEVEN_TASKS, verdict=found["verdict"],
                             diagnostics=found["diagnostics"], sac_curves=synthetic_curves(tasks),
                             out_dir=root / "report", title="Smoke study", ablation=ablation)
    return index, figures


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium to render the page (CI installs it: apt-get install chromium)")
def test_no_table_needs_a_horizontal_scrollbar_at_1400_px(report):
    index, _ = report
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


def test_every_axis_has_two_labelled_ticks_and_no_labels_overlap(report):
    _, figures = report
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
