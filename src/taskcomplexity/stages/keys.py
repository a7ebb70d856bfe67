"""Cache keys: a hash of the canonical (sorted, resolved) config subset, input keys, format version and
a fingerprint of the code that computes the stage.

The fingerprint (:func:`code_fingerprint`) hashes the syntax trees (docstrings, comments and layout
left out) of the stage's module and of every ``taskcomplexity`` module it imports, directly or
not, at any depth (imports inside functions included). So a result computed by older code is never
served: after an upgrade that changes a stage's code, that stage (and the stages downstream of it,
whose keys hold its key) recompute once; stages whose code did not change keep their artefacts.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import hashlib
import importlib.util
import json
from pathlib import Path
from typing import Any

PACKAGE = "taskcomplexity"


def canonical(value: Any) -> Any:
    """Plain JSON-able form of dataclasses, tuples, numpy scalars and mappings (keys sorted on dump)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    if hasattr(value, "item") and callable(value.item):
        return value.item()
    return value


def stage_key(stage: str, version: int, payload: dict[str, Any]) -> str:
    """16 hex digits identifying ``payload`` for ``stage`` at format ``version``, computed by today's code.

    The stage's code is the module ``taskcomplexity.stages.<stage>_stage`` and what it imports.
    """
    code = code_fingerprint(f"{__package__}.{stage}_stage")
    text = json.dumps({"stage": stage, "version": version, "code": code, "payload": canonical(payload)},
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@functools.cache
def code_fingerprint(module: str) -> str:
    """SHA-256 over the syntax trees of ``module`` and of every package module it imports (transitively).

    Memoised per process: the files do not change under a running computation.
    """
    digest = hashlib.sha256()
    for name in sorted(_closure(module)):
        digest.update(name.encode())
        digest.update(_tree_digest(_source_path(name)).encode())
    return digest.hexdigest()[:16]


def _closure(module: str) -> set[str]:
    seen, todo = set(), [module]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        path = _source_path(name)
        seen.add(name)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            for imported in _imports(node, name, path):
                if imported.split(".")[0] == PACKAGE and imported not in seen and _exists(imported):
                    todo.append(imported)
    return seen


def _imports(node: ast.AST, module: str, path: Path) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for _ in range(node.level - 1):
            package = package.rpartition(".")[0]
        base = f"{package}.{node.module}" if node.module else package
    else:
        base = node.module or ""
    # ``from package import module`` names a module; ``from module import name`` a name in it.
    return [base, *(f"{base}.{alias.name}" for alias in node.names)]


def _exists(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def _source_path(module: str) -> Path:
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None or not spec.origin.endswith(".py"):
        raise ValueError(f"no Python source for module {module!r}")
    return Path(spec.origin)


def _tree_digest(path: Path) -> str:
    """Hash of a file's syntax tree without docstrings (comments and layout never reach the tree)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body
                and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return hashlib.sha256(ast.dump(tree).encode()).hexdigest()
