"""The HTML page: one self-contained file, escaped text, outcome cells coloured, columns aligned by content."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from taskcomplexity.report.html import Document, FigureBlock, Paragraph, Section, TableBlock, render_html, table_html


def png(tmp_path):
    figure = Figure(figsize=(1, 1))
    figure.subplots().plot([0, 1], [0, 1])
    path = tmp_path / "line.png"
    figure.savefig(path, dpi=50)
    return path


def test_images_are_embedded_and_text_is_escaped(tmp_path):
    document = Document(
        title="A < B & C",
        subtitle="sub",
        headline=("First <sentence>.", "Second.", "Details."),
        headline_blocks=(),
        methods=(("N", "1000"),),
        sections=(Section("Results", (Paragraph("x < y"), FigureBlock(1, "Line.", "A line.", (png(tmp_path),)))),),
    )
    page = render_html(document)
    assert "data:image/png;base64," in page
    assert "A &lt; B &amp; C" in page and "First &lt;sentence&gt;." in page
    assert "<script" not in page and "http" not in page.replace('lang="en"', "")
    assert page.index("First &lt;sentence&gt;. Second.") < page.index("Details.")  # the lead is two sentences


def test_outcome_cells_are_coloured_and_columns_align_by_content():
    table = pd.DataFrame({"Relation": ["a < b", "c < d"], "PIC": ["✓", "✗"], "p": ["0.001", "0.2"],
                          "Outcome": ["agree", "not significant"]})
    html = table_html(table)
    assert '<td class="symbol agree">✓</td>' in html and '<td class="symbol contradict">✗</td>' in html
    assert '<th class="text">Relation</th>' in html and '<th class="number">p</th>' in html
    assert '<td class="text ns">not significant</td>' in html


def test_cell_tooltips_and_missing_values():
    table = pd.DataFrame({"x": [np.nan, 1.5]})
    titles = pd.DataFrame({"x": ["", "value 1.5"]})
    html = table_html(table, titles)
    assert '<td class="number"></td>' in html and 'title="value 1.5"' in html


def test_tables_carry_their_number_caption_and_file_links():
    block = TableBlock(3, "Verdict.", "Caption.", pd.DataFrame({"a": ["1"]}), links=("tables/v.csv",))
    document = Document("t", "s", ("h.",), (block,), ())
    page = render_html(document)
    assert '<b>Table 3.</b> <b>Verdict.</b> Caption.' in page
    assert '<a href="tables/v.csv">csv</a>' in page


def test_every_outcome_gets_its_mark_colour_and_legend_from_one_dict():
    from taskcomplexity.report.outcomes import OUTCOME_DISPLAY, legend, mark

    assert [mark(o) for o in ("agree", "contradict", "not significant", "uninformative", "undefined")] == [
        "✓", "✗", "–", "○", "?"]
    text = legend(["uninformative", "agree", "agree"])
    assert text == ("✓ the metric orders the pair as known and the difference is significant; "
                    "○ uninformative: a value equals its null or sits at its ceiling")
    html = table_html(pd.DataFrame({"PIC": [mark("uninformative"), mark("agree")]}))
    assert '<td class="symbol uninformative">○</td>' in html and '<td class="symbol agree">✓</td>' in html
    assert set(OUTCOME_DISPLAY) >= {"agree", "contradict", "not significant", "uninformative", "undefined"}
    # an outcome the dict does not know yet still gets a centred neutral mark and its name in the legend
    assert legend(["agree", "tied"]).endswith("; · tied")
    assert '<td class="symbol ns">·</td>' in table_html(pd.DataFrame({"PIC": [mark("tied"), mark("agree")]}))
