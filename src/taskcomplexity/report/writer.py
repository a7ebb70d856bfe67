"""Numbered figure and table blocks: each written once under the report's ``figures/`` and ``tables/``.

A figure with nothing to show is not drawn: one line stands where it would be, saying what is left out and
why (:func:`left_out`), and takes no number, so the figures drawn stay numbered 1, 2, … in page order. A
figure some of whose panels have nothing to show drops them and says so in its caption (:func:`panels_left_out`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from taskcomplexity.report.figures import save_figure
from taskcomplexity.report.format import and_list
from taskcomplexity.report.html import FigureBlock, Paragraph, TableBlock
from taskcomplexity.report.tables import write_table


def left_out(what: str, why: str) -> Paragraph:
    """The line that stands where a figure with nothing to show would be: "The figure of … is left out: why."

    ``what`` names the figure ("the figure of the normalised score against every metric"); ``why`` says what
    the data lack, true of the data ("this report compares 2 tasks, and a correlation needs at least 3").
    """
    return Paragraph(f"{what[:1].upper()}{what[1:]} is left out: {why}.")


def panels_left_out(gaps: Mapping[str, Sequence[str]]) -> str:
    """The caption's sentence on the panels a figure drops: "Left out, with nothing to show: the panels of A
    and B (why); of C (why)." (empty without any). ``gaps``: why → the labels of the panels it empties."""
    parts = [f"of {and_list(labels)} ({why})" for why, labels in gaps.items() if labels]
    if not parts:
        return ""
    panels = "panel" if sum(len(labels) for labels in gaps.values()) == 1 else "panels"
    return f" Left out, with nothing to show: the {panels} " + "; ".join(parts) + "."


@dataclass
class Writer:
    """Writes figures and tables under ``out_dir`` and numbers them in page order."""

    out_dir: Path
    counts: dict[str, int] = field(default_factory=lambda: {"figure": 0, "table": 0})

    @property
    def figures(self) -> Path:
        return self.out_dir / "figures"

    @property
    def tables(self) -> Path:
        return self.out_dir / "tables"

    def _next(self, kind: str) -> int:
        self.counts[kind] += 1
        return self.counts[kind]

    def figure(self, figures: list[tuple[object, str]], title: str, caption: str) -> FigureBlock:
        """Save each (figure, file name) as PNG and PDF; return the numbered block."""
        pngs, links = [], []
        for figure, name in figures:
            png, pdf = save_figure(figure, self.figures, name)
            pngs.append(png)
            links.append(f"figures/{pdf.name}")
        return FigureBlock(self._next("figure"), title, caption, tuple(pngs), tuple(links))

    def table(self, table: pd.DataFrame, name: str, title: str, caption: str,
              titles: pd.DataFrame | None = None, *, wrap: bool = False,
              files: tuple[pd.DataFrame, str] | None = None) -> TableBlock:
        """Write ``table`` (or ``files``: a table and caption for the files only) and return its block."""
        file_table, file_caption = files if files is not None else (table, caption)
        paths = write_table(file_table, self.tables, name, caption=f"{title} {file_caption}")
        return TableBlock(self._next("table"), title, caption, table.astype(str).replace("nan", "–"),
                          tuple(f"tables/{p.name}" for p in paths), titles, wrap=wrap)

    def data(self, table: pd.DataFrame, name: str) -> Path:
        """Write a tidy data table (CSV only, full precision) under ``tables/``."""
        self.tables.mkdir(parents=True, exist_ok=True)
        path = self.tables / f"{name}.csv"
        table.to_csv(path, index=False)
        return path

    def remove_earlier_build(self) -> None:
        """Delete the figure and table files of an earlier build, so that no stale file sits beside the page."""
        for directory, suffixes in ((self.figures, {".png", ".pdf"}), (self.tables, {".md", ".tex", ".csv"})):
            if directory.is_dir():
                for path in directory.iterdir():
                    if path.is_file() and path.suffix in suffixes:
                        path.unlink()
