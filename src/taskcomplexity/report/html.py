"""One self-contained HTML page: the report's document model and its renderer.

The page is the jinja2 template ``templates/report.html.j2`` (shipped with the package) rendered with the
document; this module holds the document model and what the template cannot say simply (a column's kind, a
cell's colour class, an image as a data URI). The page opens offline: images are embedded as base64 ``data:``
URIs, the style sheet is inline, and there is no script, external font or remote resource. The only links are
relative ones to the table files (CSV, LaTeX, Markdown) and figure PDFs written beside the page.
"""

from __future__ import annotations

import base64
import functools
import re
from dataclasses import dataclass, field
from pathlib import Path

import jinja2
import pandas as pd

from taskcomplexity.report.outcomes import OUTCOME_DISPLAY, UNKNOWN_MARK


@dataclass(frozen=True)
class Paragraph:
    """A paragraph of plain text (escaped on output)."""

    text: str


@dataclass(frozen=True)
class FigureBlock:
    """A numbered figure.

    Attributes
    ----------
    number : int
        Figure number.
    title : str
        Bold lead of the caption.
    caption : str
        What the figure shows and what to look at.
    images : tuple of Path
        PNG files, embedded in order (panels of one figure).
    links : tuple of str
        Relative paths of the files behind the figure (e.g. PDFs), linked under the caption.
    """

    number: int
    title: str
    caption: str
    images: tuple[Path, ...]
    links: tuple[str, ...] = ()


@dataclass(frozen=True)
class TableBlock:
    """A numbered table.

    Attributes
    ----------
    number : int
        Table number.
    title, caption : str
        Bold lead and caption, shown above the table.
    table : pandas.DataFrame
        Cells already formatted as text; the index is not shown.
    links : tuple of str
        Relative paths of the table's files (CSV, LaTeX, Markdown).
    cell_titles : pandas.DataFrame, optional
        Tooltip text of each cell (same shape as ``table``), e.g. the values behind an outcome.
    wrap : bool
        Let cells wrap at spaces (for wide matrices of "statistic (p)" cells).
    """

    number: int
    title: str
    caption: str
    table: pd.DataFrame
    links: tuple[str, ...] = ()
    cell_titles: pd.DataFrame | None = None
    wrap: bool = False


@dataclass(frozen=True)
class Section:
    """A titled section of blocks."""

    title: str
    blocks: tuple[Paragraph | FigureBlock | TableBlock, ...]


@dataclass(frozen=True)
class Document:
    """The whole report.

    Attributes
    ----------
    title, subtitle : str
        Page title and the line under it.
    headline : tuple of str
        The verdict in words; the first sentences are set large.
    headline_blocks : tuple
        Blocks shown in the verdict box after the words (the verdict tables).
    methods : tuple of (str, str)
        The methods box: (what, value) pairs.
    sections : tuple of Section
        The results, in order.
    banner : str or None
        A warning shown under the title (e.g. numbers not at the scale of the study's published table).
    """

    title: str
    subtitle: str
    headline: tuple[str, ...]
    headline_blocks: tuple[Paragraph | FigureBlock | TableBlock, ...]
    methods: tuple[tuple[str, str], ...]
    sections: tuple[Section, ...] = field(default_factory=tuple)
    banner: str | None = None


@dataclass(frozen=True)
class Cell:
    """A table cell as shown: its text, its CSS classes and its tooltip (empty: none)."""

    text: str
    classes: tuple[str, ...]
    title: str = ""


@dataclass(frozen=True)
class TableView:
    """A table as the page's ``table`` macro draws it: header cells, body rows, the table's CSS classes."""

    columns: tuple[Cell, ...]
    rows: tuple[tuple[Cell, ...], ...]
    classes: tuple[str, ...] = ()


OUTCOME_CLASSES = {
    **{outcome: shown.css for outcome, shown in OUTCOME_DISPLAY.items()},
    **{shown.mark: shown.css for shown in OUTCOME_DISPLAY.values()},
    UNKNOWN_MARK: "ns",
    "yes": "agree",
    "no": "contradict",
}
"""Cell text that gets a colour class (verdict outcomes, their marks, and a survival table's yes/no)."""

MARKS = frozenset({shown.mark for shown in OUTCOME_DISPLAY.values()} | {UNKNOWN_MARK})
"""One-character outcome marks; a column of them is centred."""


def data_uri(path: Path) -> str:
    """The PNG at ``path`` as a ``data:image/png;base64,…`` URI."""
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


_LETTERS = re.compile(r"[A-DF-Za-df-z]")
"""Letters other than the exponent ``e``: a cell containing one is text (left-aligned), else a number."""


def _is_text(value: str) -> bool:
    return bool(_LETTERS.search(value))


def _column_kind(values: list[str]) -> str:
    """``symbol`` (outcome marks), ``text`` (left-aligned) or ``number`` (right-aligned)."""
    filled = [v for v in values if v]
    if filled and all(v in MARKS for v in filled):
        return "symbol"
    if filled and sum(_is_text(v) for v in filled) * 2 >= len(filled):
        return "text"
    return "number"


def _cell_text(value: object) -> str:
    return "" if value is None or (isinstance(value, float) and value != value) else str(value)


def table_view(table: pd.DataFrame, cell_titles: pd.DataFrame | None = None, *, wrap: bool = False) -> TableView:
    """What the page shows of a DataFrame of text: each column's kind and each cell's text, classes and tooltip.

    Columns of words are ``text`` (left-aligned), numbers ``number`` (right-aligned), outcome marks ``symbol``
    (centred); an outcome cell (agree, contradict, not significant, ✓, ✗, –, yes, no) gets its colour class.
    """
    texts = [[_cell_text(v) for v in row] for row in table.itertuples(index=False)]
    kinds = [_column_kind([row[j] for row in texts]) for j in range(table.shape[1])]
    rows = []
    for i, row in enumerate(texts):
        cells = []
        for j, text in enumerate(row):
            tip = cell_titles.iat[i, j] if cell_titles is not None else None
            cells.append(Cell(text, (kinds[j], *((OUTCOME_CLASSES[text],) if text in OUTCOME_CLASSES else ())),
                              tip if isinstance(tip, str) else ""))
        rows.append(tuple(cells))
    columns = tuple(Cell(str(c), (kind,)) for c, kind in zip(table.columns, kinds, strict=True))
    return TableView(columns, tuple(rows), ("wrap",) if wrap else ())


def table_html(table: pd.DataFrame, cell_titles: pd.DataFrame | None = None, *, wrap: bool = False) -> str:
    """A DataFrame of text as an HTML table with thin rules (the page's ``table`` macro on :func:`table_view`)."""
    return str(_environment().get_template("table.html.j2").module.table(table_view(table, cell_titles, wrap=wrap)))


def render_html(document: Document) -> str:
    """The complete page of ``document`` as one HTML string (the package's ``templates/report.html.j2``)."""
    return _environment().get_template("report.html.j2").render(document=document)


def write_html(document: Document, path: Path) -> Path:
    """Write the page of ``document`` to ``path`` (UTF-8) and return ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(render_html(document), encoding="utf-8")
    return path


@functools.cache
def _environment() -> jinja2.Environment:
    """The package's templates, with the tests (``paragraph``, ``figure``) and filters (``data_uri``, ``suffix``,
    ``table_view``) the page uses."""
    environment = jinja2.Environment(loader=jinja2.PackageLoader("taskcomplexity.report", "templates"),
                                     autoescape=True, trim_blocks=True, lstrip_blocks=True,
                                     keep_trailing_newline=True, undefined=jinja2.StrictUndefined)
    environment.tests.update(paragraph=lambda b: isinstance(b, Paragraph), figure=lambda b: isinstance(b, FigureBlock))
    environment.filters.update(
        data_uri=data_uri, suffix=lambda link: Path(link).suffix.lstrip("."),
        table_view=lambda b: table_view(b.table, b.cell_titles, wrap=b.wrap))
    return environment
