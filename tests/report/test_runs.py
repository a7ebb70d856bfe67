"""Every report kept per run identity, and the index of reports (:mod:`taskcomplexity.report.runs`)."""

from __future__ import annotations

import datetime as dt
import json

from taskcomplexity.report.runs import RUN, keep_run, kept_reports, run_directory, run_id, write_summary


def _report(reports, name, key, title, built, headline="PIC agrees with 2 of 3 relations.", sac=False):
    """A report directory as a study run leaves it: its page, its summary, then its run record (the index)."""
    out = run_directory(reports, name, key, title)
    out.mkdir(parents=True, exist_ok=True)
    (out / "index.html").write_text("<html>report</html>")
    write_summary(out, title=title, headline=[headline, "More."], tasks=7, policies="100", episodes="50",
                  bins=1000, sac=sac)
    return out, keep_run(out, name=name, overrides=["experiment=quick", f"title={title}"], verdict_key=key,
                         built=built)


def test_the_run_id_follows_the_verdict_key_and_the_title_only():
    assert run_id("a" * 16, "T") == run_id("a" * 16, "T")
    assert len({run_id("a" * 16, "T"), run_id("b" * 16, "T"), run_id("a" * 16, "U")}) == 3
    assert len(run_id("a" * 16, "T")) == 12


def test_two_runs_keep_two_reports_listed_newest_first_and_the_stable_link_opens_the_latest(tmp_path):
    reports = tmp_path / "reports"
    morning = dt.datetime(2026, 11, 29, 9, 0, tzinfo=dt.UTC)
    first, index = _report(reports, "mine-quick", "1" * 16, "T", morning)
    second, again = _report(reports, "mine-quick", "2" * 16, "T", morning + dt.timedelta(hours=2),
                            headline="POIC & PIC <disagree>.", sac=True)
    other, _ = _report(reports, "seven_tasks", "3" * 16, "T", morning + dt.timedelta(hours=1))
    assert index == again == reports / "index.html"
    assert first != second and first.is_dir() and second.is_dir()
    assert [r.directory for r in kept_reports(reports)] == [second, other, first]
    page = index.read_text()
    for out in (first, second, other):
        assert f'href="{out.parent.name}/{out.name}/index.html"' in page
    assert "POIC &amp; PIC &lt;disagree&gt;." in page  # escaped, never markup
    assert "7 tasks, N = 100, M = 50, B = 1,000; SAC curves" in page and "2026-11-29 11:00" in page
    assert page.index(second.name) < page.index(first.name)
    latest = (reports / "mine-quick" / "index.html").read_text()
    assert f'url={second.name}/index.html"' in latest and first.name not in latest
    assert f'url={other.name}/index.html"' in (reports / "seven_tasks" / "index.html").read_text()


def test_the_same_run_again_rebuilds_its_own_directory_and_a_broken_record_is_not_listed(tmp_path):
    reports = tmp_path / "reports"
    when = dt.datetime(2026, 11, 29, 9, 0, tzinfo=dt.UTC)
    first, _ = _report(reports, "mine", "1" * 16, "T", when)
    again, _ = _report(reports, "mine", "1" * 16, "T", when + dt.timedelta(days=1))
    assert again == first and len(kept_reports(reports)) == 1
    assert json.loads((first / RUN).read_text())["built"].startswith("2026-11-30")
    broken = reports / "mine" / ("0" * 12)
    broken.mkdir()
    (broken / RUN).write_text("{not json")
    assert [r.directory for r in kept_reports(reports)] == [first]
    assert not list(reports.rglob("*.tmp"))
