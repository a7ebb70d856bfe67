"""Figures with nothing to show are not drawn: one line stands where they would be, saying what is left out and
why; a figure some of whose panels are empty drops those panels and names them in its caption."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.report import figures as fig
from taskcomplexity.report import sections
from taskcomplexity.report.beyond import learning_path_block
from taskcomplexity.report.html import FigureBlock, Paragraph
from taskcomplexity.report.labels import task_styles
from taskcomplexity.report.writer import Writer
from taskcomplexity.study_data import load_study_file, study_from_config

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")
SCORE = ("score", "normalised score score_R")
NAMED = "the normalised score score_R"
PANELS = [("pic", "PIC (nats)"), ("h_o", "H(O) (nats)"), ("variance", "variance")]


def study(count: int):
    return study_from_config({"name": "small", "tasks": [{"id": f"t{i}", "task": "pendulum"} for i in range(count)]})


def metrics(**columns) -> pd.DataFrame:
    count = len(next(iter(columns.values())))
    return pd.DataFrame({"task": [f"t{i}" for i in range(count)], **columns})


def scatter(tmp_path, table: pd.DataFrame):
    writer = Writer(tmp_path)
    block = sections.scatter_block(
        writer, table, task_styles(study(len(table))), y=SCORE, named=NAMED, panels=PANELS, file="score_scatter",
        title="Normalised score against every metric.", what=f"the figure of {NAMED} against every metric",
        caption="Panel titles give Pearson's r", after=".")
    return block, writer


def titles(figure) -> list[str]:
    return [ax.get_title() for ax in figure.axes if ax.get_title()]


def test_two_tasks_leave_the_score_scatter_out_with_the_reason_and_no_file(tmp_path):
    block, writer = scatter(tmp_path, metrics(score=[0.1, 0.2], pic=[1.0, 2.0], h_o=[0.1, 0.3], variance=[2.0, 1.0]))
    assert block == Paragraph("The figure of the normalised score score_R against every metric is left out: this "
                              "report compares 2 tasks, and a correlation needs at least 3.")
    assert writer.counts["figure"] == 0  # takes no number: the next figure drawn is still the next in order
    assert not (tmp_path / "figures").exists()
    with pytest.raises(ValueError, match="nothing to show"):
        fig.score_scatter_figure(metrics(score=[0.1, 0.2], pic=[1.0, 2.0]), task_styles(study(2)), y=SCORE,
                                 panels=PANELS[:1])


def test_a_score_without_enough_finite_values_or_without_spread_leaves_the_scatter_out(tmp_path):
    three = {"pic": [1.0, 2.0, 3.0], "h_o": [0.1, 0.3, 0.2], "variance": [2.0, 1.0, 5.0]}
    block, _ = scatter(tmp_path, metrics(score=[0.1, np.nan, 0.3], **three))  # e.g. a task whose returns are constant
    assert block.text.endswith("is left out: the normalised score score_R is finite on 2 of the 3 tasks, and a "
                               "correlation needs at least 3.")
    block, _ = scatter(tmp_path, metrics(score=[0.2, 0.2, 0.2], **three))
    assert block.text.endswith("is left out: the normalised score score_R is the same on every task, so there is "
                               "nothing to correlate.")
    block, _ = scatter(tmp_path, metrics(score=[0.1, 0.2, 0.3], pic=[1.0, 1.0, 1.0], h_o=[0.1, np.nan, 0.2],
                                         variance=[np.nan] * 3))
    assert block.text.endswith("is left out: no metric has a correlation with the normalised score score_R: PIC "
                               "(nats) (the same on every task); H(O) (nats) (finite together with the normalised "
                               "score score_R on 2 of the 3 tasks; a correlation needs 3); variance (finite together "
                               "with the normalised score score_R on none of the 3 tasks).")


def test_only_the_panels_without_a_correlation_are_dropped_and_the_caption_names_them(tmp_path):
    table = metrics(score=[0.1, 0.2, 0.3, 0.5], pic=[1.0, 2.5, 2.0, 4.0], h_o=[0.2, 0.2, 0.2, 0.2],
                    variance=[2.0, np.nan, 1.0, 7.0])
    block, writer = scatter(tmp_path, table)
    assert isinstance(block, FigureBlock) and block.number == 1
    assert block.caption == (
        "Panel titles give Pearson's r across 4 tasks (a title ending in (n = k): across only the k tasks where "
        "both values are finite). Left out, with nothing to show: the panel of H(O) (nats) (the same on every task).")
    assert (tmp_path / "figures" / "score_scatter.png").is_file()
    figure = fig.score_scatter_figure(table, task_styles(study(4)), y=SCORE, panels=PANELS)
    shown = titles(figure)
    assert [ax.get_xlabel() for ax in figure.axes if ax.get_title()] == ["PIC (nats)", "variance"]
    (r, p), (r3, p3) = (fig.pearson(table[c].to_numpy(), table["score"].to_numpy()) for c in ("pic", "variance"))
    assert np.isfinite([r, p, r3, p3]).all()
    assert shown == [f"r = {r:.2f}, p = {p:.2g}", f"r = {r3:.2f}, p = {p3:.2g} (n = 3)"]
    assert not any("n/a" in t for t in shown)


def curves(tasks, steps=(0, 1000, 2000), value=1.0) -> pd.DataFrame:
    return pd.DataFrame([{"task": t, "variant": "sac", "seed": seed, "env_step": step, "eval/return_mean": value}
                         for t in tasks for seed in (0, 1) for step in steps])


def sac_data(tasks) -> SimpleNamespace:
    styles = task_styles(SEVEN_TASKS)
    per_seed = pd.DataFrame({"task": tasks, "variant": "sac", "seed": 0})
    return SimpleNamespace(styles=styles, tasks=list(styles), sac_per_seed=per_seed)


def test_a_study_group_without_sac_curves_gets_no_panel_and_the_caption_says_why(tmp_path):
    dense = [t for t, s in task_styles(SEVEN_TASKS).items() if s.group == "dense"]
    block = sections.sac_curves_block(Writer(tmp_path), sac_data(dense), curves(dense))
    assert block.caption.endswith("Left out, with nothing to show: the panel of the sparse group (no SAC run of its "
                                  "tasks is in the curves).")
    figure = fig.sac_curves_figure(curves(dense), task_styles(SEVEN_TASKS))
    assert titles(figure) == ["dense"]
    assert not any(text.get_text() for ax in figure.axes for text in ax.texts)  # no "no SAC runs" panel


def test_sac_curves_with_nothing_after_step_0_are_left_out_with_the_reason(tmp_path):
    tasks = list(SEVEN_TASKS.ids)
    writer = Writer(tmp_path)
    block = sections.sac_curves_block(writer, sac_data(tasks), curves(tasks, steps=(0,)))
    assert block == Paragraph("The figure of the SAC learning curves is left out: every SAC evaluation of the "
                              "study's tasks with a finite return is at step 0, which the log axis of environment "
                              "steps cannot show.")
    block = sections.sac_curves_block(writer, sac_data(tasks), curves(tasks, value=np.nan))
    assert block.text.endswith("is left out: no SAC evaluation of the study's tasks has a finite return.")
    assert writer.counts["figure"] == 0


def null_data(knn_observed: float, knn_draws: float) -> SimpleNamespace:
    styles = task_styles(study(2))
    summary = pd.DataFrame({"metric": ["pic", "pic_knn"], "observed": [1.0, knn_observed], "null_mean": [0.9, 0.0],
                            "null_sd": [0.1, 0.0]})
    null = pd.DataFrame({"pic": [0.8, 0.9, 1.0], "pic_knn": [knn_draws] * 3})
    return SimpleNamespace(styles=styles, tasks=list(styles), registry=DEFAULT_REGISTRY,
                           diagnostics={t: {"null": null, "null_summary": summary} for t in styles})


def test_an_estimator_without_a_finite_value_gets_no_null_panel(tmp_path):
    data = null_data(np.nan, np.nan)
    block = sections.null_block(Writer(tmp_path), data, data.tasks)
    assert block.caption.endswith("Left out, with nothing to show: the panel of PIC (k-NN) (no task has a finite "
                                  "observed value or null draw).")
    figure = fig.null_figure({t: data.diagnostics[t]["null"] for t in data.tasks},
                             {t: data.diagnostics[t]["null_summary"] for t in data.tasks}, data.styles)
    assert [ax.get_xlabel() for ax in figure.axes if ax.get_visible()] == ["pic (nats)"]
    kept = null_data(0.4, 0.0)  # a finite null of zero is something to show
    assert fig.null_estimators({t: kept.diagnostics[t]["null"] for t in kept.tasks},
                               {t: kept.diagnostics[t]["null_summary"] for t in kept.tasks}) == {"pic": True,
                                                                                                  "pic_knn": True}


def test_bootstrap_and_learning_path_panels_without_a_finite_value_are_dropped(tmp_path):
    styles = task_styles(study(2))
    bootstrapped = [DEFAULT_REGISTRY["pic"], DEFAULT_REGISTRY["poic"]]  # the two panels the block is given
    draws = {t: pd.DataFrame({"pic": [1.0, 1.2], "poic": [np.nan, np.nan]}) for t in styles}
    points = pd.DataFrame({"task": list(styles), "pic": 1.1, "pic_ci_low": 1.0, "pic_ci_high": 1.2})
    data = SimpleNamespace(bootstrap=draws, metrics=points, styles=styles)
    block = sections.bootstrap_block(Writer(tmp_path), data, bootstrapped)
    assert block.title == "Bootstrap distributions of PIC."
    assert block.caption.endswith("Left out, with nothing to show: the panel of POIC (no task has a finite bootstrap "
                                  "draw).")
    nothing = SimpleNamespace(bootstrap={t: d.assign(pic=np.nan) for t, d in draws.items()}, metrics=points,
                              styles=styles)
    assert sections.bootstrap_block(Writer(tmp_path), nothing, bootstrapped) == Paragraph(
        "The figure of the bootstrap distributions of PIC, POIC is left out: no task has a finite bootstrap draw of "
        "PIC and POIC.")

    path = pd.DataFrame({"step": [0, 100, 200], "pic": [1.0, 1.1, 1.3], "poic": [np.nan] * 3})
    data = SimpleNamespace(tasks=list(styles), styles=styles)
    block = learning_path_block(Writer(tmp_path), data, {"t0": path})
    assert block.title == "PIC along SAC's learning path."
    assert block.caption.endswith("Left out, with nothing to show: the panel of POIC (no task's learning path has a "
                                  "finite value).")
    assert learning_path_block(Writer(tmp_path), data, {"t0": path.assign(pic=np.nan)}).text == (
        "The figure of PIC and POIC along SAC's learning path is left out: no task's learning path has a finite "
        "value of PIC and POIC.")
