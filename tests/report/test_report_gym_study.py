"""A study of two gymnasium tasks (no groups, one relation) and a study without relations, through the real
stages into a report: nothing about the paper's arms is needed."""

from __future__ import annotations

import re
from contextlib import contextmanager

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest

from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report import writer
from taskcomplexity.report.build import build_report
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study_data import study_from_config
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.verdict.references import on_values
from taskcomplexity.verdict.replication import FINDING_ONLY, REPLICATION_OUTCOMES

PAIR = study_from_config({
    "name": "pair",
    "tasks": [{"id": "cart", "env_id": "CartPole-v1", "label": "Cart-pole", "color": "#ff8800"},
              {"id": "pend", "env_id": "Pendulum-v1", "label": "Pendulum"}],
    "relations": [{"easier": "cart", "harder": "pend", "kind": "swing_up"}],
})
LONE = study_from_config({"name": "lone", "tasks": [{"id": "pend", "env_id": "Pendulum-v1", "label": "Pendulum"}]})


def requests(*env_ids):
    return [RWGRequest(GymTask(e), NetworkSpec(), PriorSpec(), RWGSettings(policies=10, episodes=5), backend="gym")
            for e in env_ids]


@contextmanager
def drawn_figures():
    """Every figure the report saves, by file name (the figures themselves, to read their panels)."""
    drawn = {}

    def save(figure, directory, name):
        drawn[name] = figure
        return save_figure(figure, directory, name)

    save_figure = writer.save_figure
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(writer, "save_figure", save)
        yield drawn


def panel_titles(figures) -> list[str]:
    return [ax.get_title(loc) for figure in figures.values() for ax in figure.axes for loc in ("left", "center", "right")
            if ax.get_title(loc)]


@pytest.fixture(scope="module")
def pair(tmp_path_factory, run_stages):
    """The report of the two-task study; ``found["figures"]``: the figures it drew, by file name."""
    root = tmp_path_factory.mktemp("pair")
    found = run_stages(root, PAIR, requests("CartPole-v1", "Pendulum-v1"))
    with drawn_figures() as figures:
        index = build_report(found["results"], study=PAIR, verdict=found["verdict"], diagnostics=found["diagnostics"],
                             sac_curves=None, out_dir=root / "report", title="Two gym tasks")
    found["figures"] = figures
    return index, found


def test_the_verdict_judges_the_one_relation_with_every_metric(pair):
    index, found = pair
    verdict = pd.read_parquet(found["verdict"].file("verdict.parquet"))
    computed = [m.name for m in DEFAULT_REGISTRY if m.stage in ("metrics", "diagnostics")]  # no SAC, no actor
    assert verdict["metric"].tolist() == computed
    assert set(verdict["easier"]) == {"cart"} and set(verdict["harder"]) == {"pend"}
    # CartPole's returns are positive episode lengths, Pendulum's are negative costs: the mean return orders them
    row = verdict.set_index("metric").loc["r_mean"]
    assert row["value_easier"] > 0 > row["value_harder"] and bool(row["agrees"])


def test_the_page_uses_the_study_labels_and_says_what_is_missing(pair, table1_metric_columns):
    index, _ = pair
    html = index.read_text(encoding="utf-8")
    assert "Cart-pole &lt; Pendulum" in html or "Cart-pole < Pendulum" in html
    assert "swing up" in html and "swing_up" not in html
    table1 = pd.read_csv(index.parent / "tables" / "table1.csv")
    assert list(table1.columns) == ["Task", *table1_metric_columns]  # no groups
    assert table1["Task"].tolist() == ["Cart-pole", "Pendulum"]
    assert "SAC curves were not computed" in html
    assert "it rates" in html or "no measure contradicts it significantly" in html


def test_a_task_colour_from_the_study_reaches_the_figures(pair):
    from taskcomplexity.report.labels import task_styles

    assert task_styles(PAIR)["cart"].colour == "#ff8800"
    index, found = pair
    assert (index.parent / "figures" / "rwg_trios.png").stat().st_size > 1000
    trio = found["figures"]["rwg_trios"]
    rows = [ax for ax in trio.axes if ax.get_title(loc="left")]  # each task's histogram, its name on the left
    assert [ax.get_title(loc="left") for ax in rows] == ["Cart-pole", "Pendulum"]
    assert mpl.colors.to_hex(rows[0].patches[0].get_facecolor()) == "#ff8800"


SCATTER_LEFT_OUT = ("The figure of the normalised score score_R against every metric is left out: this report "
                    "compares 2 tasks, and a correlation needs at least 3.")


def test_with_two_tasks_the_correlation_figure_is_left_out_with_one_line_saying_why(pair):
    index, found = pair
    figures = found["figures"]
    assert list(figures) == ["rwg_trios", "bootstrap", "diagnostics_bins", "diagnostics_null"]
    assert not any("n/a" in title for title in panel_titles(figures))  # was 8 panels titled "r = n/a"
    assert not any(ax.texts for figure in figures.values() for ax in figure.axes)  # no placeholder panel text
    assert not list((index.parent / "figures").glob("score_scatter.*"))
    markdown = (index.parent / "report.md").read_text(encoding="utf-8")
    assert markdown.count(SCATTER_LEFT_OUT) == 1
    # where the figure would be: after the bootstrap figure, before the random-policy statistics table
    assert markdown.index("Bootstrap distributions of") < markdown.index(SCATTER_LEFT_OUT) < markdown.index(
        "Random-policy statistics.")
    page = parse_text(index)
    assert SCATTER_LEFT_OUT in page
    # the figures drawn keep consecutive numbers in page order: the line takes none
    assert [int(n) for n in re.findall(r"Figure (\d+)\. ", page)] == [1, 2, 3, 4]
    assert "**Figure 3. PIC depends on the estimator's settings.**" in markdown


def parse_text(index) -> str:
    import html as html_lib

    return html_lib.unescape(re.sub(r"<[^>]+>", " ", index.read_text(encoding="utf-8")))


def test_a_study_without_relations_shows_its_metrics_and_says_there_is_nothing_to_judge(tmp_path, run_stages):
    found = run_stages(tmp_path, LONE, requests("Pendulum-v1"), diagnostics=False)
    verdict = pd.read_parquet(found["verdict"].file("verdict.parquet"))
    summary = pd.read_parquet(found["verdict"].file("summary.parquet"))
    assert verdict.empty
    assert summary["metric"].tolist() == [m.name for m in DEFAULT_REGISTRY.of_stage("metrics")]
    assert (summary["relations"] == 0).all()
    index = build_report(found["results"], study=LONE, verdict=found["verdict"], diagnostics=None, sac_curves=None,
                         out_dir=tmp_path / "report", title="One task")
    text = index.read_text(encoding="utf-8")
    assert "The study gives no relation to judge" in text
    assert "1 task, N = 10" in text
    assert not (index.parent / "tables" / "verdict_matrix.csv").exists()
    values = pd.read_csv(index.parent / "tables" / "verdict_values.csv")
    assert set(values["metric"]) == set(summary["metric"]) and set(values["task"]) == {"pend"}
    table1 = pd.read_csv(index.parent / "tables" / "table1.csv")
    assert table1["Task"].tolist() == ["Pendulum"]


def test_algorithm_scores_give_score_a_score_r_and_every_metrics_correlation(tmp_path, run_stages, scored_study):
    found = run_stages(tmp_path, scored_study, requests("CartPole-v1", "Pendulum-v1", "MountainCarContinuous-v0"))
    metrics = {r.task_id: pd.read_parquet(r.metrics.file("metrics.parquet")).iloc[0] for r in found["results"]}
    references = pd.read_parquet(found["verdict"].file("references.parquet")).set_index(["task", "reference"])
    for task, score in scored_study.algorithm_scores.items():  # the definitions, from the metrics artefact's bounds
        m = metrics[task]
        span = max(m["r_max"], score.max) - m["r_min"]
        assert references.loc[(task, "score_a"), "value"] == pytest.approx((score.average - m["r_min"]) / span)
        assert references.loc[(task, "score_r"), "value"] == pytest.approx((m["r_mean"] - m["r_min"]) / span)
    correlated = on_values(pd.read_parquet(found["verdict"].file("correlations.parquet")))
    metric_rows = correlated[correlated["quantity"] == correlated["metric"]]
    assert set(metric_rows["metric"]) == {m.name for m in DEFAULT_REGISTRY if m.stage in ("metrics", "diagnostics")}
    assert {"h_r", "h_r_given_theta", "h_o", "h_o_given_theta"} <= set(correlated["quantity"])
    assert set(correlated["reference"]) == {"score_a", "score_r"} and (correlated["tasks"] == 3).all()
    pic = correlated.set_index(["quantity", "reference"]).loc[("pic", "score_a")]
    values = [metrics[t]["pic"] for t in ("cart", "pend", "car")]
    x = [references.loc[(t, "score_a"), "value"] for t in ("cart", "pend", "car")]
    assert pic["pearson_r"] == pytest.approx(float(np.corrcoef(x, values)[0, 1]))
    # the bootstrap interval of r: r of Score(A) with the draws of each resample (each task's centred on its value),
    # over the resamples
    draws = {r.task_id: pd.read_parquet(r.metrics.file("bootstrap.parquet"))["pic"] for r in found["results"]}
    draws = {t: d - d.mean() + metrics[t]["pic"] for t, d in draws.items()}
    rs = [np.corrcoef(x, [draws[t][b] for t in ("cart", "pend", "car")])[0, 1] for b in range(20)]
    assert (pic["pearson_low"], pic["pearson_high"]) == pytest.approx(tuple(np.quantile(rs, [0.025, 0.975])))
    every = pd.read_parquet(found["verdict"].file("correlations.parquet"))
    information = pd.read_parquet(found["verdict"].file("information.parquet")).set_index(["metric", "task"])
    net = every[(every["quantity"] == "pic") & (every["reference"] == "score_a") & (every["basis"] == "net of null")]
    centred = [values[i] - information.loc[("pic", t), "null_mean"] for i, t in enumerate(("cart", "pend", "car"))]
    assert net["pearson_r"].item() == pytest.approx(float(np.corrcoef(x, centred)[0, 1]))
    assert net["pearson_low"].item() <= net["pearson_r"].item() <= net["pearson_high"].item()
    informative = every[(every["quantity"] == "poic") & (every["basis"] == "informative")]
    assert (informative["tasks"] == information.loc["poic", "informative"].sum()).all()
    # the published correlations beside ours, with an outcome each
    replicated = pd.read_parquet(found["verdict"].file("replications.parquet")).set_index("quantity")
    assert list(replicated.index) == ["poic", "pic"] and replicated.loc["poic", "published_r"] == 0.807
    assert replicated.loc["pic", "pearson_r"] == pytest.approx(pic["pearson_r"])
    assert set(replicated["outcome"]) <= set(REPLICATION_OUTCOMES)

    with drawn_figures() as figures:
        index = build_report(found["results"], study=scored_study, verdict=found["verdict"], diagnostics=None,
                             sac_curves=None, out_dir=tmp_path / "report", title="Scored")
    # three tasks: both correlation figures are drawn, every panel with its r (none left out)
    assert {"reference_scatter", "score_scatter"} <= set(figures)
    titles = [t for name in ("reference_scatter", "score_scatter") for t in panel_titles({name: figures[name]})]
    assert len(titles) >= 16 and all(re.fullmatch(r"r = -?\d\.\d\d, p = \S+", t) for t in titles), titles
    assert (index.parent / "figures" / "score_scatter.png").stat().st_size > 1000
    assert "is left out" not in index.read_text(encoding="utf-8")
    tables = index.parent / "tables"
    table = pd.read_csv(tables / "reference_scores.csv")
    assert list(table.columns[-2:]) == ["Score(A)", "Score(R)"] and {"H(O)", "H(R|Θ)"} <= set(table.columns)
    text = index.read_text(encoding="utf-8")
    assert "Against Score(A) across 3 tasks, PIC r = " in text
    assert pd.read_csv(tables / "reference_correlations.csv")["Quantity"].iloc[0] == "PIC"
    assert (index.parent / "figures" / "reference_scatter.png").stat().st_size > 1000
    # the published values and correlations beside ours, and a sentence for each primary metric
    printed = pd.read_csv(tables / "published_printed.csv")
    assert printed["Task"].tolist() == ["cart", "pend"]
    assert printed["PIC"].iloc[1] == f"{metrics['pend']['pic']:.3f} (3.700)"
    assert pd.read_csv(tables / "replications.csv")["Outcome"].isin((*REPLICATION_OUTCOMES, FINDING_ONLY)).all()
    for metric, r in (("POIC", "0.807"), ("PIC", "-0.295")):
        assert f"{metric} against Score(A): a paper prints r = {r}" in parse_text(index)


def test_the_methods_give_directions_of_the_computed_metrics_only_in_one_wording(pair):
    import html as html_lib
    import re

    index, found = pair
    page = html_lib.unescape(index.read_text(encoding="utf-8"))
    directions = re.search(r"<dt>Directions</dt><dd>(.*?)</dd>", page).group(1)
    computed = [m for m in DEFAULT_REGISTRY if m.stage in ("metrics", "diagnostics")]  # no SAC, no actor
    for metric in DEFAULT_REGISTRY:
        named = re.search(rf"(^|; |, ){re.escape(metric.label)}(:|,)", directions) is not None
        assert named == (metric in computed), metric.label
    assert "= harder" not in directions
    assert directions.count("higher = easier") + directions.count("lower = easier") == len(
        {(m.higher_is_easier, m.why) for m in computed})  # metrics sharing a direction and a reason share a line
    assert len(directions) < 1500  # 3 226 characters when every registered metric was listed: not ~40 lines about metrics the study did not compute


def test_counts_outside_the_headline_read_right_with_one_relation(pair):
    import re

    index, _ = pair
    page = index.read_text(encoding="utf-8")
    body = re.sub(r"<[^>]+>", " ", page[page.index('class="methods"'):])  # headline.py's words are not judged here
    assert "PIC and POIC leave the one known relation open" in body or "PIC and POIC leave no known relation open" in body
    assert not re.search(r"\b1 (known |complexity |[a-z]+ )?(relations|tasks|policies|episodes|cells)\b", body)
    assert not re.search(r"\b[01] of (the )?1\b", body)
    assert "this report compares 2 tasks" in body


def test_a_reproduced_correlation_says_where_the_published_level_lies():
    from taskcomplexity.report.headline import _level

    row = {"outcome": "reproduced", "published_r": 0.807, "pearson_low": 0.51, "pearson_high": 0.73,
           "tasks_low": 0.14, "tasks_high": 0.88}
    assert _level(row) == ("; the published r lies outside our interval over resampled policies and inside Fisher's "
                           "interval across the tasks (0.14 to 0.88)")
    assert _level({**row, "pearson_high": 0.9}).startswith("; the published r lies inside our interval")
    assert _level({**row, "outcome": "estimator bias"}) == "" and _level({**row, "pearson_low": float("nan")}) == ""


def test_a_reproduced_finding_whose_value_ours_excludes_says_both_in_its_sentence(scored_study):
    from types import SimpleNamespace

    from taskcomplexity.report.headline import replication_sentences

    pic = {"table": "printed", "reference": "score_a", "quantity": "pic", "metric": "pic", "published_r": -0.295,
           "published_p": 0.328, "tasks": 13, "pearson_r": 0.44, "pearson_p": 0.13, "pearson_low": 0.38,
           "pearson_high": 0.48, "tasks_low": -0.15, "tasks_high": 0.80, "informative_tasks": float("nan"),
           "informative_r": float("nan"), "informative_p": float("nan"), "net_r": float("nan"),
           "net_p": float("nan"), "net_low": float("nan"), "net_high": float("nan"), "outcome": "reproduced",
           "why": "neither the published correlation nor ours is significant"}
    data = SimpleNamespace(verdict={"replications": pd.DataFrame([pic])}, registry=DEFAULT_REGISTRY,
                           study=scored_study, metrics=pd.DataFrame({"policies": [1000], "episodes": [1000]}))
    (sentence,) = replication_sentences(data)
    assert ("Finding reproduced, value not at N = 1,000 × M = 1,000: neither the published correlation nor ours is "
            "significant; the published r lies outside our interval over resampled policies and outside Fisher's "
            "interval across the tasks (-0.15 to 0.80).") in sentence.replace("−", "-")


def test_a_study_without_sac_budgets_is_advised_its_own_command_never_the_seven_task_targets(pair, tmp_path):
    from taskcomplexity.stages.declared import STAGES

    _, found = pair
    missing = {stage.name: stage.missing for stage in STAGES if stage.missing}
    assert any("make beyond" in text for text in missing.values())  # the stages' own advice, about the 7 tasks

    def page(sac_curves, name):
        index = build_report(found["results"], study=PAIR, verdict=found["verdict"], diagnostics=None,
                             sac_curves=sac_curves, out_dir=tmp_path / name, title="Two gym tasks", missing=missing)
        return parse_text(index)

    # default settings: no sac_steps and no sac.total_steps, so no SAC reference (as the SAC stage logs it)
    none = page(None, "none")
    assert ("The study gives no task a SAC budget (sac_steps) and this run no sac.total_steps, so it has no SAC "
            "reference") in none  # in the SAC section, and as section 4's way to SAC
    assert "(SAC: the study gives no task a SAC budget" in none
    # experiment=quick: sac.total_steps trains every task; the report gives this run's own command
    curves = pd.DataFrame(columns=["task", "variant", "seed", "env_step", "eval/return_mean"])
    curves.attrs.update(sac_command="pipelines/study.py study=pair experiment=quick sac.enabled=true",
                        sac_missing=["pend"])
    quick = page(curves, "quick")
    assert ("Compute the curves with `pipelines/study.py study=pair experiment=quick sac.enabled=true`; the study "
            "gives no task a SAC budget (sac_steps), so SAC trains every task for this run's sac.total_steps") in quick
    assert "(SAC: `pipelines/study.py study=pair experiment=quick sac.enabled=true`" in quick  # section 4 too
    for text in (none, quick):
        assert "make beyond" not in text and "make paper" not in text
