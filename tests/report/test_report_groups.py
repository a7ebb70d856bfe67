"""A study of ordered difficulty groups through the real stages into a report: the groups figure, the rank-agreement
and group-relations tables, and a headline whose every number is the verdict's."""

from __future__ import annotations

import re

import pandas as pd
import pytest
from tests.report.test_report_gym_study import drawn_figures

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report.build import build_report
from taskcomplexity.report.format import num, pvalue
from taskcomplexity.report.groups import judged_basis
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study_data import study_from_config
from taskcomplexity.tasks.gym_task import GymTask

IDS = {"CartPole-v1": "easy", "Acrobot-v1": "easy", "Pendulum-v1": "medium", "MountainCarContinuous-v0": "hard",
       "MountainCar-v0": "hard"}
GROUPED = study_from_config({
    "name": "grouped",
    "tasks": [{"id": env_id.split("-")[0].lower(), "env_id": env_id, "group": group} for env_id, group in IDS.items()],
    "groups": {"order": ["easy", "medium", "hard"], "source": "a test's grouping"},
})


@pytest.fixture(scope="module")
def grouped(tmp_path_factory, run_stages):
    root = tmp_path_factory.mktemp("grouped")
    requests = [RWGRequest(GymTask(e), NetworkSpec(), PriorSpec(), RWGSettings(policies=10, episodes=5),
                           backend="kernel") for e in IDS]
    found = run_stages(root, GROUPED, requests)
    with drawn_figures() as figures:
        index = build_report(found["results"], study=GROUPED, verdict=found["verdict"],
                             diagnostics=found["diagnostics"], sac_curves=None, out_dir=root / "report",
                             title="Grouped")
    return index, found, figures


def test_the_verdict_ranks_every_comparable_metric_against_the_groups(grouped):
    _, found, _ = grouped
    ranks = pd.read_parquet(found["verdict"].file("groups.parquet"))
    relations = pd.read_parquet(found["verdict"].file("group_relations.parquet"))
    assert {"pic", "poic"} <= set(ranks["metric"]) and "r_mean" not in set(ranks["metric"])  # task units: left out
    assert set(ranks.loc[ranks["metric"] == "pic", "basis"]) == {"value", "informative", "net of null"}
    assert set(zip(relations["easier"], relations["harder"], strict=True)) == {
        ("easy", "medium"), ("easy", "hard"), ("medium", "hard")}
    value = ranks[(ranks["metric"] == "pic") & (ranks["basis"] == "value")].iloc[0]
    assert value["tasks"] == 5 and -1 <= value["kendall_tau"] <= 1


def test_the_headline_states_the_verdicts_own_tau_for_each_primary_metric(grouped):
    index, found, _ = grouped
    ranks = pd.read_parquet(found["verdict"].file("groups.parquet"))
    markdown = (index.parent / "report.md").read_text(encoding="utf-8")
    headline = markdown[markdown.index("Against the published difficulty groups of these 5 tasks"):]
    headline = headline[: headline.index("\n")]
    assert "easy (2) < medium (1) < hard (2); a test's grouping" in headline
    for metric, label in (("pic", "PIC"), ("poic", "POIC")):
        row = ranks[(ranks["metric"] == metric) & (ranks["basis"] == judged_basis(ranks, metric))].iloc[0]
        said = re.search(rf"{label} [^:]*: τ-b = (\S+?)(?: \([^)]*\))?, p = ([^;\s]+?)[;.]?(?:\s|$)", headline)
        assert said is not None, headline
        assert said.group(1) == num(row["kendall_tau"], 2) and said.group(2).strip() == pvalue(row["kendall_p"])
    assert "The information check finds PIC informative on" in markdown


def test_the_page_has_the_groups_figure_and_both_tables(grouped):
    index, _, figures = grouped
    assert "groups" in figures
    panels = [ax for ax in figures["groups"].axes if ax.get_xticklabels()]
    assert [t.get_text() for t in panels[0].get_xticklabels()] == ["easy", "medium", "hard"]
    assert all(len(ax.get_yticks()) >= 2 for ax in panels)
    tables = index.parent / "tables"
    assert (tables / "group_rank_agreement.csv").is_file() and (tables / "group_relations.csv").is_file()
    html = index.read_text(encoding="utf-8")
    assert "Rank agreement with the difficulty groups." in html and "Relations between the difficulty groups." in html
