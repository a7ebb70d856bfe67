"""`pipelines/study.py experiment=smoke`: the whole chain from a composed config to the report."""

from __future__ import annotations

import re
from pathlib import Path

from taskcomplexity.pipeline.chain import run_study


def test_smoke_study_writes_a_self_contained_report_and_says_where(compose_config, capsys):
    cfg = compose_config("experiment=smoke", "sac.enabled=false")
    index = run_study(cfg)
    assert index == Path(cfg.paths.outputs) / "reports" / "seven_tasks-smoke" / "index.html"
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
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"Report: {index.resolve()}"


def test_a_second_run_only_hits_the_cache(compose_config, caplog):
    cfg = compose_config("experiment=smoke", "sac.enabled=false")
    run_study(cfg)
    caplog.clear()
    with caplog.at_level("INFO"):
        run_study(cfg)
    assert "computed:" not in caplog.text
    assert caplog.text.count("cache hit") >= 7
