"""Write the configuration reference (``reference/config/``) from the YAML files under ``src/taskcomplexity/conf``.

docs/hooks/gen_reference.py writes these pages at every build, so they cannot drift from the configs: one page per
config group, one section per option, and for every key its dotted path, its value as written and the comment
that documents it. Comments are read from the YAML source itself:

- the comment block at the top of a file (after ``# @package``) describes the option; when the file starts with
  its ``defaults:`` list, the first block at column 0 after it does;
- a comment after a key's value (``key: value  # …``) documents the key, continued by the comment-only lines
  below it that are indented deeper than the key;
- a comment block directly above a key, at the key's indentation, documents it too.

PyYAML's scanner gives the span of every token, so a ``#`` inside a quoted value (a colour ``"#1f5aa6"``) is
never taken for a comment. Run it by hand to print the pages: ``python docs/hooks/gen_config_reference.py``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
CONF = ROOT / "src" / "taskcomplexity" / "conf"
PRIMARY = "config.yaml"
OUT = "reference/config"
SOURCE_URL = "src/taskcomplexity/conf"  # how a file is named on the pages
LONG_VALUE = 160  # characters: a longer list is summarised in the table and shown in the file below it


@dataclass
class Key:
    """One documented key of an option file."""

    path: str
    value: str
    comment: str


@dataclass
class Option:
    """One YAML file of a config group."""

    group: str
    name: str
    description: str
    package: str | None
    defaults: list[tuple[str, str]] = field(default_factory=list)
    keys: list[Key] = field(default_factory=list)
    source: str = ""


class _Comments:
    """The comments of one YAML text, by line: after content (inline) and on lines of their own."""

    def __init__(self, text: str) -> None:
        self.lines = text.splitlines()
        covered: set[int] = set()
        content_end: dict[int, int] = {}
        for token in yaml.scan(text):
            start, end = token.start_mark, token.end_mark
            if start.index == end.index:  # zero-width markers (block start/end, keys)
                continue
            covered.update(range(start.line, end.line + 1))
            content_end[end.line] = max(content_end.get(end.line, 0), end.column)
        self.inline: dict[int, str] = {}
        self.own_line: dict[int, tuple[int, str]] = {}
        for number, line in enumerate(self.lines):
            if number in content_end:
                rest = line[content_end[number]:].strip()
                if rest.startswith("#"):
                    self.inline[number] = rest[1:].strip()
            elif number not in covered and line.strip().startswith("#"):
                indent = len(line) - len(line.lstrip())
                self.own_line[number] = (indent, line.strip()[1:].strip())
        self.used: set[int] = set()

    def take_block(self, first: int, *, indent: int | None = None) -> str:
        """The comment-only lines from ``first`` on (at ``indent`` if given), joined; marks them used."""
        texts, number = [], first
        while number in self.own_line and number not in self.used:
            line_indent, text = self.own_line[number]
            if indent is not None and line_indent != indent:
                break
            texts.append(text)
            self.used.add(number)
            number += 1
        return " ".join(texts)

    def above(self, line: int, indent: int) -> str:
        """The comment block directly above ``line`` at ``indent`` (no blank line between)."""
        first = line
        while first - 1 in self.own_line and first - 1 not in self.used and self.own_line[first - 1][0] == indent:
            first -= 1
        return self.take_block(first, indent=indent) if first < line else ""

    def after(self, line: int, indent: int) -> str:
        """The inline comment on ``line`` and its continuation lines indented deeper than ``indent``."""
        texts = [self.inline[line]] if line in self.inline else []
        number = line + 1
        while number in self.own_line and number not in self.used and self.own_line[number][0] > indent and texts:
            texts.append(self.own_line[number][1])
            self.used.add(number)
            number += 1
        return " ".join(texts)


def _raw(text: str, node: yaml.Node) -> str:
    """The node's source text with its line breaks folded (``null`` for an empty value)."""
    raw = text[node.start_mark.index:node.end_mark.index].strip()
    return " ".join(raw.split()) if raw else "null"


def _is_block(node: yaml.Node) -> bool:
    return isinstance(node, yaml.MappingNode | yaml.SequenceNode) and not node.flow_style


def _sequence_value(text: str, node: yaml.SequenceNode, comments: _Comments) -> tuple[str, str]:
    """A block sequence as a flow list (or a count when long) and its items' comments."""
    items = [_raw(text, item) for item in node.value]
    notes = [comments.after(item.end_mark.line if item.end_mark.column else item.end_mark.line - 1, 0)
             for item in node.value]
    flow = "[" + ", ".join(items) + "]"
    value = flow if len(flow) <= LONG_VALUE else f"{len(items)} entries (in the file below)"
    return value, "; ".join(note for note in notes if note)


def _keys(text: str, node: yaml.MappingNode, comments: _Comments, prefix: str = "") -> list[Key]:
    keys: list[Key] = []
    for key_node, value_node in node.value:
        path = f"{prefix}{key_node.value}"
        line, column = key_node.start_mark.line, key_node.start_mark.column
        parts = [comments.above(line, column)]
        if isinstance(value_node, yaml.MappingNode) and not value_node.flow_style:
            parts.append(comments.after(line, column))
            comment = " ".join(part for part in parts if part)
            if comment:
                keys.append(Key(path, "", comment))
            keys.extend(_keys(text, value_node, comments, prefix=f"{path}."))
            continue
        if isinstance(value_node, yaml.SequenceNode) and not value_node.flow_style:
            value, notes = _sequence_value(text, value_node, comments)
            parts.append("; ".join(part for part in (comments.after(line, column), notes) if part))
        else:
            value = _raw(text, value_node)
            parts.append(comments.after(value_node.end_mark.line, column))
        keys.append(Key(path, value, " ".join(part for part in parts if part)))
    return keys


def _defaults(text: str, node: yaml.SequenceNode, comments: _Comments) -> list[tuple[str, str]]:
    entries = []
    for item in node.value:
        if isinstance(item, yaml.MappingNode):
            (key, value), = item.value
            entry = f"{key.value}: {_raw(text, value)}"
        else:
            entry = _raw(text, item)
        entries.append((entry, comments.after(item.end_mark.line, item.start_mark.column - 2)))
    return entries


def read_option(path: Path, group: str) -> Option:
    """Read one option file: its description, its defaults list and its documented keys."""
    text = path.read_text(encoding="utf-8")
    comments = _Comments(text)
    package = None
    for number, (_, line) in sorted(comments.own_line.items()):
        if line.startswith("@package"):
            package = line.removeprefix("@package").strip()
            comments.used.add(number)
            break
    root = yaml.compose(text)
    option = Option(group=group, name=path.stem, description="", package=package, source=text)
    if root is None:
        return option
    first_key = root.value[0][0].start_mark.line if root.value else len(comments.lines)
    description_end = first_key
    if root.value and root.value[0][0].value == "defaults":
        option.defaults = _defaults(text, root.value[0][1], comments)
        description_end = root.value[1][0].start_mark.line if len(root.value) > 1 else len(comments.lines)
    for number in range(description_end):
        if number in comments.own_line and number not in comments.used and comments.own_line[number][0] == 0:
            option.description = comments.take_block(number, indent=0)
            break
    body = yaml.MappingNode(root.tag, [pair for pair in root.value if pair[0].value != "defaults"])
    option.keys = _keys(text, body, comments)
    return option


def read_groups(conf: Path = CONF) -> dict[str, list[Option]]:
    """Every config group (a folder of YAML files, ``hydra/launcher`` included) and its options."""
    groups: dict[str, list[Option]] = {}
    for path in sorted(conf.rglob("*.yaml")):
        if path.parent == conf:
            continue
        group = path.parent.relative_to(conf).as_posix()
        groups.setdefault(group, []).append(read_option(path, group))
    return groups


# --- Markdown --------------------------------------------------------------------------------------------------

_CODE = re.compile(r"(`[^`]*`)")


def prose(text: str) -> str:
    """A YAML comment as Markdown table text: HTML and table characters escaped outside code spans."""
    pieces = _CODE.split(text)
    for index in range(0, len(pieces), 2):
        piece = pieces[index].replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
        pieces[index] = piece.replace("|", "\\|").replace("[", "\\[").replace("*", "\\*")
    return "".join(pieces)


def code(value: str) -> str:
    """A value as an inline code span (Python-Markdown's tables do not split a row at a ``|`` inside one)."""
    if not value:
        return ""
    fence = "``" if "`" in value else "`"
    return f"{fence}{value}{fence}" if fence == "`" else f"{fence} {value} {fence}"


def page_name(group: str) -> str:
    return group.replace("/", "-") + ".md"


def _defaults_of_primary(conf: Path) -> dict[str, str]:
    """The default option of each group, from the primary config's ``defaults`` list."""
    chosen = {}
    for entry in yaml.safe_load((conf / PRIMARY).read_text(encoding="utf-8")).get("defaults", []):
        if isinstance(entry, dict):
            (key, value), = entry.items()
            chosen[key.removeprefix("override ").strip()] = value
    return chosen


def _key_table(keys: list[Key]) -> list[str]:
    lines = ["| key | value | what it is |", "|---|---|---|"]
    lines += [f"| `{key.path}` | {code(key.value)} | {prose(key.comment)} |" for key in keys]
    return lines


def _composes(option: Option, siblings: set[str]) -> list[str]:
    lines = ["Composes, in order:", ""]
    for entry, comment in option.defaults:
        shown = f"[`{entry}`](#{entry})" if entry in siblings else f"`{entry}`"
        lines.append(f"- {shown}" + (f": {prose(comment)}" if comment else ""))
    return lines


def option_section(option: Option, *, default: bool, siblings: set[str]) -> list[str]:
    """One option's section of its group page."""
    select = f"{option.group}={option.name}"
    lines = [f"## {option.name}", ""]
    if option.description:
        lines += [prose(option.description), ""]
    facts = [f"File `{SOURCE_URL}/{option.group}/{option.name}.yaml`; select it with `{select}`"]
    if default:
        facts.append("the group's default")
    if option.package:
        facts.append(f"package `{option.package}` (its keys are top-level keys)")
    lines += ["; ".join(facts) + ".", ""]
    if option.defaults:
        lines += [*_composes(option, siblings), ""]
    if option.keys:
        lines += [*_key_table(option.keys), ""]
    lines += [f'??? note "{option.name}.yaml"', "", "    ```yaml"]
    lines += [f"    {line}".rstrip() for line in option.source.rstrip("\n").splitlines()]
    lines += ["    ```", ""]
    return lines


def group_page(group: str, options: list[Option], default: str | None) -> str:
    siblings = {option.name for option in options}
    ordered = sorted(options, key=lambda option: (option.name != default, option.name))
    lines = [f"# {group}", "", "Generated from "
             f"`{SOURCE_URL}/{group}/` at every build of this site. Options: "
             + ", ".join(f"[{option.name}](#{option.name})" for option in ordered)
             + (f" (default: `{default}`)." if default else " (no default: select one to use it)."), ""]
    for option in ordered:
        lines += option_section(option, default=option.name == default, siblings=siblings)
    return "\n".join(lines)


def index_page(primary: Option, groups: dict[str, list[Option]], chosen: dict[str, str]) -> str:
    lines = ["# All groups and keys", "",
             "Generated from `src/taskcomplexity/conf/` at every build of this site: every config group, every "
             "option, every key with its value as written and the comment that documents it. "
             "[Configuration](../configuration.md) is the overview.", "",
             f"## {PRIMARY}", "", prose(primary.description), "",
             "| group | default | options |", "|---|---|---|"]
    for group in _group_order(groups, chosen):
        default = chosen.get(group)
        names = ", ".join(f"[`{option.name}`]({page_name(group)}#{option.name})" for option in groups[group])
        lines.append(f"| [`{group}/`]({page_name(group)}) | {code(str(default)) if default else '—'} | {names} |")
    lines += ["", "Its own keys:", "", *_key_table(primary.keys), "",
              f'??? note "{PRIMARY}"', "", "    ```yaml"]
    lines += [f"    {line}".rstrip() for line in primary.source.rstrip("\n").splitlines()]
    lines += ["    ```", ""]
    return "\n".join(lines)


def _group_order(groups: dict[str, list[Option]], chosen: dict[str, str]) -> list[str]:
    first = [group for group in chosen if group in groups]
    return first + sorted(group for group in groups if group not in first)


def fill_from_group(groups: dict[str, list[Option]], chosen: dict[str, str], options: list[Option]) -> None:
    """Give an undocumented key the comment of the same key where its group documents it.

    A key of an option (``sac/quick``'s ``seeds``) takes the comment of the same key in the group's default
    option, else in another option of the group; a key of a global overlay (``experiment/smoke``'s
    ``rwg.policies``) takes the comment of ``policies`` in the ``rwg`` group. The comment is marked with the
    file it comes from.
    """
    documented: dict[str, dict[str, tuple[str, str]]] = {}
    for group, group_options in groups.items():
        ordered = sorted(group_options, key=lambda option: option.name != chosen.get(group))
        table = documented.setdefault(group, {})
        for option in ordered:
            for key in option.keys:
                if key.comment and key.path not in table:
                    table[key.path] = (key.comment, f"{group}/{option.name}")
    for option in options:
        for key in option.keys:
            if key.comment:
                continue
            if option.package == "_global_" or not option.group:
                group, _, rest = key.path.partition(".")
                found = documented.get(group, {}).get(rest)
            else:
                found = documented.get(option.group, {}).get(key.path)
            if found is not None:
                key.comment = f"{found[0]} (from `{found[1]}`)"


def pages(conf: Path = CONF) -> dict[str, str]:
    """Every page of the reference, by path under the docs directory, with its literate-nav summary."""
    groups = read_groups(conf)
    chosen = {group: value for group, value in _defaults_of_primary(conf).items() if value is not None}
    primary = read_option(conf / PRIMARY, "")
    options = [option for group_options in groups.values() for option in group_options]
    fill_from_group(groups, chosen, [primary, *options])
    order = _group_order(groups, chosen)
    out = {f"{OUT}/index.md": index_page(primary, groups, chosen)}
    summary = ["* [All groups and keys](index.md)"]
    for group in order:
        out[f"{OUT}/{page_name(group)}"] = group_page(group, groups[group], chosen.get(group))
        summary.append(f"* [{group}]({page_name(group)})")
    out[f"{OUT}/SUMMARY.md"] = "\n".join(summary) + "\n"
    return out
