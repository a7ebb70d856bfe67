"""Atomic, verified checkpoints of a SAC run: one file, a SHA-256 header then a ``torch.save`` payload.

The digest lives in the same file as the bytes it covers, and the file is written beside its final
name then renamed, so a run killed at any point leaves either the previous checkpoint or the new
one, each with its own digest. A checkpoint whose bytes do not match its digest (a flipped bit on
disk, a cut file) or that ``torch.load`` cannot read is discarded with one warning, and its run
starts afresh: a run resumes from exactly the state it saved, or from nothing.
"""

from __future__ import annotations

import errno
import hashlib
import io
import logging
import os
import tempfile
from pathlib import Path
from typing import IO, Any

import torch

log = logging.getLogger(__name__)

CHECKPOINT_NAME = "checkpoint.pt"
MAGIC = b"taskcomplexity-checkpoint sha256:"


def _header(digest: str) -> bytes:
    """The first line of a checkpoint file: the magic and the hex SHA-256 of the payload after it."""
    return MAGIC + digest.encode("ascii") + b"\n"


HEADER_SIZE = len(_header(hashlib.sha256().hexdigest()))


def checkpoint_path(directory: Path) -> Path:
    """Where the checkpoint of a run lives inside ``directory``."""
    return Path(directory) / CHECKPOINT_NAME


class _DigestingWriter:
    """The file object ``torch.save`` writes to: passes bytes on to ``handle`` and hashes them.

    torch's zip writer reports a failed write as a ``RuntimeError`` ("unexpected pos …"); the
    writer keeps the write's own ``OSError`` (``error``), which says why it failed.
    """

    def __init__(self, handle: IO[bytes]):
        self.handle = handle
        self.digest = hashlib.sha256()
        self.error: OSError | None = None

    def write(self, data) -> int:
        try:
            written = self.handle.write(data)
        except OSError as err:
            self.error = err
            raise
        self.digest.update(data)
        return written

    def flush(self) -> None:
        self.handle.flush()


def save_checkpoint(directory: Path, state: dict[str, Any]) -> Path:
    """Write ``state`` to ``directory/checkpoint.pt`` atomically, with the SHA-256 of its payload.

    The file is written to a temporary name in the same directory (the header's place first, filled
    in once the payload's digest is known), flushed to disk, then moved over the previous checkpoint
    with ``os.replace``: a reader (or a run killed mid-write) sees either the old checkpoint or the
    new one, never a partial file.

    Raises
    ------
    OSError
        ``errno.ENOSPC`` with the checkpoint's path as ``filename`` when the disk fills up, whatever
        part of the write it stops (the entry points report it in one line). No temporary file is
        left behind on any failure.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = checkpoint_path(directory)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".checkpoint-", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(bytes(HEADER_SIZE))
            payload = _DigestingWriter(handle)
            try:
                torch.save(state, payload)
            except RuntimeError:
                if payload.error is None:  # not a failed write: a bug, raised as it is
                    raise
                raise payload.error from None
            handle.seek(0)
            handle.write(_header(payload.digest.hexdigest()))
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException as err:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(err, OSError) and err.errno == errno.ENOSPC:
            raise OSError(errno.ENOSPC, "No space left on device", str(path)) from err
        raise
    return path


def load_checkpoint(directory: Path) -> dict[str, Any] | None:
    """The checkpoint in ``directory``, or ``None`` if there is none or it is damaged.

    A damaged checkpoint (no header, a payload that does not match its digest, or one ``torch.load``
    cannot read) is logged in one warning naming the file and removed, so the run starts afresh.

    The file holds tensordicts, NumPy RNG state and Python objects written by this package, so it is
    unpickled in full (``weights_only=False``): load only checkpoints you wrote.
    """
    path = checkpoint_path(directory)
    try:
        with path.open("rb") as handle:
            header, payload = handle.read(HEADER_SIZE), handle.read()
    except FileNotFoundError:
        return None
    problem = _problem(header, payload)
    if problem is None:
        try:
            return torch.load(io.BytesIO(payload), weights_only=False)
        except MemoryError:
            raise
        except Exception as err:  # noqa: BLE001 - bytes torch cannot read are discarded like damaged ones
            problem = "torch cannot read it: " + " ".join(str(err).split())
    log.warning("discarding the damaged checkpoint %s (%s); its run starts afresh", path, problem)
    path.unlink(missing_ok=True)
    return None


def _problem(header: bytes, payload: bytes) -> str | None:
    """Why ``header`` + ``payload`` is not an intact checkpoint, or None when it is."""
    if len(header) < HEADER_SIZE or not header.startswith(MAGIC):
        return "no SHA-256 header"
    if header != _header(hashlib.sha256(payload).hexdigest()):
        return "its SHA-256 does not match its bytes"
    return None
