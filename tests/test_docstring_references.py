"""The library's words about itself stay true: references in docstrings and comments resolve, and each package's
docstring names every module of its folder.

A docstring or comment that names ``taskcomplexity.x.y`` (a Sphinx role, a backticked path or plain text) names
something that exists: the module imports and each further part is an attribute, so a renamed or moved object
fails here instead of leaving a dead reference (the API pages of the documentation site render such a reference
as plain text, without a link). The same holds for the Sphinx roles that name an object by its short name
(``:func:`pic```): the name is defined in the module, or in the class, that the docstring belongs to.
"""

from __future__ import annotations

import ast
import builtins
import dataclasses
import importlib
import inspect
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "src" / "taskcomplexity"
CONF = SOURCE / "conf"

DOTTED = re.compile(r"\btaskcomplexity(?:\.[A-Za-z_][A-Za-z0-9_]*)+")
ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|obj|exc|const):`~?\.?(?P<target>[^`]+)`")

# Files whose stale references are known and waiting for a fix, each with its reason (a strict xfail: the mark
# fails as soon as the file is right, so it cannot outlive the fix). Empty: every reference resolves.
KNOWN_STALE: dict[str, str] = {}
# Package docstrings known not to name every module of their folder yet (strict, as above).
KNOWN_UNLISTED: dict[str, str] = {}


def _relative(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def python_files() -> list[Path]:
    return sorted(SOURCE.rglob("*.py"))


def docs_and_comments(path: Path) -> list[tuple[int, str, str | None]]:
    """(line, text, enclosing class) of every docstring, string statement and comment of a Python file."""
    text = path.read_text(encoding="utf-8")
    found: list[tuple[int, str, str | None]] = []

    def visit(node: ast.AST, cls: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            if (isinstance(child, ast.Expr) and isinstance(child.value, ast.Constant)
                    and isinstance(child.value.value, str)):
                found.append((child.lineno, child.value.value, cls))
            visit(child, child.name if isinstance(child, ast.ClassDef) else cls)

    visit(ast.parse(text), None)
    for token in tokenize.generate_tokens(io.StringIO(text).readline):
        if token.type == tokenize.COMMENT:
            found.append((token.start[0], token.string, None))
    return found


def yaml_comments(path: Path) -> list[tuple[int, str, str | None]]:
    """(line, comment) of every YAML comment (a ``#`` at the start of a line or after a space)."""
    found = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        match = re.search(r"(?:^|\s)#(.*)$", line)
        if match:
            found.append((number, match.group(1), None))
    return found


def _instance_attribute(cls: type, name: str) -> bool:
    """Whether ``name`` is a field or an attribute a class's instances get (annotated or set on ``self``)."""
    for klass in inspect.getmro(cls):
        if name in getattr(klass, "__annotations__", {}):
            return True
        if dataclasses.is_dataclass(klass) and name in {field.name for field in dataclasses.fields(klass)}:
            return True
        try:
            source = inspect.getsource(klass)
        except (OSError, TypeError):
            continue
        if re.search(rf"\bself\.{re.escape(name)}\s*(?::[^=\n]*)?=", source):
            return True
    return False


def resolve(dotted: str) -> bool:
    """Whether ``dotted`` names a module, or an attribute path below the longest importable module."""
    parts = dotted.split(".")
    obj = None
    for index in range(len(parts), 0, -1):
        name = ".".join(parts[:index])
        try:
            obj = importlib.import_module(name)
        except ModuleNotFoundError as error:
            if error.name is not None and not name.startswith(error.name):
                raise  # a dependency is missing, not the reference
            continue
        break
    if obj is None:
        return False
    for attribute in parts[index:]:
        if hasattr(obj, attribute):
            obj = getattr(obj, attribute)
        elif inspect.isclass(obj) and _instance_attribute(obj, attribute):
            return attribute == parts[-1]  # an instance attribute: nothing further can be checked
        else:
            return False
    return True


def _module_name(path: Path) -> str:
    parts = path.relative_to(SOURCE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _line_of(line: int, text: str, match: re.Match) -> int:
    """The line of a match inside a text that starts on ``line`` (a docstring's line numbers are its own)."""
    return line + text.count("\n", 0, match.start())


def dotted_references(path: Path) -> list[tuple[int, str]]:
    texts = yaml_comments(path) if path.suffix == ".yaml" else docs_and_comments(path)
    return sorted({(_line_of(line, text, match), match.group()) for line, text, _ in texts
                   for match in DOTTED.finditer(text)})


def short_role_targets(path: Path) -> list[tuple[int, str, str | None]]:
    """(line, target, enclosing class) of every Sphinx role whose target is not a ``taskcomplexity.`` path."""
    found = []
    for line, text, cls in docs_and_comments(path):
        for match in ROLE.finditer(text):
            target = match["target"].strip().removesuffix("()")
            if not target.startswith("taskcomplexity."):
                found.append((_line_of(line, text, match), target, cls))
    return found


def resolve_short(module, target: str, cls: str | None) -> bool:
    """Whether a role's short target names something in scope: the module, its class, or an importable path."""
    first, _, rest = target.partition(".")
    scopes = [module]
    if cls is not None and hasattr(module, cls):
        scopes.insert(0, getattr(module, cls))
    for scope in scopes:
        if hasattr(scope, first) or (inspect.isclass(scope) and _instance_attribute(scope, first)):
            obj = getattr(scope, first, None)
            if not rest or obj is None:
                return obj is not None or not rest
            return resolve(f"{getattr(obj, '__module__', '')}.{getattr(obj, '__qualname__', '')}.{rest}"
                           if not inspect.ismodule(obj) else f"{obj.__name__}.{rest}")
    if hasattr(builtins, first):
        return True
    if inspect.ismodule(module) and resolve(f"{module.__name__}.{target}"):
        return True  # a submodule of a package (Sphinx looks in the current module first)
    try:
        return resolve(target)  # another library's object: numpy.random.Generator
    except ModuleNotFoundError:
        return False


SOURCE_FILES = [*python_files(), *sorted(CONF.rglob("*.yaml"))]


def _param(path: Path):
    name = _relative(path)
    marks = [pytest.mark.xfail(strict=True, reason=KNOWN_STALE[name])] if name in KNOWN_STALE else []
    return pytest.param(path, id=name, marks=marks)


@pytest.mark.parametrize("path", [_param(path) for path in SOURCE_FILES])
def test_every_reference_in_docstrings_and_comments_resolves(path):
    stale = [f"{_relative(path)}:{line}: {dotted}" for line, dotted in dotted_references(path) if not resolve(dotted)]
    if path.suffix == ".py":
        module = importlib.import_module(_module_name(path))
        stale += [f"{_relative(path)}:{line}: {target}" for line, target, cls in short_role_targets(path)
                  if not resolve_short(module, target, cls)]
    assert stale == [], "stale references (rename them to what exists):\n" + "\n".join(stale)


def test_the_reference_reader_finds_what_is_written():
    # The checks above are only as good as the reader: a stale path and a live one, in each place a reference
    # can sit, are found and judged.
    assert resolve("taskcomplexity.metrics.pic.pic")
    assert resolve("taskcomplexity.policies.mlp.NetworkSpec")
    assert not resolve("taskcomplexity.policies.NoSuchSpec")
    assert not resolve("taskcomplexity.no_such_module.thing")
    found = {text for _, text, _ in docs_and_comments(SOURCE / "metrics" / "pic.py")}
    assert any("taskcomplexity.metrics.histogram.histogram_terms" in text for text in found)


# --- package docstrings ------------------------------------------------------------------------------------------

PACKAGES = sorted(path.parent for path in SOURCE.rglob("__init__.py"))


def modules_of(package: Path) -> list[str]:
    """The modules of a package's folder: its .py files and its subpackages."""
    names = [path.stem for path in package.glob("*.py") if path.name != "__init__.py"]
    names += [path.name for path in package.iterdir() if (path / "__init__.py").is_file()]
    return sorted(names)


def names_module(docstring: str, name: str) -> bool:
    """Whether a docstring names a module: a line of a Modules list starting with it, a role or a code span."""
    escaped = re.escape(name)
    return bool(re.search(rf"^\s*{escaped}(?:\.py|/)?(?:\s|$)", docstring, flags=re.MULTILINE)
                or re.search(rf":mod:`~?[\w.]*\.?{escaped}`", docstring)
                or re.search(rf"``{escaped}(?:\.py)?``", docstring))


def _package_param(package: Path):
    name = _relative(package / "__init__.py")
    marks = [pytest.mark.xfail(strict=True, reason=KNOWN_UNLISTED[name])] if name in KNOWN_UNLISTED else []
    return pytest.param(package, id=_relative(package), marks=marks)



@pytest.mark.parametrize("package", [_package_param(package) for package in PACKAGES])
def test_each_package_docstring_names_every_module_of_its_folder(package):
    docstring = ast.get_docstring(ast.parse((package / "__init__.py").read_text(encoding="utf-8"))) or ""
    assert [name for name in modules_of(package) if not names_module(docstring, name)] == []


# --- the configuration reference ------------------------------------------------------------------------------


def _config_reference():
    """docs/hooks/gen_config_reference.py, the script the documentation build runs, as a module."""
    import importlib.util
    import sys

    path = ROOT / "docs" / "hooks" / "gen_config_reference.py"
    spec = importlib.util.spec_from_file_location("gen_config_reference", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the file executes
    spec.loader.exec_module(module)
    return module


def _leaf_keys(node, prefix: str = "") -> list[str]:
    """The dotted paths of a composed YAML node's keys, down to the values (a flow mapping is one value)."""
    import yaml

    if not isinstance(node, yaml.MappingNode) or node.flow_style:
        return [prefix.rstrip(".")]
    keys = []
    for key, value in node.value:
        if not (prefix == "" and key.value == "defaults"):
            keys += _leaf_keys(value, f"{prefix}{key.value}.")
    return keys


def test_the_configuration_reference_lists_every_group_option_and_key():
    import yaml

    pages = _config_reference().pages()
    text = "\n".join(pages.values())
    for path in sorted(CONF.rglob("*.yaml")):
        group = path.parent.relative_to(CONF).as_posix()
        if group != ".":
            page = pages[f"reference/config/{group.replace('/', '-')}.md"]
            assert f"## {path.stem}\n" in page, f"{_relative(path)} has no section on its group's page"
        root = yaml.compose(path.read_text(encoding="utf-8"))
        for key in _leaf_keys(root) if root is not None else []:
            assert f"| `{key}` |" in text, f"{_relative(path)}: key {key} is missing from the reference"


def test_the_configuration_reference_reads_comments_not_values(tmp_path):
    # A '#' inside a quoted value is not a comment; a comment continues on deeper-indented lines below it, and a
    # comment block above a key at its indentation documents it too.
    (tmp_path / "colours").mkdir()
    (tmp_path / "colours" / "dark.yaml").write_text(
        "# Dark colours.\n"
        'color: "#1f5aa6"   # the line colour\n'
        "width: 2           # line width, points;\n"
        "                   # thicker lines print better\n"
        "nested:\n"
        "  # the fill's opacity\n"
        "  alpha: 0.5\n",
        encoding="utf-8",
    )
    reference = _config_reference()
    (option,) = reference.read_groups(tmp_path)["colours"]
    assert option.description == "Dark colours."
    assert [(key.path, key.value, key.comment) for key in option.keys] == [
        ("color", '"#1f5aa6"', "the line colour"),
        ("width", "2", "line width, points; thicker lines print better"),
        ("nested.alpha", "0.5", "the fill's opacity"),
    ]
