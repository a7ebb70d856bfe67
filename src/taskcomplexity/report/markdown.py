"""``report.md``: the document's text in Markdown, figures linked (PNG) and tables inline."""

from __future__ import annotations

from taskcomplexity.report.html import Document, FigureBlock, Paragraph


def _block(b) -> list[str]:
    if isinstance(b, Paragraph):
        return [b.text, ""]
    if isinstance(b, FigureBlock):
        images = [f"![Figure {b.number}]({p.parent.name}/{p.name})" for p in b.images]
        return [*images, "", f"**Figure {b.number}. {b.title}** {b.caption}", ""]
    return [f"**Table {b.number}. {b.title}** {b.caption}", "", b.table.to_markdown(index=False), ""]


def render_markdown(document: Document) -> str:
    """The whole document as Markdown."""
    lines = [f"# {document.title}", "", f"*{document.subtitle}*", ""]
    if document.banner:
        lines += [f"> **Note.** {document.banner}", ""]
    lines += ["## The verdict", "", " ".join(document.headline), ""]
    for b in document.headline_blocks:
        lines += _block(b)
    lines += ["## Methods", ""] + [f"- **{k}**: {v}" for k, v in document.methods] + [""]
    for i, section in enumerate(document.sections, start=1):
        lines += [f"## {i}. {section.title}", ""]
        for b in section.blocks:
            lines += _block(b)
    return "\n".join(lines)
