"""A content-addressed cache that never lies.

Layout: ``<root>/<stage>/<key>/`` holds the artefact's files and ``manifest.json``. An artefact is
written into a temporary directory beside it and renamed into place, under a file lock, so an
interrupted or concurrent run never leaves a half artefact under a valid key. Every hit is verified
before it is served: the manifest names this stage and key (and, when the caller gives it, the same
config), lists at least one file, and every file has the size and SHA-256 the manifest recorded. A
damaged, foreign or unverifiable artefact is reported, removed and recomputed — never served.
Temporary directories of processes that died are removed by the next writer of the same key.

``python -m taskcomplexity.stages.cache list [root]`` lists what is cached, with sizes.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import logging
import os
import platform
import shutil
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from taskcomplexity.errors import ArtefactError
from taskcomplexity.stages.resources import human_bytes

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"


def library_versions() -> dict[str, str]:
    """Versions of the libraries that shape results (a new dict for each manifest)."""
    return dict(_library_versions())


@functools.cache
def _library_versions() -> dict[str, str]:
    """Read from the installed packages' metadata once per process (each lookup scans the path's packages: ~20 ms
    for the nine, for each artefact written): a library upgraded while the process runs is not the one it has
    loaded, so the first reading is the true one."""
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


def ensure_writable(root: Path, key: str = "paths.outputs") -> None:
    """Fail early, naming the config ``key`` and the path, when a directory cannot be written."""
    try:
        root.mkdir(parents=True, exist_ok=True)
        probe = root / f".write-probe-{uuid.uuid4().hex}"
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise ArtefactError(f"{key}: cannot write to {root} ({err.strerror or err})") from err


def read_only(root: Path) -> bool:
    """Whether ``root`` is an existing directory this process can read but not write (a shared cache on a
    read-only mount, or another user's)."""
    return root.is_dir() and os.access(root, os.R_OK | os.X_OK) and not os.access(root, os.W_OK)


def check_writable(outputs: Path, cache: Cache) -> None:
    """Fail early, naming the config key, when ``outputs`` (``paths.outputs``) or the cache's root (``paths.cache``)
    cannot be written (each made if missing); a read-only cache that exists is kept to serve what it holds."""
    ensure_writable(outputs)
    if read_only(cache.root):
        log.info("paths.cache %s is read-only: its artefacts are served, anything it lacks is refused", cache.root)
    else:
        ensure_writable(cache.root, key="paths.cache")


@contextlib.contextmanager
def waiting_lock(path: Path, what: str) -> Iterator[None]:
    """Hold the file lock at ``path``; if another run holds it, say what this run waits for, then wait."""
    lock = FileLock(str(path))
    try:
        lock.acquire(timeout=0)
    except Timeout:
        log.info("waiting for another run that is computing %s (it holds %s)", what, path)
        started = time.monotonic()
        lock.acquire()
        log.info("%s: the other run is done after %.0f s", what, time.monotonic() - started)
    try:
        yield
    finally:
        lock.release()


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def check_artefact(path: Path, *, stage: str | None = None, key: str | None = None,
                   config: dict[str, Any] | None = None) -> list[str]:
    """Problems of the artefact at ``path`` (empty when it is complete, intact and the one asked for).

    Parameters
    ----------
    stage, key : str, optional
        What the caller looked up; the manifest must name the same.
    config : dict, optional
        The config subset the key hashes; the manifest's must be equal.
    """
    manifest_path = path / MANIFEST
    try:
        manifest = json.loads(manifest_path.read_text())
        files = manifest["files"]
    except (OSError, ValueError, KeyError, TypeError) as err:
        return [f"{manifest_path}: unreadable manifest ({err})"]
    if not isinstance(files, dict) or not files:
        return [f"{manifest_path}: lists no files"]
    for name, expected in (("stage", stage), ("key", key)):
        if expected is not None and manifest.get(name) != expected:
            return [f"{manifest_path}: written for {name} {manifest.get(name)!r}, looked up as {expected!r}"]
    if config is not None and manifest.get("config") != json.loads(json.dumps(config, default=str)):
        return [f"{manifest_path}: written for other settings than those looked up"]
    problems = []
    for name, recorded in files.items():
        file = path / name
        if not isinstance(recorded, dict) or "sha256" not in recorded:
            problems.append(f"{file}: no content hash in the manifest (written by an older version)")
        elif not file.is_file():
            problems.append(f"{file}: missing")
        elif file.stat().st_size != recorded.get("bytes"):
            problems.append(f"{file}: size {file.stat().st_size} bytes, manifest says {recorded.get('bytes')}")
        elif file_digest(file) != recorded["sha256"]:
            problems.append(f"{file}: content differs from what was written (SHA-256 mismatch)")
    return problems


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    return True


def remove_orphans(directory: Path, pattern: str) -> int:
    """Delete ``pattern`` entries of ``directory`` whose name carries the pid of a dead process.

    Names look like ``….<pid>.…`` or ``…-<pid>-…`` (``.tmp-<key>-<pid>-<hex>``, ``chunk….<pid>.tmp.npz``).
    Returns how many were removed.
    """
    removed = 0
    for entry in directory.glob(pattern):
        pids = [int(part) for part in entry.name.replace(".", "-").split("-") if part.isdigit() and len(part) < 8]
        if pids and not _pid_alive(pids[-1]):
            if entry.is_dir():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
            removed += 1
    return removed


@dataclass(frozen=True)
class Cache:
    """The artefact store under ``root`` (``<paths.outputs>/cache``): a place, so making one writes nothing."""

    root: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "root", Path(self.root))

    def path(self, stage: str, key: str) -> Path:
        return self.root / stage / key

    def require_writable(self, stage: str, key: str) -> None:
        """Refuse, in one line, to compute an artefact into a read-only cache (a hit needs no writing)."""
        if read_only(self.root):
            raise ArtefactError(f"paths.cache {self.root} is read-only and holds no {stage} artefact {key}: "
                                "point paths.cache at a writable directory to compute it")

    def scratch(self, stage: str, key: str) -> Path:
        """A per-key directory for resumable partial work (chunks, shards, checkpoints)."""
        path = self.root / stage / f".partial-{key}"
        path.mkdir(parents=True, exist_ok=True)
        return path

    def lookup(self, stage: str, key: str, config: dict[str, Any] | None = None) -> Artefact | None:
        """The complete, verified artefact, or None; a damaged or foreign one is reported and removed."""
        path = self.path(stage, key)
        if not path.exists():
            return None
        problems = check_artefact(path, stage=stage, key=key, config=config)
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
            found = self.lookup(stage, key, config)
            if found is not None:
                log.debug("cache hit: %s %s (%s)", stage, key, found.path)
                return found, True
        self.require_writable(stage, key)
        final = self.path(stage, key)
        final.parent.mkdir(parents=True, exist_ok=True)
        with waiting_lock(final.parent / f".{key}.lock", f"{stage} {key}"):
            remove_orphans(final.parent, f".tmp-{key}-*")
            if not force:
                found = self.lookup(stage, key, config)
                if found is not None:  # a concurrent job finished it while we waited
                    log.debug("cache hit: %s %s (computed by a concurrent job)", stage, key)
                    return found, True
            tmp = final.parent / f".tmp-{key}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            tmp.mkdir()
            try:
                started = time.time()
                extra = compute(tmp) or {}
                files = {p.name: {"bytes": p.stat().st_size, "sha256": file_digest(p)}
                         for p in sorted(tmp.iterdir()) if p.is_file()}
                if not files:
                    raise ArtefactError(f"{stage} {key}: the stage wrote no file")
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
        log.debug("computed: %s %s (%s)", stage, key, final)
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


def main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(prog="python -m taskcomplexity.stages.cache")
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
        print(f"{e['stage']:<10} {e['key']:<17} {human_bytes(e['bytes']):>10}  {e['created']:<25} {e['what']}")
    print(f"{len(entries)} artefacts, {human_bytes(sum(e['bytes'] for e in entries))} under {args.root}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
