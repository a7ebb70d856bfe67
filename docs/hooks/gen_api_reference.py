"""Write the Python API reference (``reference/api/``): one page per public module, rendered by mkdocstrings.

docs/hooks/gen_reference.py writes these pages at every build. Every module of the packages below gets a page holding
``::: taskcomplexity.<module>`` (private modules, ``_name.py``, are left out), and each package a page with
its own docstring; ``SUMMARY.md`` gives literate-nav the order. A module added to a package appears in the
reference without an edit here.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "src" / "taskcomplexity"
OUT = "reference/api"
# The library, in the order the data flows (config → task → returns → metrics → verdict → report), then the
# top-level modules the packages share. The entry points (commands/, cli.py) are in reference/commands.md.
PACKAGES = ["tasks", "policies", "rwg", "metrics", "verdict", "rl", "stages", "study", "report"]
MODULES = ["study_data", "seeding", "config", "errors", "progress"]


ROLE = re.compile(r":[a-z]+:`(?P<tilde>~?)\.?(?P<target>[^`]+)`")


def _summary_line(path: Path) -> str:
    """The first paragraph of a module's docstring, as one table cell of the overview page."""
    docstring = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    paragraph = " ".join(docstring.strip().split("\n\n")[0].split())

    def code(match: re.Match) -> str:
        target = match["target"]
        return f"`{target.rsplit('.', 1)[-1] if match['tilde'] else target}`"

    return ROLE.sub(code, paragraph).replace("``", "`").replace("|", "\\|")


def _own_members(path: Path) -> list[str]:
    """The public names a module defines itself (functions, classes, assignments), in source order."""
    names = []
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            names += [target.id for target in node.targets if isinstance(target, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
    return [name for name in names if not name.startswith("_")]


def _modules(package: Path) -> list[Path]:
    """A package's public modules, subpackages' included, in alphabetical order by dotted name."""
    found = []
    for path in sorted(package.rglob("*.py")):
        parts = path.relative_to(package).with_suffix("").parts
        if any(part.startswith("_") and part != "__init__" for part in parts):
            continue
        found.append(path)
    return found


def pages() -> dict[str, str]:
    """Every page of the API reference by path under the docs directory, ``SUMMARY.md`` and the index included."""
    out: dict[str, str] = {}
    summary = ["* [Overview](index.md)"]
    overview = ["# Python API", "",
                "Generated at every build from the docstrings of `src/taskcomplexity/` by mkdocstrings: one page "
                "per module. The entry points are in [Commands](../commands.md).", "",
                "| package or module | what it holds |", "|---|---|"]
    for package in PACKAGES:
        summary.append(f"* [{package}]({package}/index.md)")
        init = SOURCE / package / "__init__.py"
        overview.append(f"| [`taskcomplexity.{package}`]({package}/index.md) | {_summary_line(init)} |")
        for path in _modules(SOURCE / package):
            parts = path.relative_to(SOURCE).with_suffix("").parts
            dotted = ".".join(("taskcomplexity", *parts)).removesuffix(".__init__")
            if path.name == "__init__.py":  # its own definitions; what it re-exports has its module's page
                page = "/".join(parts[:-1]) + "/index.md"
                options = f"    options:\n      members: {_own_members(path) or 'false'}\n"
            else:
                page = "/".join(parts) + ".md"
                options = ""
            out[f"{OUT}/{page}"] = f"::: {dotted}\n{options}"
            if page != f"{package}/index.md":  # a module, or a subpackage's page heading its modules
                names = parts[1:-1] if path.name == "__init__.py" else parts[1:]
                summary.append(f"{'    ' * len(names)}* [{names[-1]}]({page})")
    summary.append("* Shared modules")
    for module in MODULES:
        out[f"{OUT}/{module}.md"] = f"::: taskcomplexity.{module}\n"
        summary.append(f"    * [{module}]({module}.md)")
        overview.append(f"| [`taskcomplexity.{module}`]({module}.md) | {_summary_line(SOURCE / f'{module}.py')} |")
    out[f"{OUT}/index.md"] = "\n".join(overview) + "\n"
    out[f"{OUT}/SUMMARY.md"] = "\n".join(summary) + "\n"
    return out
