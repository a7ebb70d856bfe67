"""Every study report kept, one directory per run identity, and the index page that finds them.

A study's report goes to ``<paths.outputs>/reports/<name>/<run id>/`` (``name``: ``<study.name>[-<tag>]``). The run id
is a digest of what the report shows: the verdict's key, which holds the key of every artefact the verdict judged
(RWG, metrics, diagnostics, the SAC curves' content and the stages built on SAC), and the report's title. Two runs
whose numbers differ (another N, M or B, SAC on or off, another prior) get two directories; rerunning one run
rebuilds its own directory with the same numbers. Beside the runs::

    reports/index.html           every kept report: study, budget, date, the headline's first sentence, a link
    reports/<name>/index.html    the latest run of <name> (a redirect: a stable link)
    reports/<name>/<run id>/     one report (index.html, report.md, figures/, tables/, summary.json, run.json)

``summary.json`` is what the report says (written by :func:`write_summary` when the report is built); ``run.json`` is
where it came from (the run's name, its overrides, the verdict's key, when it was built; :func:`keep_run`). The
index pages are rebuilt from those files alone, so a report directory copied in from elsewhere is listed too.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from taskcomplexity.report.budget import Recommendation

SUMMARY = "summary.json"
"""The report's own account of itself, in its directory: title, budget, headline."""

RUN = "run.json"
"""Where the report came from, in its directory: run name, overrides, verdict key, build time."""

INDEX = "index.html"


def run_id(verdict_key: str, title: str) -> str:
    """The directory name of a report: 12 hex digits of the digest of the verdict's key and the report's title."""
    return hashlib.sha256(json.dumps([verdict_key, title]).encode()).hexdigest()[:12]


def run_directory(reports: Path, name: str, verdict_key: str, title: str) -> Path:
    """``reports/<name>/<run id>``: the report's directory (not created)."""
    return reports / name / run_id(verdict_key, title)


def write_summary(out_dir: Path, *, title: str, headline: Sequence[str], tasks: int, policies: str, episodes: str,
                  bins: int, sac: bool, next_budget: dict | None = None) -> None:
    """Write the report's ``summary.json``: its title, the study's size (``tasks``; ``policies`` and ``episodes``
    as printed, e.g. ``"1,000"`` or ``"100 and 1,000"``; ``bins``), whether it holds SAC curves, its headline
    sentences (plain text) and the next budget it recommends with the relations that budget sizes
    (:meth:`~taskcomplexity.report.budget.NextBudget.record`; None without one), which the run at that budget
    re-checks."""
    summary = {"title": title, "tasks": tasks, "policies": policies, "episodes": episodes, "bins": bins, "sac": sac,
               "headline": list(headline), "next_budget": next_budget}
    (out_dir / SUMMARY).write_text(json.dumps(summary, indent=1), encoding="utf-8")


def keep_run(out_dir: Path, *, name: str, overrides: Sequence[str], verdict_key: str,
             built: dt.datetime | None = None) -> Path:
    """Record the run in its report directory (``run.json``), then rebuild the index pages of the reports root
    (``out_dir``'s grandparent); return the root's ``index.html``."""
    built = built or dt.datetime.now().astimezone()
    record = {"name": name, "run": out_dir.name, "overrides": list(overrides), "verdict_key": verdict_key,
              "built": built.isoformat(timespec="seconds")}
    (out_dir / RUN).write_text(json.dumps(record, indent=1), encoding="utf-8")
    return write_index(out_dir.parent.parent)


@dataclass(frozen=True)
class KeptReport:
    """One kept report, as its ``summary.json`` and ``run.json`` describe it."""

    directory: Path
    name: str
    built: dt.datetime
    overrides: tuple[str, ...]
    verdict_key: str
    summary: dict

    @property
    def first_sentence(self) -> str:
        headline = self.summary.get("headline") or [""]
        return headline[0]

    @property
    def budget(self) -> str:
        s = self.summary
        if not s:
            return ""
        sac = "SAC curves" if s.get("sac") else "no SAC"
        return f"{s['tasks']} tasks, N = {s['policies']}, M = {s['episodes']}, B = {s['bins']:,}; {sac}"


def kept_reports(reports: Path, pattern: str = f"*/*/{RUN}") -> list[KeptReport]:
    """Every report under ``reports`` that has a ``run.json`` (found by ``pattern``), newest first (an unreadable
    record is skipped: a report being written by another run, or a file edited by hand)."""
    kept = []
    for record in reports.glob(pattern):
        try:
            run = json.loads(record.read_text(encoding="utf-8"))
            summary_file = record.parent / SUMMARY
            summary = json.loads(summary_file.read_text(encoding="utf-8")) if summary_file.is_file() else {}
            kept.append(KeptReport(record.parent, run["name"], dt.datetime.fromisoformat(run["built"]),
                                   tuple(run.get("overrides", ())), run.get("verdict_key", ""), summary))
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return sorted(kept, key=lambda r: r.built, reverse=True)


def earlier_recommendations(out_dir: Path) -> list[Recommendation]:
    """The next budgets that the other kept reports of the same run name (``out_dir``'s siblings) recommended,
    newest first, as :class:`~taskcomplexity.report.budget.Recommendation` (a report without one is left out)."""
    from taskcomplexity.report.budget import Recommendation

    out_dir = Path(out_dir).resolve()
    siblings = kept_reports(out_dir.parent, f"*/{RUN}") if out_dir.parent.is_dir() else []
    return [Recommendation(r.built.strftime("%Y-%m-%d %H:%M"), r.summary["next_budget"]) for r in siblings
            if r.directory.resolve() != out_dir and isinstance(r.summary.get("next_budget"), dict)]


def write_index(reports: Path) -> Path:
    """Rebuild ``reports/index.html`` (every kept report) and each ``reports/<name>/index.html`` (a redirect to the
    latest run of that name); return the former. Each page is written to a temporary file and renamed into
    place, so a concurrent run never leaves a half-written page."""
    from jinja2 import Environment, PackageLoader

    kept = kept_reports(reports)
    environment = Environment(loader=PackageLoader("taskcomplexity.report", "templates"),
                              autoescape=True, trim_blocks=True, lstrip_blocks=True)
    names: dict[str, list[KeptReport]] = {}
    for report in kept:
        names.setdefault(report.name, []).append(report)
    page = environment.get_template("runs.html.j2").render(
        names=names, relative=lambda r: r.directory.relative_to(reports).as_posix())
    _replace(reports / INDEX, page)
    latest = environment.get_template("latest.html.j2")
    for name, runs in names.items():
        _replace(reports / name / INDEX, latest.render(name=name, target=f"{runs[0].directory.name}/{INDEX}"))
    return reports / INDEX


def _replace(path: Path, text: str) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)
