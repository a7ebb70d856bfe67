"""The library's words about itself stay true: references in docstrings and comments resolve, each package's
docstring names every module of its folder, the paths the code and the pages name exist, the tests mirror the
library, and the layout page lists what the tree holds.

A docstring or comment that names ``taskcomplexity.x.y`` (a Sphinx role, a backticked path or plain text) names
something that exists: the module imports and each further part is an attribute, so a renamed or moved object
fails here instead of leaving a dead reference (the API pages of the documentation site render such a reference
as plain text, without a link). The same holds for the Sphinx roles that name an object by its short name
(``:func:`pic```): the name is defined in the module, or in the class, that the docstring belongs to.

A path under ``tests/``, ``docs/``, ``bench/`` or ``pipelines/`` named in a docstring or comment (of the library, the
tests, the benchmarks, the entry scripts) or anywhere in a documentation page, the README, the Makefile or CI's
script exists, so a moved test or page cannot leave its old path behind. ``tests/`` mirrors
``src/taskcomplexity/``: a folder per subpackage, the support folders declared with what they test. The layout page
(``docs/reference/layout.md``) names only what exists, and lists every top-level part of the repository, every
module and subpackage of the library, the support folders of the tests and the entry scripts.
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


# --- paths named in words --------------------------------------------------------------------------------------------

NAMED_PATH = re.compile(r"(?<![\w./~<>-])(?:tests|docs|bench|pipelines)/(?:[\w.*-]|<\w+>|/)*")
"""A repository path named in prose: it starts at one of these folders (not inside another path or a URL), and may
hold a glob (``docs/how-to/*.md``) or a placeholder (``bench/bench_<name>.py``), which must then match something."""

NOT_IN_THE_TREE: dict[tuple[str, str], str] = {
    ("docs/how-to/add-a-stage.md", "tests/golden/values/spread.npz"):
        "the file the recipe's recording command writes, in the reader's copy",
}
"""(file, path) of the named paths that are not in the tree on purpose, each with its reason."""

TESTS = ROOT / "tests"
PROSE = sorted({*SOURCE_FILES, *(ROOT / "src" / "hydra_plugins").rglob("*.py"), *TESTS.rglob("*.py"),
                *(ROOT / "bench").rglob("*.py"), *(ROOT / "pipelines").rglob("*.py")})
"""The files whose docstrings and comments (YAML: comments) are read for named paths."""
PAGES_AND_RECIPES = sorted({*(ROOT / "docs").rglob("*.md"), ROOT / "README.md", ROOT / "mkdocs.yml",
                            ROOT / "Makefile", ROOT / ".ci" / "run"})
"""The files read whole: the documentation's pages, and the files that run tests by their paths."""


def named_paths(path: Path) -> list[tuple[int, str]]:
    """(line, path) of every repository path that a file names: in docstrings and comments of code, anywhere in a
    page, a Makefile or a script."""
    if path.suffix in (".py", ".yaml"):
        texts = [(line, text) for line, text, _ in (yaml_comments(path) if path.suffix == ".yaml"
                                                     else docs_and_comments(path))]
    else:
        texts = [(1, path.read_text(encoding="utf-8"))]
    return sorted({(_line_of(line, text, match), match.group().rstrip(".-")) for line, text in texts
                   for match in NAMED_PATH.finditer(text)})


def exists(named: str) -> bool:
    """Whether a named path is in the tree: a file or a folder, or a pattern that matches one."""
    pattern = re.sub(r"<\w+>", "*", named)
    if "*" in pattern:
        return any(ROOT.glob(pattern.rstrip("/")))
    return (ROOT / pattern).exists()


def missing_paths(path: Path) -> list[str]:
    """``file:line: path`` of every path a file names that is not in the tree (nor declared so)."""
    shown = _relative(path) if path.is_relative_to(ROOT) else str(path)
    return [f"{shown}:{line}: {named}" for line, named in named_paths(path)
            if not exists(named) and (shown, named) not in NOT_IN_THE_TREE]


@pytest.mark.parametrize("path", [pytest.param(path, id=_relative(path)) for path in [*PROSE, *PAGES_AND_RECIPES]])
def test_every_path_a_file_names_exists(path):
    missing = missing_paths(path)
    assert missing == [], ("paths named but missing from the tree (name the file or folder where it lives now, or "
                           "declare it in NOT_IN_THE_TREE with its reason):\n" + "\n".join(missing))


def test_every_path_declared_not_in_the_tree_is_named_and_missing():
    for file, named in NOT_IN_THE_TREE:
        assert named in {n for _, n in named_paths(ROOT / file)}, f"{file} no longer names {named}"
        assert not exists(named), f"{named} exists now: remove it from NOT_IN_THE_TREE"


def test_the_path_reader_finds_what_is_written(tmp_path):
    # Each form a path takes in prose, and the ones that are not repository paths, judged as a reader would.
    page = tmp_path / "page.md"
    page.write_text("Run `tests/golden/golden_runs.py`, see tests/recipes/howto.py.\n"
                    "pages: docs/how-to/*.md, bench/bench_<name>.py, a folder tests/golden/\n"
                    "gone: tests/test_no_such_file.py::test_it and docs/no-such-page.md\n"
                    "not ours: https://example.org/docs/x.md, outputs/tests/x.py, src/taskcomplexity/docs/x\n",
                    encoding="utf-8")
    assert named_paths(page) == [(1, "tests/golden/golden_runs.py"), (1, "tests/recipes/howto.py"),
                                 (2, "bench/bench_<name>.py"), (2, "docs/how-to/*.md"), (2, "tests/golden/"),
                                 (3, "docs/no-such-page.md"), (3, "tests/test_no_such_file.py")]
    assert missing_paths(page) == [f"{page}:3: docs/no-such-page.md", f"{page}:3: tests/test_no_such_file.py"]
    code = tmp_path / "code.py"
    code.write_text('"""See ``tests/no_such_test.py``."""\n\nPATH = "tests/not_prose.py"  # and bench/no_such.py\n',
                    encoding="utf-8")
    assert named_paths(code) == [(1, "tests/no_such_test.py"), (3, "bench/no_such.py")]


# --- tests/ mirrors src/taskcomplexity/ ------------------------------------------------------------------------------

SUPPORT_FOLDERS: dict[str, str] = {
    "bench": "the benchmarks' summary (bench/floors.py, bench/run.py) on canned script output",
    "cluster": "the cluster path on the local SLURM (make test-cluster): the launcher, local_slurm.sh, the jobs",
    "golden": "each stage's golden run at its version (golden_runs.py) and the values recorded",
    "recipes": "the how-to pages (docs/how-to/) followed on a scratch copy of the repository",
}
"""The folders of tests/ that mirror no subpackage, each with what it tests instead: every other folder is the
tests of the ``src/taskcomplexity/`` subpackage of its name, and top-level test files test top-level modules or
the project as a whole (its install, its README, its docs)."""


def subpackages() -> list[str]:
    """The subpackages of ``src/taskcomplexity/`` that hold code (a module beside their ``__init__.py``)."""
    return sorted(path.name for path in SOURCE.iterdir() if (path / "__init__.py").is_file()
                  and any(module.name != "__init__.py" for module in path.rglob("*.py")))


def folders_of_tests() -> list[str]:
    return sorted(path.name for path in TESTS.iterdir()
                  if path.is_dir() and path.name != "__pycache__" and not path.name.startswith("."))




def test_every_test_folder_mirrors_a_subpackage_or_is_declared_support():
    stray = [f"tests/{name}/" for name in folders_of_tests()
             if name not in subpackages() and name not in SUPPORT_FOLDERS]
    assert stray == [], (f"{stray} mirror no subpackage of src/taskcomplexity/: move their tests to the folder of "
                         "the subpackage they test, or declare the folder in SUPPORT_FOLDERS with what it tests")
    assert [name for name in SUPPORT_FOLDERS if name not in folders_of_tests() or name in subpackages()] == [], (
        "a SUPPORT_FOLDERS entry that is gone or now mirrors a subpackage")


def test_every_subpackage_has_its_test_folder():
    missing = [f"tests/{name}/ (src/taskcomplexity/{name}/)" for name in subpackages()
               if not any((TESTS / name).glob("test_*.py"))]
    assert missing == [], f"subpackages without tests in the folder that mirrors them: {missing}"


NAMED_AFTER_ANOTHER: dict[str, str] = {
    "tests/rl/test_batched_backend.py": "SAC stepping the batched kernel (sac.backend=batched), not rwg's backend",
}
"""Test files named after a module of another subpackage than their folder's, each with why they belong there."""


def test_a_test_named_after_a_module_lives_in_the_folder_of_its_subpackage():
    # a reader looks for test_cost.py, which tests commands/cost.py, in tests/commands/, and for
    # test_envpool_backend.py, which tests rwg/envpool_backend.py, in tests/rwg/
    homes: dict[str, set[str]] = {}
    for package in subpackages():
        homes.setdefault(package, set()).add(package)
        for name in modules_of(SOURCE / package):
            homes.setdefault(Path(name).stem, set()).add(package)
    misplaced = [f"{_relative(path)} -> tests/{'/ or tests/'.join(sorted(homes[name]))}/"
                 for path in sorted([*TESTS.glob("test_*.py"), *TESTS.glob("*/test_*.py")])
                 if (name := path.stem.removeprefix("test_")) in homes and path.parent.name not in homes[name]
                 and _relative(path) not in NAMED_AFTER_ANOTHER]
    assert misplaced == [], ("tests named after a module of another subpackage (move them, or declare them in "
                             f"NAMED_AFTER_ANOTHER with why they belong where they are): {misplaced}")
    assert [name for name in NAMED_AFTER_ANOTHER if not (ROOT / name).is_file()] == [], "a stale NAMED_AFTER_ANOTHER"


# --- the layout page -------------------------------------------------------------------------------------------------

LAYOUT = ROOT / "docs" / "reference" / "layout.md"
NOT_IN_A_CHECKOUT = {"outputs/": "git-ignored; the first run makes it"}
"""Entries of the layout page that a fresh checkout lacks, each with its reason (their descriptions are not read)."""
NAME = re.compile(r"(?<![\w/.=-])[\w*.-]+(?:/[\w*.-]+)*(?:/|\.(?:py|sh|md|toml|yml|yaml|json))(?=[\s,;:)]|$)")
"""A file or folder a description names: a name ending in ``/`` or in a file suffix (``run.py``, ``hooks/``)."""


@dataclasses.dataclass(frozen=True)
class Entry:
    line: int
    path: str  # from the repository's root, ``/``-terminated for a folder
    text: str  # its description, continuation lines joined


def layout_entries(page: Path = LAYOUT) -> list[Entry]:
    """The entries of the layout page's code blocks: ``name  description`` lines, a description continued on more
    deeply indented lines; a block whose first line is a lone path (``src/taskcomplexity/``) lists what is in it."""
    entries: list[Entry] = []
    lines = page.read_text(encoding="utf-8").splitlines()
    block: list[tuple[int, str]] | None = None
    for number, line in enumerate(lines, start=1):
        if line.startswith("```"):
            if block is not None:
                entries += _block_entries(block)
            block = None if block is not None else []
        elif block is not None and line.strip():
            block.append((number, line))
    return entries


def _block_entries(block: list[tuple[int, str]]) -> list[Entry]:
    root = ""
    if len(block) > 1 and " " not in block[0][1].strip() and block[1][1].startswith(" "):
        root, block = block[0][1].strip(), block[1:]
    indent = len(block[0][1]) - len(block[0][1].lstrip())
    entries: list[Entry] = []
    for number, line in block:
        depth = len(line) - len(line.lstrip())
        if depth == indent:
            name, _, text = line.strip().partition(" ")
            entries.append(Entry(number, root + name, text.strip()))
        elif depth > indent and entries:
            last = entries[-1]
            entries[-1] = dataclasses.replace(last, text=f"{last.text} {line.strip()}")
    return entries


def test_every_entry_of_the_layout_page_and_every_name_it_gives_exists():
    missing = []
    for entry in layout_entries():
        if entry.path in NOT_IN_A_CHECKOUT:
            continue
        if not (ROOT / entry.path).exists():
            missing.append(f"{_relative(LAYOUT)}:{entry.line}: {entry.path}")
            continue
        bases = [ROOT / entry.path, ROOT, SOURCE] if entry.path.endswith("/") else [ROOT, SOURCE]
        missing += [f"{_relative(LAYOUT)}:{entry.line}: {name} (in {entry.path})" for name in NAME.findall(entry.text)
                    if not any(any(base.glob(name.rstrip("/"))) for base in bases)]
    assert missing == [], "the layout page names what is not in the tree:\n" + "\n".join(missing)


def _tracked() -> list[str]:
    import subprocess

    listed = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    if listed.returncode != 0:
        pytest.skip("not a git checkout: the tracked files are unknown")
    return listed.stdout.splitlines()


def test_the_layout_page_lists_every_part_of_the_repository_and_of_the_library():
    entries = layout_entries()
    listed = {entry.path.rstrip("/") for entry in entries}
    described = {entry.path: entry.text for entry in entries}
    unlisted = []
    for path in sorted({"/".join(path.split("/")[:2] if path.startswith("src/") else path.split("/")[:1])
                        for path in _tracked() if not path.startswith(".")}):
        if not any(entry == path or entry.startswith(f"{path}/") for entry in listed):
            unlisted.append(path)  # a top-level file or folder, or a folder of src/
    unlisted += [f"src/taskcomplexity/{name}{'/' if (SOURCE / name).is_dir() else '.py'}" for name in modules_of(SOURCE)
                 if f"src/taskcomplexity/{name}" not in {path.removesuffix(".py") for path in listed}]
    words = set(re.findall(r"[\w.-]+/?", described.get("tests/", "")))
    unlisted += [f"tests/{name}/ (in the tests/ entry)" for name in SUPPORT_FOLDERS if f"{name}/" not in words]
    words = set(re.findall(r"[\w.-]+", described.get("pipelines/", "")))
    unlisted += [f"{_relative(path)} (in the pipelines/ entry)" for path in sorted((ROOT / "pipelines").glob("*.py"))
                 if path.name not in words]
    assert unlisted == [], f"{_relative(LAYOUT)} does not list: {unlisted}"


def test_the_layout_reader_reads_entries_and_their_continuations(tmp_path):
    page = tmp_path / "layout.md"
    page.write_text("# Layout\n\n```\nMakefile      every target\ndocs/         this site: tutorials/ hooks/;\n"
                    "              run.py\n```\n\ntext\n\n```\nsrc/pkg/\n  tasks/   base.py: the seam\n"
                    "  cli.py\n```\n", encoding="utf-8")
    assert layout_entries(page) == [Entry(4, "Makefile", "every target"),
                                    Entry(5, "docs/", "this site: tutorials/ hooks/; run.py"),
                                    Entry(13, "src/pkg/tasks/", "base.py: the seam"), Entry(14, "src/pkg/cli.py", "")]
    assert NAME.findall("this site: tutorials/ hooks/; run.py, hydra/launcher=cluster (a/b.py)") == [
        "tutorials/", "hooks/", "run.py", "a/b.py"]
