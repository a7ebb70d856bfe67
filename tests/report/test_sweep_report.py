"""The sweep report: cells of a multirun, read from their verdict artefacts, and their mean."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from taskcomplexity.policies import NetworkSpec, PriorSpec
from taskcomplexity.report.sweep import JOB_FILE, cell_names, sweep_jobs, write_sweep_report
from taskcomplexity.rwg import RWGSettings
from taskcomplexity.stages.rwg_stage import RWGRequest
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
    assert "Sweep of scored: 2 cells" in readme.read_text(encoding="utf-8")
    assert write_sweep_report(tmp_path / "empty") is None


@pytest.mark.slow
def test_a_multirun_of_studies_ends_with_the_sweep_report(tmp_path):
    command = [sys.executable, str(ROOT / "pipelines" / "study.py"), "-m", "study=classic_control",
               "network=pic_linear,pic_h1_4", "study.policies=10", "study.episodes=4", "metrics.resamples=10",
               "diagnostics.repeats=2", f"paths.outputs={tmp_path}"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=1200, cwd=tmp_path,
                          env={**os.environ, "HYDRA_FULL_ERROR": "0"})
    assert done.returncode == 0, done.stderr[-2000:]
    (readme,) = tmp_path.glob("runs/multirun/*/*/sweep_report/README.md")
    assert f"Sweep report: {readme.resolve()}" in done.stdout
    table = pd.read_csv(readme.parent / "sweep_correlations.csv")
    assert table["Cell"].tolist()[:4] == ["network=pic_linear"] * 2 + ["network=pic_h1_4"] * 2
    for job in ("0", "1"):  # each cell's report in its own job directory: the cells do not overwrite each other
        assert (readme.parents[1] / job / "report" / "index.html").is_file()
