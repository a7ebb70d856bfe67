"""Off the paper's scale the report says first when a primary metric measures its estimator (e.g. CartPole-v1
against Pendulum-v1 at N = 64, M = 8 with the published B = 10⁵), and says how far from the paper's scale it is."""

from __future__ import annotations

import re

import pandas as pd
import pytest

from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report.build import build_report
from taskcomplexity.report.format import of_total
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.metrics_stage import MetricsSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study_data import study_from_config
from taskcomplexity.tasks.gym_task import GymTask

PAIR = study_from_config({
    "name": "pair",
    "tasks": [{"id": "cart", "env_id": "CartPole-v1", "label": "CartPole"},
              {"id": "pend", "env_id": "Pendulum-v1", "label": "Pendulum"}],
    "relations": [{"easier": "cart", "harder": "pend", "kind": "swing_up"}],
})


def report(root, run_stages, settings):
    requests = [RWGRequest(GymTask(e), NetworkSpec(), PriorSpec(), RWGSettings(policies=64, episodes=8), backend="gym")
                for e in ("CartPole-v1", "Pendulum-v1")]
    found = run_stages(root, PAIR, requests, settings=settings)
    index = build_report(found["results"], study=PAIR, verdict=found["verdict"], diagnostics=found["diagnostics"],
                         sac_curves=None, out_dir=root / "report", title="CartPole against Pendulum")
    return (index.parent / "report.md").read_text(encoding="utf-8"), found


@pytest.fixture(scope="module")
def published_bins(tmp_path_factory, run_stages):
    return report(tmp_path_factory.mktemp("b100000"), run_stages, MetricsSettings(bins=100_000, resamples=20))


def test_pic_at_its_ceiling_and_null_is_uninformative_and_the_headline_says_it_first(published_bins):
    text, found = published_bins
    checked = pd.read_parquet(found["verdict"].file("information.parquet")).set_index(["metric", "task"])
    pend = checked.loc[("pic", "pend")]
    assert not pend["informative"] and "ceiling" in pend["reason"] and pend["null_share"] > 0.99
    verdict = pd.read_parquet(found["verdict"].file("verdict.parquet")).set_index("metric")
    assert verdict.loc["pic", "outcome"] == "uninformative"
    headline = text.split("## The verdict", 1)[1].strip().splitlines()[0]
    assert headline.startswith("PIC ")
    first = headline.split(". ")[0]
    assert "ceiling ln N" in first and "measures the estimator, not the tasks" in first
    assert "PIC agrees" not in headline and "PIC contradicts" not in headline
    # A study without a published: block is compared with nothing published: its own N, M, B and what the
    # information check found, counted from the information table.
    assert "Table 1 of the paper" not in text.split("## The verdict", 1)[0]
    assert "This study has no published table to compare with" in text
    for metric, label in (("pic", "PIC"), ("poic", "POIC")):
        rows = checked.xs(metric, level="metric")
        found = of_total(int(rows["informative"].sum()), len(rows), "task")
        assert f"{label} informative on {found}" in text or f"{label} on {found}" in text
    assert "○" in text  # the matrix marks the uninformative relation


def test_the_verdict_table_prints_the_n_to_resolve_and_the_nulls_share(published_bins):
    text, found = published_bins
    verdict = pd.read_parquet(found["verdict"].file("verdict.parquet"))
    assert {"policies_to_resolve", "null_share_of_difference"} <= set(verdict.columns)
    unresolved = verdict[verdict["outcome"] == "not significant"]
    assert (unresolved["policies_to_resolve"].dropna() > 0).all()
    assert "To resolve" in text and "Nulls' share of Δ" in text
    # one next budget, whose N is the largest N to resolve of the primary metrics' tests not significant (as the
    # full verdict table shows them, rounded up to 2 digits)
    projected = unresolved[unresolved["metric"].isin(["pic", "poic"]) & unresolved["policies_to_resolve"].lt(1e9)]
    budget = re.search(r"Next budget: N = ([\d\u2009]+) policies × M = ([\d\u2009]+) episodes", text)
    if projected.empty:
        assert budget is None or int(budget.group(1).replace("\u2009", "")) == 64
    else:
        largest = projected["policies_to_resolve"].max()
        shown = int(budget.group(1).replace("\u2009", ""))
        assert largest <= shown < largest * 1.1  # rounded up to 2 significant digits
        assert f"N ≈ {budget.group(1)}" in text  # the same number in the full verdict table
        # B = 10⁵ is not the auto rule's N·M/50 here, so nothing is said of auto
        assert "nulls move with N too" in text and "bins=auto" not in text
    table1 = text.split("PIC null share", 1)
    assert len(table1) == 2  # Table 1 carries the null's share per task


def test_with_auto_bins_the_study_runs_at_the_papers_ratio(tmp_path, run_stages):
    text, found = report(tmp_path, run_stages, MetricsSettings(resamples=20))
    manifest = found["results"][0].metrics.manifest["config"]
    assert manifest["bins"] == 64 * 8 // 50  # N·M / 50
    assert "B = 10" in text


def test_table1_says_what_its_values_hold_besides_information(published_bins):
    text, found = published_bins
    caption = text.split("of random policies.**", 1)[1].split("\n", 1)[0]
    assert "null share is the part of the whole-sample value that its permutation null gives" in caption
    # the caption names the bootstrap mean's bias exactly when a value's bootstrap mean is over 2 sd from it
    rows = [pd.read_parquet(r.metrics.file("metrics.parquet")).iloc[0] for r in found["results"]]
    biased = [r for r in rows for m in ("pic", "poic") if abs(r[m] - r[f"{m}_mean"]) > 2 * r[f"{m}_sd"]]
    assert biased  # at N = 64 (Pendulum's PIC sits at its ceiling; a resample repeats policies)
    assert "the bootstrap mean is biased" in caption
