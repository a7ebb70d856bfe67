"""A Griffe extension: the docstrings' Sphinx roles (``:func:`~taskcomplexity.metrics.pic.pic```) become links.

The library's docstrings are NumPy-style and cross-reference with Sphinx roles (``:class:``, ``:func:``,
``:meth:``, ``:mod:``, ``:data:``, ``:attr:``), which mkdocstrings does not read. Before the docstrings are
parsed, each role becomes an *optional* mkdocs-autorefs reference: a link when its target is rendered in the
API reference, plain code otherwise (a private helper, another library's object), never a build warning.
A target is resolved the way Sphinx does: a dotted ``taskcomplexity.…`` path as it is, a short name in the
scope of the object whose docstring holds it (its module, its class). ``~`` shows the last component only.

Whether each ``taskcomplexity.…`` target exists is a test (``tests/test_docstring_references.py``), not this
extension's concern: the site builds whatever the docstrings say, and the test names the stale references.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|obj|exc|const):`(?P<target>[^`]+)`")


def _identifier(obj: griffe.Object, target: str) -> str:
    """The canonical path of ``target`` as seen from ``obj``'s docstring (``target`` itself if unresolved)."""
    target = target.lstrip(".")
    if target.startswith("taskcomplexity."):
        path = target
    else:
        first, _, rest = target.partition(".")
        try:
            path = obj.resolve(first) if first not in obj.members else obj.members[first].path
        except (griffe.NameResolutionError, AttributeError):
            return target
        path = f"{path}.{rest}" if rest else path
    try:
        found = obj.modules_collection[path]
        return found.final_target.path if found.is_alias else found.path
    except (KeyError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return target  # not loaded: another library's object, or a name Griffe cannot follow


def convert(obj: griffe.Object, text: str) -> str:
    """``text`` with every Sphinx role replaced by an optional autorefs reference."""

    def replace(match: re.Match) -> str:
        target = match["target"].strip()
        short = target.startswith("~")
        target = target.lstrip("~")
        title = target.rsplit(".", 1)[-1] if short else target
        identifier = html.escape(_identifier(obj, target), quote=True)
        return f'<autoref identifier="{identifier}" optional><code>{html.escape(title)}</code></autoref>'

    return ROLE.sub(replace, text)


def _objects(obj: griffe.Object):
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from _objects(member)


class SphinxRoles(griffe.Extension):
    """Rewrites the Sphinx roles of every docstring of a loaded package (see the module docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        for obj in _objects(pkg):
            if obj.docstring is not None and ":" in obj.docstring.value:
                obj.docstring.value = convert(obj, obj.docstring.value)
