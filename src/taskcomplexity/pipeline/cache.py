"""A content-addressed cache that never lies.

Layout: ``<root>/<stage>/<key>/`` holds the artefact's files and ``manifest.json``. An artefact is
written into a temporary directory beside it and renamed into place, under a file lock, so an
interrupted or concurrent run never leaves a half artefact under a valid key. On read every file is
checked (the manifest parses and lists the files; each parquet's footer and schema read); a corrupt
artefact is reported, removed and recomputed.

``python -m taskcomplexity.pipeline.cache list [root]`` lists what is cached, with sizes.
"""

from __future__ import annotations

import json
import logging
import os
import platform
import shutil
import sys
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from filelock import FileLock

from taskcomplexity.errors import ArtefactError

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"


def library_versions() -> dict[str, str]:
    """Versions of the libraries that shape results."""
    import importlib.metadata as md

    versions = {"python": platform.python_version()}
    for name in ("taskcomplexity", "numpy", "scipy", "pandas", "pyarrow", "torch", "torchrl", "pybullet", "numba"):
        try:
            versions[name] = md.version(name)
        except md.PackageNotFoundError:  # pragma: no cover
            pass
    return versions


@dataclass(frozen=True)
class Artefact:
    """A complete cached artefact."""

    stage: str
    key: str
    path: Path

    @property
    def manifest(self) -> dict[str, Any]:
        return json.loads((self.path / MANIFEST).read_text())

    def file(self, name: str) -> Path:
        return self.path / name


def ensure_writable(root: Path) -> None:
    """Fail early, with the path named, when the output directory cannot be written."""
    try:
        root.mkdir(parents=True, exist_ok=True)
        probe = root / f".write-probe-{uuid.uuid4().hex}"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise ArtefactError(f"paths.outputs: cannot write to {root} ({err.strerror or err})") from err


def check_artefact(path: Path) -> list[str]:
    """Problems of the artefact at ``path`` (empty when it is complete and readable)."""
    import pyarrow.parquet as pq

    manifest_path = path / MANIFEST
    try:
        manifest = json.loads(manifest_path.read_text())
        files = manifest["files"]
    except (OSError, ValueError, KeyError, TypeError) as err:
        return [f"{manifest_path}: unreadable manifest ({err})"]
    problems = []
    for name, size in files.items():
        file = path / name
        if not file.is_file():
            problems.append(f"{file}: missing")
        elif file.stat().st_size != size:
            problems.append(f"{file}: size {file.stat().st_size} bytes, manifest says {size}")
        elif name.endswith(".parquet"):
            try:
                pq.read_metadata(file)
                pq.read_schema(file)
            except Exception as err:  # noqa: BLE001 - any reader failure means corrupt
                problems.append(f"{file}: unreadable parquet ({err})")
    return problems


class Cache:
    """The artefact store under ``root`` (``<paths.outputs>/cache``)."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    def path(self, stage: str, key: str) -> Path:
        return self.root / stage / key

    def scratch(self, stage: str, key: str) -> Path:
        """A per-key directory for resumable partial work (chunks, shards, checkpoints)."""
        path = self.root / stage / f".partial-{key}"
        path.mkdir(parents=True, exist_ok=True)
        return path

    def lookup(self, stage: str, key: str) -> Artefact | None:
        """The complete artefact, or None; a corrupt one is reported and removed."""
        path = self.path(stage, key)
        if not path.exists():
            return None
        problems = check_artefact(path)
        if problems:
            log.warning("corrupt %s artefact %s, recomputing: %s", stage, key, "; ".join(problems))
            self._discard(path)
            return None
        return Artefact(stage, key, path)

    def _discard(self, path: Path) -> None:
        trash = path.with_name(f".trash-{path.name}-{uuid.uuid4().hex[:8]}")
        try:
            os.replace(path, trash)
        except OSError:
            return
        shutil.rmtree(trash, ignore_errors=True)

    def get_or_compute(
        self,
        stage: str,
        key: str,
        compute: Callable[[Path], dict[str, Any]],
        *,
        config: dict[str, Any],
        inputs: dict[str, str] | None = None,
        force: bool = False,
        after: Callable[[], None] | None = None,
    ) -> tuple[Artefact, bool]:
        """Return the artefact for ``key``, computing it if needed.

        Parameters
        ----------
        compute : callable
            ``compute(directory)`` writes the artefact's files into ``directory`` and returns extra
            manifest fields (e.g. timing).
        config : dict
            The resolved config subset the key hashes (goes into the manifest).
        inputs : dict, optional
            Keys of upstream artefacts.
        force : bool
            Recompute even if a valid artefact exists.
        after : callable, optional
            Run under the lock once the artefact is in place (e.g. to remove partial work).

        Returns
        -------
        (Artefact, hit) — ``hit`` is True when the cache already held it.
        """
        if not force:
            found = self.lookup(stage, key)
            if found is not None:
                log.info("cache hit: %s %s (%s)", stage, key, found.path)
                return found, True
        final = self.path(stage, key)
        final.parent.mkdir(parents=True, exist_ok=True)
        with FileLock(str(final.parent / f".{key}.lock")):
            if not force:
                found = self.lookup(stage, key)
                if found is not None:  # a concurrent job finished it while we waited
                    log.info("cache hit: %s %s (computed by a concurrent job)", stage, key)
                    return found, True
            tmp = final.parent / f".tmp-{key}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            tmp.mkdir()
            try:
                started = time.time()
                extra = compute(tmp) or {}
                files = {p.name: p.stat().st_size for p in sorted(tmp.iterdir()) if p.is_file()}
                manifest = {
                    "stage": stage,
                    "key": key,
                    "config": config,
                    "inputs": inputs or {},
                    "versions": library_versions(),
                    "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                    "seconds": round(time.time() - started, 3),
                    "argv": sys.argv,
                    "files": files,
                    **extra,
                }
                (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True, default=str))
                if final.exists():
                    self._discard(final)
                os.replace(tmp, final)
                if after is not None:
                    after()
            finally:
                if tmp.exists():
                    shutil.rmtree(tmp, ignore_errors=True)
        log.info("computed: %s %s (%s)", stage, key, final)
        return Artefact(stage, key, final), False

    def entries(self) -> list[dict[str, Any]]:
        """Every complete artefact with its size in bytes."""
        out = []
        if not self.root.exists():
            return out
        for stage_dir in sorted(p for p in self.root.iterdir() if p.is_dir()):
            for path in sorted(p for p in stage_dir.iterdir() if p.is_dir() and not p.name.startswith(".")):
                size = sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
                try:
                    manifest = json.loads((path / MANIFEST).read_text())
                except (OSError, ValueError):
                    manifest = {}
                out.append(
                    {
                        "stage": stage_dir.name,
                        "key": path.name,
                        "bytes": size,
                        "created": manifest.get("created", "?"),
                        "what": manifest.get("label", ""),
                    }
                )
        return out


def _human(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1024:
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TB"


def main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(prog="python -m taskcomplexity.pipeline.cache")
    parser.add_argument("command", choices=["list"])
    default_root = os.path.join(os.environ.get("TASKCOMPLEXITY_OUTPUTS", "outputs"), "cache")
    parser.add_argument("root", nargs="?", default=default_root)
    args = parser.parse_args(argv)
    entries = Cache(args.root).entries()
    if not entries:
        print(f"no artefacts under {args.root}")
        return 0
    print(f"{'stage':<10} {'key':<17} {'size':>10}  {'created':<25} what")
    for e in entries:
        print(f"{e['stage']:<10} {e['key']:<17} {_human(e['bytes']):>10}  {e['created']:<25} {e['what']}")
    print(f"{len(entries)} artefacts, {_human(sum(e['bytes'] for e in entries))} under {args.root}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
