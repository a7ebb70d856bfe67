"""The sweep report: cells of a multirun, read from their verdict artefacts, and their mean."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import preloaded
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.report.sweep import JOB_FILE, cell_names, sweep_jobs, write_sweep_report
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
from taskcomplexity.study_data import study_from_config
from taskcomplexity.tasks.gym_task import GymTask

ROOT = Path(__file__).resolve().parents[2]
CELLS = {"network=pic_linear prior=normal": (NetworkSpec(hidden=(), activation="tanh", output="linear"),
                                              PriorSpec()),
         "network=pic_h1_4 prior=uniform": (NetworkSpec(hidden=(4,), activation="tanh", output="linear"),
                                            PriorSpec(kind="uniform", low=-1.0, high=1.0))}


def test_cells_are_named_by_the_overrides_that_differ():
    jobs = [{"overrides": ["study=s", "network=a", "prior=x"]}, {"overrides": ["study=s", "network=b", "prior=x"]}]
    assert cell_names(jobs) == ["network=a", "network=b"]
    assert cell_names(jobs[:1]) == ["study=s network=a prior=x"]  # one job: every override names it


def test_the_sweep_report_tabulates_each_cell_and_the_mean_over_cells(tmp_path, run_stages, scored_study):
    sweep = tmp_path / "sweep"
    for num, (cell, (network, prior)) in enumerate(CELLS.items()):
        requests = [RWGRequest(GymTask(e), network, prior, RWGSettings(policies=10, episodes=4), backend="kernel")
                    for e in ("CartPole-v1", "Pendulum-v1", "MountainCarContinuous-v0")]
        found = run_stages(tmp_path / "cache", scored_study, requests, diagnostics=False)
        (sweep / str(num)).mkdir(parents=True)
        record = {"study": "scored", "overrides": ["study=scored", *cell.split()],
                  "verdict": str(found["verdict"].path), "report": f"cell {num}"}
        (sweep / str(num) / JOB_FILE).write_text(json.dumps(record))
    (sweep / "9").mkdir()  # a job that recorded nothing (e.g. failed) is skipped
    assert [j["report"] for j in sweep_jobs(sweep)] == ["cell 0", "cell 1"]
    readme = write_sweep_report(sweep)
    out = readme.parent
    tidy = pd.read_csv(out / "sweep_correlations_tidy.csv")
    pic = tidy[(tidy["quantity"] == "pic") & (tidy["reference"] == "score_a")]
    assert pic["cell"].tolist() == list(CELLS)
    table = pd.read_csv(out / "sweep_correlations.csv")
    mean_row = table[(table["Cell"] == "mean ± sd over 2 cells") & (table["Reference"] == "Score(A)")].iloc[0]
    r = pic["pearson_r"].to_numpy()
    assert mean_row["PIC"] == f"{r.mean():.2f} ± {r.std(ddof=1):.2f}"
    values = pd.read_csv(out / "sweep_values_tidy.csv")
    score_a = values[(values["quantity"] == "score_a") & (values["task"] == "cart")]["value"].to_numpy()
    assert score_a.size == 2 and np.all((score_a > 0) & (score_a <= 1))
    # the cells as one bag: r across tasks of the means over the cells
    means = values.groupby(["task", "quantity"])["value"].mean().unstack()
    bag = pd.read_csv(out / "sweep_bag_correlations.csv").set_index("Metric")
    expected = np.corrcoef(means["score_a"], means["poic"])[0, 1]
    assert bag.loc["POIC", "r with Score(A) (p)"].startswith(f"{expected:.2f} (") and bag.loc["POIC", "Tasks"] == 3
    text = readme.read_text(encoding="utf-8")
    assert "Sweep of scored: 2 cells" in text
    # the study gives no relation: no verdict table is written, and the README says why in one line
    assert not list(out.glob("sweep_verdict*"))
    assert "No verdict table: the study gives no known relation" in text
    assert write_sweep_report(tmp_path / "empty") is None


RANKED = study_from_config({
    "name": "ranked",
    "tasks": [{"id": "cart", "env_id": "CartPole-v1", "label": "Cart-pole"},
              {"id": "pend", "env_id": "Pendulum-v1", "label": "Pendulum"},
              {"id": "car", "env_id": "MountainCarContinuous-v0", "label": "Mountain car"}],
    "relations": [{"easier": "cart", "harder": "pend", "kind": "swing_up"},
                  {"easier": "cart", "harder": "car", "kind": "exploration"}],
})


def markdown_tables(text: str) -> list[list[str]]:
    """The Markdown tables of a page, each as its lines."""
    tables, current = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            tables.append(current)
            current = []
    return tables


def test_the_sweep_report_has_a_verdict_per_cell_and_no_empty_table(tmp_path, run_stages):
    sweep = tmp_path / "sweep"
    verdicts = {}
    for num, (cell, (network, prior)) in enumerate(CELLS.items()):
        requests = [RWGRequest(GymTask(e), network, prior, RWGSettings(policies=10, episodes=4), backend="kernel")
                    for e in ("CartPole-v1", "Pendulum-v1", "MountainCarContinuous-v0")]
        found = run_stages(tmp_path / "cache", RANKED, requests, diagnostics=False)
        verdicts[cell] = pd.read_parquet(found["verdict"].file("verdict.parquet"))
        (sweep / str(num)).mkdir(parents=True)
        record = {"study": "ranked", "overrides": ["study=ranked", *cell.split()],
                  "labels": {t.id: t.label for t in RANKED.tasks},
                  "verdict": str(found["verdict"].path), "report": f"cell {num}"}
        (sweep / str(num) / JOB_FILE).write_text(json.dumps(record))
    readme = write_sweep_report(sweep)
    out, text = readme.parent, readme.read_text(encoding="utf-8")
    table = pd.read_csv(out / "sweep_verdict.csv")
    assert list(table.columns[:6]) == ["Cell", "Metric", "Relations", "Agree", "Contradict", "Not significant"]
    assert list(zip(table["Cell"], table["Metric"], strict=True)) == [(c, m) for c in CELLS for m in ("PIC", "POIC")]
    for row in table.itertuples(index=False):
        judged = verdicts[row.Cell][verdicts[row.Cell]["metric"] == row.Metric.lower()]
        assert row.Relations == len(judged) == 2
        assert (row.Agree, row.Contradict) == ((judged["outcome"] == "agree").sum(),
                                               (judged["outcome"] == "contradict").sum())
        assert sum(row[3:-1]) == row.Relations  # every outcome counted once
        named = {"Cart-pole < Pendulum", "Cart-pole < Mountain car"}
        assert row.Contradicted == "–" or set(row.Contradicted.split("; ")) <= named
    assert pd.read_csv(out / "sweep_values.csv")["Task"].tolist() == ["Cart-pole", "Pendulum", "Mountain car"]
    # no reference scores: no correlation table (nor its tidy data), one line says why; every table has rows
    assert not list(out.glob("sweep_correlations*"))
    assert "No correlation table: the study gives no reference scores" in text
    tables = markdown_tables(text)
    assert len(tables) == 2 and all(len(t) >= 3 for t in tables)  # header, rule and at least one row each


@pytest.mark.slow
def test_a_multirun_of_studies_ends_with_the_sweep_report(tmp_path):
    command = [sys.executable, str(ROOT / "pipelines" / "study.py"), "-m", "study=classic_control",
               "network=pic_linear,pic_h1_4", "study.policies=10", "study.episodes=4", "metrics.resamples=10",
               "diagnostics.repeats=2", f"paths.outputs={tmp_path}"]
    done = preloaded.run(command, capture_output=True, text=True, timeout=1200, cwd=tmp_path,
                         env={**os.environ, "HYDRA_FULL_ERROR": "0"})
    assert done.returncode == 0, done.stderr[-2000:]
    (readme,) = tmp_path.glob("runs/multirun/*/*/sweep_report/README.md")
    assert f"Sweep report: {readme.resolve()}" in done.stdout
    table = pd.read_csv(readme.parent / "sweep_correlations.csv")
    assert table["Cell"].tolist()[:4] == ["network=pic_linear"] * 2 + ["network=pic_h1_4"] * 2
    for job in ("0", "1"):  # each cell's report in its own job directory: the cells do not overwrite each other
        assert (readme.parents[1] / job / "report" / "index.html").is_file()


def test_the_verdict_table_counts_every_outcome_and_names_contradicted_relations_by_label():
    from taskcomplexity.report.sweep import verdict_table

    rows = [("a", "pic", "cart", "pend", "contradict"), ("a", "pic", "cart", "car", "agree"),
            ("a", "poic", "cart", "pend", "uninformative"), ("a", "poic", "cart", "car", "not significant"),
            ("a", "r_mean", "cart", "pend", "contradict"), ("b", "pic", "cart", "pend", "agree"),
            ("b", "pic", "cart", "car", "agree"), ("b", "poic", "cart", "pend", "agree"),
            ("b", "poic", "cart", "car", "agree")]
    verdicts = pd.DataFrame(rows, columns=["cell", "metric", "easier", "harder", "outcome"])
    table = verdict_table(verdicts, labels={"cart": "Cart-pole", "pend": "Pendulum"})
    assert list(table.columns) == ["Cell", "Metric", "Relations", "Agree", "Contradict", "Not significant",
                                   "Uninformative", "Contradicted"]
    assert table["Metric"].tolist() == ["PIC", "POIC", "PIC", "POIC"]  # primary metrics only
    first = table.iloc[0]
    assert (first["Agree"], first["Contradict"], first["Contradicted"]) == (1, 1, "Cart-pole < Pendulum")
    assert table.iloc[1]["Uninformative"] == 1 and table.iloc[1]["Not significant"] == 1
    assert table.iloc[2]["Contradicted"] == "–"
    assert verdict_table(verdicts.iloc[:0]).empty
