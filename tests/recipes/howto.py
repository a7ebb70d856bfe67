"""Follow a how-to page on a scratch copy of the repository: apply the blocks that name a file, in page order.

The convention the pages under ``docs/how-to/`` follow: a fenced code block whose first line is a comment
naming a file, by its path from the repository root, is a change to that file. The rest of the block is:

``# <path>``
    the whole file (created, or replaced);
``# <path>: append``
    appended at the end of the file;
``# <path>: insert after: <line>`` / ``# <path>: insert before: <line>``
    inserted after (before) the one line of the file that reads ``<line>`` (compared without the indentation
    and trailing spaces; it must be there exactly once).

The comment starts with ``#`` whatever the language (Python, YAML). Any other block is not applied: a shell block
(``bash``) prints commands (:func:`commands`), which the recipe test runs on the copy once the blocks are
applied; any other block is an example to read. Each page states, in bold, how many files its recipe touches (``**two files**``): the
recipe test checks that count against the blocks.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest

REPOSITORY = Path(__file__).resolve().parents[2]
HOW_TO = REPOSITORY / "docs" / "how-to"

FENCE = re.compile(r"^```(?P<language>[^\n]*)\n(?P<body>.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
SHELL = ("bash", "sh", "console")
"""The languages of the blocks that print commands."""
TARGET = re.compile(r"#\s+(?P<path>(?:[\w.-]+/)+[\w.-]+\.\w+)(?::\s*(?P<how>.*))?")
HOW = re.compile(r"append|insert (?P<where>after|before):\s*(?P<line>.+)")
HEADING = re.compile(r"^#{2,}\s+(?P<title>.+)$", re.MULTILINE)
COUNT = re.compile(r"\*\*(?P<number>\w+)(?: more)? files?\*\*", re.IGNORECASE)
NUMBERS = {word: n for n, word in enumerate(
    ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten"))}


@dataclass(frozen=True)
class Block:
    """One change a page makes: to ``path`` (from the repository root), ``how`` (``file``, ``append``,
    ``after`` or ``before``), at ``line`` (for an insertion), with ``text``; ``section`` is the page's heading
    above it."""

    path: str
    how: str
    line: str
    text: str
    section: str


def page(name: str) -> str:
    """The text of ``docs/how-to/<name>``."""
    return (HOW_TO / name).read_text(encoding="utf-8")


def blocks(text: str) -> list[Block]:
    """The blocks of a page that change a file, in page order (see the module docstring)."""
    found = []
    headings = [(m.start(), m["title"].strip()) for m in HEADING.finditer(text)]
    for fence in FENCE.finditer(text):
        first, _, rest = fence["body"].partition("\n")
        target = TARGET.fullmatch(first.strip())
        if target is None:
            continue
        how, line = "file", ""
        if target["how"] is not None:
            marker = HOW.fullmatch(target["how"].strip())
            if marker is None:
                raise ValueError(f"block for {target['path']}: unknown marker {target['how']!r} (allowed: "
                                 "append, insert after: <line>, insert before: <line>)")
            how, line = (marker["where"], marker["line"].strip()) if marker["where"] else ("append", "")
        section = next((title for start, title in reversed(headings) if start < fence.start()), "")
        found.append(Block(target["path"], how, line, rest, section))
    return found


def commands(text: str) -> list[tuple[dict[str, str], list[str]]]:
    """The commands a page prints (each line of its shell blocks), in page order: (environment assignments that
    lead the line, the command's words)."""
    found = []
    for fence in FENCE.finditer(text):
        if fence["language"].strip() not in SHELL:
            continue
        for line in fence["body"].splitlines():
            words = shlex.split(line, comments=True)
            env = {}
            while words and re.fullmatch(r"[A-Z_]+=\S*", words[0]):
                name, _, value = words.pop(0).partition("=")
                env[name] = value
            if words:
                found.append((env, words))
    return found


def stated_counts(text: str) -> list[int]:
    """The file counts a page states in bold (``**three files**``, ``**one more file**``), in page order."""
    return [int(m["number"]) if m["number"].isdigit() else NUMBERS[m["number"].lower()] for m in COUNT.finditer(text)]


def touched(chosen: list[Block]) -> list[str]:
    """The files ``chosen`` change, each once, in order."""
    return list(dict.fromkeys(block.path for block in chosen))


def apply(root: Path, chosen: list[Block]) -> list[Path]:
    """Apply ``chosen`` to the copy of the repository at ``root``; returns the files changed, each once."""
    changed: dict[Path, None] = {}
    for block in chosen:
        path = root / block.path
        text = block.text if block.text.endswith("\n") else block.text + "\n"
        if block.how == "file":
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
        elif block.how == "append":
            old = path.read_text(encoding="utf-8")
            path.write_text(old + ("" if old.endswith("\n") else "\n") + text, encoding="utf-8")
        else:
            lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
            at = [i for i, line in enumerate(lines) if line.strip() == block.line]
            if len(at) != 1:
                raise ValueError(f"{block.path}: the line {block.line!r} is there {len(at)} times, not once")
            where = at[0] + (1 if block.how == "after" else 0)
            path.write_text("".join(lines[:where]) + text + "".join(lines[where:]), encoding="utf-8")
        changed[path] = None
    return list(changed)


def skip_if_followed(chosen: list[Block], source: Path = REPOSITORY) -> None:
    """Skip the calling test when ``source`` already holds a file the page creates: the page has been followed in
    this repository, and following it again on a copy would insert its lines twice. The recipe test ran when it
    was followed; a researcher's own metric, stage or family under another name leaves the test running."""
    held = [block.path for block in chosen if block.how == "file" and (source / block.path).exists()]
    if held:
        pytest.skip(f"the repository already holds this page's example ({', '.join(held)}); following the page "
                    "again would declare it twice")


COPIED = ("src", "tests", "conf", "pipelines", "pyproject.toml")
"""What a scratch copy holds, from the repository root (``conf`` only when the root has one)."""
SKIPPED = shutil.ignore_patterns("*.egg-info", ".pytest_cache", ".ruff_cache")
SKIPPED_OUTSIDE_SRC = shutil.ignore_patterns("__pycache__", ".pytest_cache", ".ruff_cache")


def copy_repository(target: Path, source: Path = REPOSITORY) -> Path:
    """Copy the parts of ``source`` that :data:`COPIED` names into ``target`` (a symbolic link, like ``conf``
    pointing into ``src``, stays a link)."""
    target.mkdir(parents=True, exist_ok=True)
    for name in COPIED:
        path = source / name
        if path.is_symlink():
            (target / name).symlink_to(os.readlink(path))
        elif path.is_dir():
            shutil.copytree(path, target / name, symlinks=True,
                            ignore=SKIPPED if name == "src" else SKIPPED_OUTSIDE_SRC)
        elif path.is_file():
            shutil.copy2(path, target / name)
    return target


def environment(root: Path) -> dict[str, str]:
    """The environment of a command run on the copy at ``root``: its sources first on the path; no HYDRA_FULL_ERROR
    (refusals stay one line), no pytest variables of the calling run."""
    env = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR" and not k.startswith("PYTEST_")}
    env["PYTHONPATH"] = str(root / "src")
    return env
