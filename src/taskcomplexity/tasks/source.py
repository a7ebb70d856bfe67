"""The source an env's returns depend on, as a digest in its task's identity: an edit to it is a new task.

A researcher's env is rarely one file: its constants, its dynamics or its reward often live in helper modules of
the same package. The digest covers the file that defines the env's entry point and every module of the
researcher's own code that it imports, directly or through one another, found by reading the ``import``
statements (absolute and relative) of each file, not by running them: the digest is the same whatever else the
process imported.

*Own code* is a Python file outside the interpreter's standard library and its installed packages
(any ``site-packages`` on the path), and outside this package: gymnasium's, Meta-World's and our own envs are
versioned with their package, and their digest stays the one file that defines them. Data files an env reads
(a MuJoCo XML) are not covered: name them in the env's constructor arguments, which are in the identity, or keep
them beside a module whose edit marks the change.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import site
import sys
import sysconfig
from functools import cache
from pathlib import Path

OWN_PACKAGE = "taskcomplexity"


def source_digest(module: str | None, origin: Path | None = None) -> str:
    """SHA-256 (16 hex digits) of the env's source: the file ``origin`` that defines it (of ``module`` when not
    given), followed, when it is the researcher's own code and imports any of the researcher's own modules, by each
    of them (its name and its bytes, in name order); an installed package's file is not read for imports. "" when
    there is no file to read."""
    try:
        origin = origin or _origin(module)
        if origin is None:
            return ""
        digest = hashlib.sha256(origin.read_bytes())
        if module is not None and not module.startswith(OWN_PACKAGE + ".") and _own(origin):
            for name, path in sorted(own_imports(module, origin).items()):
                digest.update(b"\0" + name.encode() + b"\0" + path.read_bytes())
        return digest.hexdigest()[:16]
    except (OSError, ImportError, ValueError, SyntaxError):
        return ""


def own_imports(module: str, origin: Path) -> dict[str, Path]:
    """Every module of the researcher's own code that ``module`` (defined in ``origin``) imports, directly or
    through one another, by name (``module`` itself left out)."""
    found: dict[str, Path] = {}
    pending = [(module, origin)]
    while pending:
        name, path = pending.pop()
        for imported in _imports(name, path):
            if imported in found or imported == module or not _own_package(imported.partition(".")[0]):
                continue
            where = _origin(imported)
            if where is not None and _own(where):
                found[imported] = where
                pending.append((imported, where))
    return found


def _imports(module: str, path: Path) -> set[str]:
    """The absolute names of the modules a file imports (``from a import b`` names ``a`` and ``a.b``: ``b`` may be
    a submodule)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_bytes(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".") if package else []
                if node.level - 1 > len(parts):
                    continue
                anchor = ".".join(parts[: len(parts) - (node.level - 1)])
                base = f"{anchor}.{base}" if base and anchor else (base or anchor)
            if base:
                names.add(base)
                names.update(f"{base}.{alias.name}" for alias in node.names if alias.name != "*")
    expanded = set()
    for name in names:  # importing a.b.c runs a/__init__ and a/b/__init__ too
        parts = name.split(".")
        expanded.update(".".join(parts[:i]) for i in range(1, len(parts) + 1))
    return expanded


@cache
def _own_package(top: str) -> bool:
    """Whether the top-level module or package ``top`` is the researcher's own code. Asked before any of its
    submodules is looked up: finding ``a.b`` imports ``a``, which for an installed package would run its code (and
    could fail on a dependency it lacks) for nothing."""
    if top in sys.builtin_module_names:
        return False
    where = _origin(top)
    if where is not None:
        return _own(where)
    try:  # a namespace package (no __init__.py): its own code, if any, is in its directories
        spec = importlib.util.find_spec(top)
    except Exception:  # noqa: BLE001 - as in _origin
        return False
    locations = list(getattr(spec, "submodule_search_locations", None) or []) if spec is not None else []
    return any(_own(Path(location) / "__init__.py") for location in locations)


def _origin(module: str) -> Path | None:
    """The source file of ``module`` (None for a built-in, a namespace package, a compiled extension, or a name that
    is not a module, or whose parent package fails to import)."""
    try:
        spec = importlib.util.find_spec(module)
    except Exception:  # noqa: BLE001 - a parent package that raises on import (a dependency it lacks): not followed
        return None
    if spec is None or not spec.origin or not spec.origin.endswith(".py"):
        return None
    return Path(spec.origin)


def _own(path: Path) -> bool:
    """Whether ``path`` is the researcher's own code (module docstring)."""
    resolved = path.resolve()
    if any(resolved.is_relative_to(root) for root in _installed_roots()):
        return False
    return not resolved.is_relative_to(_OWN_ROOT)


@cache
def _installed_roots() -> tuple[Path, ...]:
    """The standard library's and the installed packages' directories: this environment's, and any other
    ``site-packages`` on the path (a venv's system site packages, another environment's packages through a ``.pth``
    line), whose packages are installed too."""
    paths = sysconfig.get_paths()
    roots = {paths[key] for key in ("stdlib", "platstdlib", "purelib", "platlib") if key in paths}
    roots.update(site.getsitepackages())
    if site.ENABLE_USER_SITE and site.getusersitepackages():
        roots.add(site.getusersitepackages())
    roots.update(entry for entry in sys.path if entry and Path(entry).name in ("site-packages", "dist-packages"))
    return tuple(Path(root).resolve() for root in roots)


_OWN_ROOT = Path(__file__).resolve().parents[1]
"""This package's directory (its own envs are versioned with it)."""
