"""Atomic checkpoints of a SAC run: one ``torch.save`` file, written beside its final name then renamed."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import torch

CHECKPOINT_NAME = "checkpoint.pt"


def checkpoint_path(directory: Path) -> Path:
    """Where the checkpoint of a run lives inside ``directory``."""
    return Path(directory) / CHECKPOINT_NAME


def save_checkpoint(directory: Path, state: dict[str, Any]) -> Path:
    """Write ``state`` to ``directory/checkpoint.pt`` atomically.

    The file is written to a temporary name in the same directory, flushed to disk, then moved over
    the previous checkpoint with ``os.replace``: a reader (or a run killed mid-write) sees either the
    old checkpoint or the new one, never a partial file.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".checkpoint-", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            torch.save(state, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, checkpoint_path(directory))
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return checkpoint_path(directory)


def load_checkpoint(directory: Path) -> dict[str, Any] | None:
    """The checkpoint in ``directory``, or ``None`` if there is none.

    The file holds tensordicts, NumPy RNG state and Python objects written by this package, so it is
    unpickled in full (``weights_only=False``): load only checkpoints you wrote.
    """
    path = checkpoint_path(directory)
    if not path.exists():
        return None
    return torch.load(path, weights_only=False)
