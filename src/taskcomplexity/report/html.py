"""One self-contained HTML page: the report's document model and its renderer.

The page opens offline: images are embedded as base64 ``data:`` URIs, the style sheet is inline, and
there is no script, external font or remote resource. The only links are relative ones to the
table files (CSV, LaTeX, Markdown) and figure PDFs written beside the page.
"""

from __future__ import annotations

import base64
import html
import re
from dataclasses import dataclass, field
from pathlib import Path

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

STYLE = """
:root { --ink: #1d1d1d; --muted: #5a5a5a; --rule: #1d1d1d; --agree: #1e7b34; --contradict: #b3261e; }
* { box-sizing: border-box; }
body { font-family: "Iowan Old Style", "Palatino Linotype", Palatino, "Book Antiqua", "URW Palladio L",
       Georgia, "DejaVu Serif", "Times New Roman", serif;
       color: var(--ink); background: #fff; max-width: 60em; margin: 2.5em auto 4em; padding: 0 1.5em;
       font-size: 16px; line-height: 1.5; }
h1 { font-size: 1.9em; line-height: 1.2; margin: 0 0 .2em; font-weight: 600; }
h2 { font-size: 1.3em; margin: 2.2em 0 .6em; padding-bottom: .2em; border-bottom: 1px solid #ccc; font-weight: 600; }
.subtitle { color: var(--muted); margin: 0 0 1.6em; }
.banner { border-left: 4px solid #b9770e; background: #fdf2e0; padding: .5em .9em; margin: -.8em 0 1.6em; }
p { margin: .6em 0; text-align: justify; hyphens: auto; }
.verdict { border-top: 2px solid var(--rule); border-bottom: 2px solid var(--rule); padding: .8em 0 1em;
           margin: 1em 0 2em; }
.verdict .label { font-variant: small-caps; letter-spacing: .05em; color: var(--muted); margin: 0; }
.verdict .lead { font-size: 1.18em; line-height: 1.45; margin: .3em 0 .6em; text-align: left; }
.verdict .more { color: #333; }
.verdict td.text { white-space: normal; }
.methods { background: #f6f5f1; border: 1px solid #dcd9cf; padding: .7em 1.1em; margin: 1.5em 0;
           font-size: .88em; }
.methods h3 { margin: .1em 0 .4em; font-size: 1em; font-variant: small-caps; letter-spacing: .05em; }
.methods dl { display: grid; grid-template-columns: max-content 1fr; gap: .15em 1.2em; margin: 0; }
.methods dt { color: var(--muted); }
.methods dd { margin: 0; }
figure { margin: 1.8em 0; }
figure img { display: block; max-width: 100%; height: auto; margin: 0 auto .4em; }
figcaption, .caption { font-size: .9em; line-height: 1.45; color: #333; }
figcaption b, .caption b { color: var(--ink); }
.files { font-size: .8em; color: var(--muted); }
.files a { color: var(--muted); }
.table { margin: 1.6em 0; }
.table .caption { margin-bottom: .4em; }
.scroll { overflow-x: auto; }
table { border-collapse: collapse; border-top: 1.5px solid var(--rule); border-bottom: 1.5px solid var(--rule);
        font-size: .8em; font-variant-numeric: tabular-nums; margin: 0 auto .3em; }
thead th { border-bottom: 1px solid var(--rule); font-weight: 600; vertical-align: bottom; }
th, td { padding: .22em .6em; text-align: right; white-space: nowrap; }
th { white-space: normal; min-width: 3.2em; }
.text { text-align: left; }
table.wrap td { white-space: normal; min-width: 5.5em; }
.symbol { text-align: center; }
tbody tr:nth-child(even) { background: #fafafa; }
td.agree { color: var(--agree); font-weight: 600; }
td.contradict { color: var(--contradict); font-weight: 600; }
td.ns { color: #8a8a8a; }
td.uninformative { color: #b9770e; }
footer { margin-top: 3em; font-size: .8em; color: var(--muted); border-top: 1px solid #ccc; padding-top: .6em; }
"""


def data_uri(path: Path) -> str:
    """The PNG at ``path`` as a ``data:image/png;base64,…`` URI."""
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


def _links(links: tuple[str, ...]) -> str:
    if not links:
        return ""
    items = " · ".join(f'<a href="{html.escape(link)}">{html.escape(Path(link).suffix.lstrip("."))}</a>'
                       for link in links)
    return f'<div class="files">files: {items}</div>'


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


def table_html(table: pd.DataFrame, cell_titles: pd.DataFrame | None = None, *, wrap: bool = False) -> str:
    """A DataFrame of text as an HTML table with thin rules.

    Columns of words are left-aligned, numbers right-aligned, outcome marks centred; an outcome cell
    (agree, contradict, not significant, ✓, ✗, –, yes, no) gets a colour class.
    """
    cells = [[_cell_text(v) for v in row] for row in table.itertuples(index=False)]
    kinds = [_column_kind([row[j] for row in cells]) for j in range(table.shape[1])]
    head = "".join(f'<th class="{kind}">{html.escape(str(c))}</th>' for c, kind in zip(table.columns, kinds,
                                                                                      strict=True))
    body = []
    for i, row in enumerate(cells):
        parts = []
        for j, text in enumerate(row):
            classes = [kinds[j]] + ([OUTCOME_CLASSES[text]] if text in OUTCOME_CLASSES else [])
            title = ""
            if cell_titles is not None:
                tip = cell_titles.iat[i, j]
                title = f' title="{html.escape(str(tip))}"' if isinstance(tip, str) and tip else ""
            parts.append(f'<td class="{" ".join(classes)}"{title}>{html.escape(text)}</td>')
        body.append("<tr>" + "".join(parts) + "</tr>")
    opening = '<table class="wrap">' if wrap else "<table>"
    return f"{opening}<thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _block(block: Paragraph | FigureBlock | TableBlock) -> str:
    if isinstance(block, Paragraph):
        return f"<p>{html.escape(block.text)}</p>"
    if isinstance(block, FigureBlock):
        images = "".join(
            f'<img src="{data_uri(path)}" alt="Figure {block.number}: {html.escape(block.title)}">'
            for path in block.images
        )
        return (
            f'<figure id="figure-{block.number}">{images}<figcaption><b>Figure {block.number}.</b> '
            f"<b>{html.escape(block.title)}</b> {html.escape(block.caption)}{_links(block.links)}"
            "</figcaption></figure>"
        )
    return (
        f'<div class="table" id="table-{block.number}"><div class="caption"><b>Table {block.number}.</b> '
        f"<b>{html.escape(block.title)}</b> {html.escape(block.caption)}</div>"
        f'<div class="scroll">{table_html(block.table, block.cell_titles, wrap=block.wrap)}</div>'
        f"{_links(block.links)}</div>"
    )


def render_html(document: Document) -> str:
    """The complete page of ``document`` as one HTML string."""
    lead, more = document.headline[:2], document.headline[2:]
    headline = (
        '<section class="verdict"><p class="label">the verdict</p>'
        f'<p class="lead">{html.escape(" ".join(lead))}</p>'
        + (f'<p class="more">{html.escape(" ".join(more))}</p>' if more else "")
        + "".join(_block(b) for b in document.headline_blocks)
        + "</section>"
    )
    methods = "".join(f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in document.methods)
    sections = "".join(
        f"<section><h2>{i}. {html.escape(s.title)}</h2>{''.join(_block(b) for b in s.blocks)}</section>"
        for i, s in enumerate(document.sections, start=1)
    )
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{html.escape(document.title)}</title><style>{STYLE}</style></head><body>"
        f"<header><h1>{html.escape(document.title)}</h1>"
        f'<p class="subtitle">{html.escape(document.subtitle)}</p>'
        + (f'<p class="banner">{html.escape(document.banner)}</p>' if document.banner else "")
        + "</header>"
        f'{headline}<aside class="methods"><h3>methods</h3><dl>{methods}</dl></aside>{sections}'
        "<footer>Generated by taskcomplexity. Tables as CSV, LaTeX and Markdown and figures as PDF are in "
        "tables/ and figures/ beside this page; report.md holds the same text.</footer>"
        "</body></html>\n"
    )


def write_html(document: Document, path: Path) -> Path:
    """Write the page of ``document`` to ``path`` (UTF-8) and return ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(render_html(document), encoding="utf-8")
    return path
