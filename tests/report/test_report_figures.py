"""Figures: episode dots at their policy's rank, bands, files on disk, study styles in every panel."""

from __future__ import annotations

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import policy_statistics
from taskcomplexity.report import figures as fig
from taskcomplexity.report.labels import task_styles
from taskcomplexity.study_data import load_study_file, study_from_config

SEVEN_TASKS = load_study_file(CONF_DIR / "study" / "seven_tasks.yaml")


def test_episode_dots_sit_at_their_policys_rank_not_its_sampling_index():
    returns = np.array([[5.0, 7.0], [1.0, 3.0], [9.0, 11.0]])  # means 6, 2, 10 → ranks 2, 1, 3
    ranks = policy_statistics(returns)["rank"].to_numpy()
    x, y = fig.episode_dots(returns, ranks)
    assert x.tolist() == [2, 2, 1, 1, 3, 3]
    assert y.tolist() == [5.0, 7.0, 1.0, 3.0, 9.0, 11.0]


def test_many_episode_dots_are_subsampled_the_same_way_every_time():
    returns = np.random.default_rng(0).normal(size=(300, 50))
    ranks = policy_statistics(returns)["rank"].to_numpy()
    first = fig.episode_dots(returns, ranks, max_dots=1000)
    second = fig.episode_dots(returns, ranks, max_dots=1000)
    assert first[0].size == 1000
    np.testing.assert_array_equal(first[1], second[1])
    assert set(first[1]) <= set(returns.ravel())


def test_pearson_is_undefined_for_a_constant_side_or_fewer_than_three_points():
    assert np.isnan(fig.pearson(np.array([1.0, 2.0, 3.0]), np.array([4.0, 4.0, 4.0]))[0])
    assert np.isnan(fig.pearson(np.array([1.0, 2.0]), np.array([1.0, 2.0]))[0])
    r, p = fig.pearson(np.array([1.0, 2.0, 3.0, 4.0]), np.array([2.0, 4.0, 6.0, 8.5]))
    assert r == pytest.approx(1.0, abs=0.01) and p < 0.05


def test_the_seed_band_is_the_95_percent_t_interval_of_the_mean():
    values = pd.DataFrame({"env_step": [1, 1, 1, 2], "seed": [0, 1, 2, 0], "r": [1.0, 2.0, 3.0, 5.0]})
    band = fig.seed_band(values, "r").set_index("env_step")
    half = 4.302652729911275 * 1.0 / np.sqrt(3)  # t(0.975, 2 dof) · sd / √n
    assert band.loc[1, "low"] == pytest.approx(2.0 - half) and band.loc[1, "high"] == pytest.approx(2.0 + half)
    assert np.isnan(band.loc[2, "low"])  # one seed: no band


def test_figures_are_saved_as_png_and_pdf_without_touching_global_state(tmp_path):
    before = dict(mpl.rcParams)
    returns = np.random.default_rng(1).normal(size=(40, 6))
    figure = fig.rwg_trio_figure("2-link, dense", policy_statistics(returns), returns=returns)
    paths = fig.save_figure(figure, tmp_path, "trio")
    assert [p.name for p in paths] == ["trio.png", "trio.pdf"]
    assert paths[0].read_bytes()[:4] == b"\x89PNG" and paths[1].read_bytes()[:4] == b"%PDF"
    assert dict(mpl.rcParams) == before
    labels = [ax.get_ylabel() for ax in figure.axes]
    assert labels == ["policies (log scale)", "return (sum of rewards)", "sd √Vₙ (sum of rewards)"]


@pytest.mark.parametrize("automatic", ["figure.autolayout", "figure.constrained_layout.use"])
def test_both_files_are_written_at_the_last_layout_whatever_the_rc_says(tmp_path, monkeypatch, automatic):
    # save_figure writes each file with no layout engine (one draw per file) and the engine back after, also where
    # a user's matplotlibrc turns an automatic layout on
    returns = np.random.default_rng(1).normal(size=(40, 6))
    figure = fig.rwg_trio_figure("2-link, dense", policy_statistics(returns), returns=returns)
    engines = []
    savefig = figure.savefig
    monkeypatch.setattr(figure, "savefig", lambda *a, **k: (engines.append(figure.get_layout_engine()), savefig(*a, **k)))
    with mpl.rc_context({automatic: True}):
        fig.save_figure(figure, tmp_path, "trio")
    assert engines == [None, None]
    assert isinstance(figure.get_layout_engine(), mpl.layout_engine.ConstrainedLayoutEngine)


def test_legible_ticks_lays_the_figure_out_without_drawing_it_and_a_draw_changes_nothing_it_read(monkeypatch):
    # The ticks are read as the layout engine leaves the axes: no draw walks the artists for it, and a draw after it
    # neither moves an axes nor shows other tick labels. Counts below 10 on a log axis, and a crowded linear axis,
    # make it change the ticks and lay the figure out again.
    rng = np.random.default_rng(3)
    figure, axes = fig._figure(2, 3, 3.4)
    for row in axes:
        returns = rng.normal(size=(6, 4)) * 1000
        fig.draw_rwg_trio(row, policy_statistics(returns), returns=returns, colour="C0")
    axes[1, 2].xaxis.set_major_locator(mpl.ticker.MaxNLocator(nbins=12))
    draws = []
    monkeypatch.setattr(type(figure), "draw", lambda self, renderer: draws.append(self))
    with fig.paper_style():
        figure.set_dpi(fig.DPI)
        fig.lay_out(figure)
        crowded = fig.shown_tick_labels(axes[1, 2].xaxis)
        assert fig.overlapping(crowded)   # what legible_ticks has to change
        fig.legible_ticks(figure)
        monkeypatch.undo()
        positions = [ax.get_position().bounds for ax in figure.axes]
        shown = [[label.get_text() for label in fig.shown_tick_labels(axis)]
                 for ax in figure.axes for axis in (ax.xaxis, ax.yaxis)]
        figure.draw_without_rendering()   # lays the figure out again: constrained layout moves an axes by ~1e-9
        # of the figure's width (a thousandth of a pixel at most: within 1e-6) each time it runs
        np.testing.assert_allclose([ax.get_position().bounds for ax in figure.axes], positions, rtol=0, atol=1e-6)
        assert [[label.get_text() for label in fig.shown_tick_labels(axis)]
                for ax in figure.axes for axis in (ax.xaxis, ax.yaxis)] == shown
    assert draws == []
    assert all(len(labels) >= 2 for labels in shown)
    thinned = fig.shown_tick_labels(axes[1, 2].xaxis)
    assert not fig.overlapping(thinned) and 2 <= len(thinned) < len(crowded)


def test_the_ablation_overlays_returns_and_policy_tables_of_different_sizes():
    rng = np.random.default_rng(2)
    figure = fig.ablation_figure({"N = 30": rng.normal(size=(30, 5)), "N = 60": policy_statistics(rng.normal(size=(60, 5)))},
                                 title="two_link-dense")
    ranked = figure.axes[1]
    assert [line.get_xdata().max() for line in ranked.get_lines()] == [1.0, 1.0]


def test_the_sac_curves_get_one_panel_per_study_group_and_the_study_colours():
    styles = task_styles(SEVEN_TASKS)
    rows = [{"task": t, "variant": "sac", "seed": seed, "env_step": step, "eval/return_mean": float(step + seed)}
            for t in ("two_link-dense", "two_link-sparse") for seed in (0, 1) for step in (0, 1000, 2000)]
    figure = fig.sac_curves_figure(pd.DataFrame(rows), styles)
    panels = [ax for ax in figure.axes if ax.get_title()]
    assert [ax.get_title() for ax in panels] == ["dense", "sparse"]
    dense_lines = panels[0].get_lines()
    assert len(dense_lines) == 1 and mpl.colors.to_hex(dense_lines[0].get_color()) == "#c0392b"
    assert dense_lines[0].get_label() == "2-link"


def test_a_study_without_groups_gets_one_sac_panel():
    study = study_from_config({"name": "pair", "tasks": [{"id": "cart", "task": "cartpole"},
                                                         {"id": "pend", "task": "pendulum"}]})
    rows = [{"task": t, "variant": "sac", "seed": 0, "env_step": step, "eval/return_mean": 1.0}
            for t in ("cart", "pend") for step in (1000, 2000)]
    figure = fig.sac_curves_figure(pd.DataFrame(rows), task_styles(study))
    assert len(figure.axes) == 1 and len(figure.axes[0].get_lines()) == 2


def test_step_labels_are_readable_at_every_scale():
    values = [0, 80, 500, 2000, 10_000, 12_500, 80_000, 500_000, 1_000_000, 2_500_000]
    assert [fig.step_label(v) for v in values] == ["0", "80", "500", "2k", "10k", "12.5k", "80k", "0.5M", "1M",
                                                   "2.5M"]


def _tick_labels(axis) -> list[str]:
    lo, hi = axis.get_view_interval()
    return [t.get_text() for t, v in zip(axis.get_ticklabels(), axis.get_ticklocs(), strict=True)
            if lo <= v <= hi and t.get_text()]


def test_the_sac_legends_sit_below_the_curves_and_the_step_axis_reads_in_k():
    styles = task_styles(SEVEN_TASKS)
    rows = [{"task": t, "variant": v, "seed": seed, "env_step": step, "eval/return_mean": float(step + seed)}
            for t in SEVEN_TASKS.ids for v in (("sac", "sac+her") if t.endswith("sparse") else ("sac",))
            for seed in (0, 1) for step in (0, 1000, 10_000, 100_000)]
    figure = fig.sac_curves_figure(pd.DataFrame(rows), styles)
    figure.draw_without_rendering()
    for ax in figure.axes:
        legend = ax.get_legend().get_window_extent()
        assert legend.y1 < ax.xaxis.label.get_window_extent().y0  # under the axis label, so off the curves
        assert legend.y1 < ax.get_window_extent().y0
        assert legend.y0 >= figure.bbox.y0  # still on the figure
        assert _tick_labels(ax.xaxis) == ["1k", "10k", "0.1M"]  # decades only over three decades
    short = pd.DataFrame(rows).query("env_step in (1000, 10000)").replace({"env_step": {1000: 100, 10_000: 300}})
    figure = fig.sac_curves_figure(short, styles)  # 100 to 300 steps: less than a decade
    figure.draw_without_rendering()
    ax = figure.axes[0]
    shown = _tick_labels(ax.xaxis) + [t.get_text() for t, v in zip(ax.xaxis.get_minorticklabels(),
                                                                  ax.xaxis.get_minorticklocs(), strict=True)
                                      if t.get_text() and ax.get_xlim()[0] <= v <= ax.get_xlim()[1]]
    assert "300" in shown and all(label.isdigit() for label in shown), shown


def test_the_learning_path_step_axis_prints_small_step_counts_as_integers():
    styles = task_styles(SEVEN_TASKS)
    path = pd.DataFrame({"step": [0, 20, 40, 60, 80], "pic": [1.0, 1.1, 1.2, 1.1, 1.3],
                         "poic": [0.1, 0.2, 0.2, 0.3, 0.3]})
    figure = fig.learning_path_figure({"two_link-dense": path}, styles)
    figure.draw_without_rendering()
    for ax in figure.axes:
        labels = _tick_labels(ax.xaxis)
        assert labels and all(label.isdigit() for label in labels), labels  # not "0.08k"
        assert "80" in labels
    large = fig.learning_path_figure({"two_link-dense": path.assign(step=path["step"] * 1000)}, styles)
    large.draw_without_rendering()
    assert _tick_labels(large.axes[0].xaxis)[:3] == ["0", "20k", "40k"]
