"""`pipelines/study.py experiment=smoke`: the whole chain from a composed config to the report."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import open_dict

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.metrics import DEFAULT_REGISTRY
from taskcomplexity.stages.declared import judged_stages
from taskcomplexity.stages.sac_stage import STAGE as SAC
from taskcomplexity.study.chain import CHAIN, study_artefacts
from taskcomplexity.study.plan import read_plan, study_from
from taskcomplexity.study.run import run_study


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """One smoke study (SAC off) computed for the whole module: (cfg, index.html, what it printed)."""
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose("config", overrides=["experiment=smoke", "sac.enabled=false"])
    GlobalHydra.instance().clear()
    with open_dict(cfg):
        cfg.paths.outputs = str(tmp_path_factory.mktemp("smoke") / "outputs")
    with pytest.MonkeyPatch.context() as patch:
        printed = []
        patch.setattr("builtins.print", lambda *a, **k: printed.append(" ".join(map(str, a))))
        index = run_study(cfg)
    return cfg, index, "\n".join(printed)


def test_smoke_study_writes_a_self_contained_report_and_says_where(smoke):
    cfg, index, printed = smoke
    reports = Path(cfg.paths.outputs) / "reports"
    assert index.parent.parent == reports / "seven_tasks-smoke" and index.name == "index.html"
    html = index.read_text()
    assert "verdict" in html.lower()
    assert not re.search(r'<(script|link)\b', html)
    for src in re.findall(r'src="([^"]+)"', html):
        assert src.startswith("data:image/png;base64,")
    figures = list((index.parent / "figures").glob("*.png"))
    tables = list((index.parent / "tables").glob("*.md"))
    assert figures and tables
    assert all(p.stat().st_size > 0 for p in figures + tables)
    assert (index.parent / "report.md").stat().st_size > 0
    assert printed.strip().splitlines()[-2:] == [f"Report: {index.resolve()}",
                                                 f"Every report: {(reports / 'index.html').resolve()}"]


def test_a_report_off_the_published_scale_says_so_and_says_how_to_get_sac_curves(smoke):
    _, index, _ = smoke
    report = (index.parent / "report.md").read_text()
    assert ("These numbers are at N = 10, M = 4, B = 1,000, not at the scale of Table 1 of the paper (N = 10,000, "
            "M = 500, B = 100,000)") in report
    assert "sac.enabled=true`" in report and "SAC was not trained in this run" in report
    assert ("W₂ to SAC's policy was not computed for this report: it needs a trained SAC actor for each task"
            in report)  # the proposed metric says why it is missing
    assert 'class="banner"' in index.read_text()


def test_a_second_run_only_hits_the_cache(smoke, caplog):
    cfg, _, _ = smoke
    with caplog.at_level("DEBUG", logger="taskcomplexity"):
        run_study(cfg)
    assert "computed:" not in caplog.text
    assert caplog.text.count("cache hit") >= 7
    assert "cache hit: verdict" in caplog.text and re.search(r"verdict +cache hit: ", caplog.text)


def test_two_runs_whose_numbers_differ_keep_two_reports_and_the_index_lists_both(smoke):
    cfg, index, _ = smoke
    reports = Path(cfg.paths.outputs) / "reports"
    other = cfg.copy()
    with open_dict(other):
        other.metrics.bins = 500
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("builtins.print", lambda *a, **k: None)
        second = run_study(other)
    assert second.parent != index.parent and second.parent.parent == index.parent.parent
    assert index.is_file() and second.is_file()  # the first report is kept
    assert "B = 500" in (second.parent / "report.md").read_text()
    assert "B = 1,000" in (index.parent / "report.md").read_text()
    listing = (reports / "index.html").read_text()
    assert "N = 10, M = 4, B = 500; no SAC" in listing  # SAC is off in this study: its index says so
    assert f"seven_tasks-smoke/{index.parent.name}/index.html" in listing
    assert f"seven_tasks-smoke/{second.parent.name}/index.html" in listing
    latest = (reports / "seven_tasks-smoke" / "index.html").read_text()
    assert f'url={second.parent.name}/index.html"' in latest  # the stable link opens the latest run
    assert run_study(cfg) == index  # the first run again: its own directory, rebuilt, not a third


def judged_without_sac() -> set[str]:
    """The judged stages a study computes with SAC off: those that read no SAC output, at any depth (the stage
    records' inputs)."""
    records = {stage.name: stage for stage in CHAIN}

    def reads_sac(name: str) -> bool:
        return name == SAC or any(reads_sac(source) for source in records[name].inputs)

    return {name for name in judged_stages() if not reads_sac(name)}


def test_the_verdict_entry_point_writes_a_row_for_every_metric_and_relation(smoke):
    cfg, index, _ = smoke
    artefact = study_artefacts(read_plan(cfg)).verdict
    verdict = pd.read_parquet(artefact.file("verdict.parquet"))
    study = study_from(cfg)
    # SAC off: no trained actor, so the stages that read SAC's output have no values; the others judge every relation
    judged = [m.name for m in DEFAULT_REGISTRY if m.stage in judged_without_sac()]
    assert {"metrics", "diagnostics", "primitives"} <= judged_without_sac()
    assert len(verdict) == len(judged) * len(study.relations)
    assert set(zip(verdict["metric"], verdict["easier"], verdict["harder"], strict=True)) == {
        (m, r.easier, r.harder) for m in judged for r in study.relations}
    # the report read the same artefact: its tidy verdict is the artefact's
    tidy = pd.read_csv(index.parent / "tables" / "verdict_tidy.csv")
    assert tidy["outcome"].tolist() == verdict["outcome"].tolist()


def test_one_writer_per_table(smoke):
    cfg, index, _ = smoke
    outputs = Path(cfg.paths.outputs)
    assert not (outputs / "tables").exists()  # no second copy of Table 1 or the Welch matrices
    assert sorted(p.name for p in index.parent.rglob("table1*")) == ["table1.csv", "table1.md", "table1.tex"]
    assert {p.parent.parent for p in outputs.rglob("table1.md")} <= {r.parent for r in outputs.glob("reports/*/*/run.json")}
    assert (index.parent / "tables" / "welch_pic.csv").is_file()
