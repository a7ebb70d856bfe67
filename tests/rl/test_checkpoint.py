"""A SAC checkpoint is verified before a run resumes from it, and a full disk while writing one is reported as such.

A damaged checkpoint (a flipped byte, a cut file, a file without its digest) is discarded with one warning and the
run starts afresh: its curve is the uninterrupted run's. A write that fails for lack of space raises
``OSError(ENOSPC)`` naming the checkpoint, which the entry points turn into their one disk-full line, and leaves no
temporary file behind.
"""

from __future__ import annotations

import errno
import io
import logging
import os

import pandas as pd
import pytest
import torch

from taskcomplexity.cli import EXIT_DISK_FULL, one_line_errors
from taskcomplexity.rl import CURVE_COLUMNS, WALL_CLOCK, SACSettings, train_sac
from taskcomplexity.rl.checkpoint import checkpoint_path, load_checkpoint, save_checkpoint
from taskcomplexity.tasks.spec import make_task

TASK = make_task("one_link_1m0", "dense")
TINY = SACSettings(total_steps=60, warmup_steps=20, eval_every=30, eval_episodes=1, checkpoint_every=30, seeds=(0,),
                   hidden_sizes=(16, 16))
DETERMINISTIC = [c for c in CURVE_COLUMNS if not c.startswith(WALL_CLOCK)]
LOGGER = "taskcomplexity.rl.checkpoint"


@pytest.fixture(scope="module")
def uninterrupted():
    return train_sac(TASK, TINY, seed=0)


def _flip_byte(data: bytes) -> bytes:
    middle = len(data) // 2
    return data[:middle] + bytes([data[middle] ^ 0xFF]) + data[middle + 1:]


DAMAGE = {
    "flipped byte": _flip_byte,
    "cut short": lambda data: data[: len(data) // 2],
    "without its digest": lambda data: data[data.index(b"PK\x03\x04"):],  # the bare torch.save payload
}


@pytest.mark.parametrize("damage", DAMAGE)
def test_a_run_discards_a_damaged_checkpoint_with_one_warning_and_gives_the_uninterrupted_curve(
    damage, uninterrupted, tmp_path, caplog
):
    partial = train_sac(TASK, TINY, seed=0, checkpoint_dir=tmp_path, stop_after=30)
    assert partial["env_step"].max() == 30
    path = checkpoint_path(tmp_path)
    path.write_bytes(DAMAGE[damage](path.read_bytes()))
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        resumed = train_sac(TASK, TINY, seed=0, checkpoint_dir=tmp_path)
    warnings = [r for r in caplog.records if r.name == LOGGER and r.levelno == logging.WARNING]
    assert len(warnings) == 1 and str(path) in warnings[0].getMessage()
    assert "\n" not in warnings[0].getMessage()
    pd.testing.assert_frame_equal(resumed[DETERMINISTIC], uninterrupted[DETERMINISTIC], check_exact=True)
    assert load_checkpoint(tmp_path)["progress"]["step"] == TINY.total_steps  # the fresh run's own checkpoint


def test_a_checkpoint_round_trips_and_any_flipped_byte_is_caught(tmp_path, caplog):
    state = {"weights": torch.arange(1000, dtype=torch.float32), "step": 30, "rows": [{"a": 1.5}]}
    path = save_checkpoint(tmp_path, state)
    loaded = load_checkpoint(tmp_path)
    assert torch.equal(loaded["weights"], state["weights"]) and loaded["step"] == 30 and loaded["rows"] == [{"a": 1.5}]
    original = path.read_bytes()
    for position in range(0, len(original), max(1, len(original) // 40)):
        damaged = bytearray(original)
        damaged[position] ^= 0x01
        path.write_bytes(bytes(damaged))
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger=LOGGER):
            assert load_checkpoint(tmp_path) is None, position
        assert [r.name for r in caplog.records] == [LOGGER], position
        assert not path.exists()  # discarded: the next save starts over


class _FullDisk(io.RawIOBase):
    """A file descriptor on a disk with ``room`` bytes left: a write beyond them fails as write(2) does."""

    def __init__(self, fd: int, room: int):
        self.fd, self.room = fd, room

    def writable(self) -> bool:
        return True

    def fileno(self) -> int:
        return self.fd

    def write(self, data) -> int:
        if self.room == 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written = os.write(self.fd, bytes(data[: self.room]))
        self.room -= written
        return written

    def close(self) -> None:
        if not self.closed:
            os.close(self.fd)
        super().close()


@pytest.fixture
def disk_with_room(monkeypatch):
    """``disk_with_room(n)``: from now on, files opened with ``os.fdopen(fd, "wb")`` fill up after ``n`` bytes."""
    real_fdopen = os.fdopen

    def fill_after(room: int) -> None:
        def fdopen(fd, mode="r", *args, **kwargs):
            if mode != "wb":
                return real_fdopen(fd, mode, *args, **kwargs)
            return io.BufferedWriter(_FullDisk(fd, room))

        monkeypatch.setattr(os, "fdopen", fdopen)

    return fill_after


@pytest.mark.parametrize("room", [0, 20_000, 300_000])  # before torch's first record, inside it, at its end
def test_a_full_disk_while_writing_a_checkpoint_raises_enospc_naming_it_and_leaves_no_temporary_file(
    room, disk_with_room, tmp_path
):
    disk_with_room(room)
    with pytest.raises(OSError) as raised:  # torch's zip writer turns a failed write into "unexpected pos"
        save_checkpoint(tmp_path, {"weights": torch.zeros(100_000), "step": 30})
    assert raised.value.errno == errno.ENOSPC
    assert raised.value.filename == str(checkpoint_path(tmp_path))
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_during_a_runs_first_checkpoint_raises_enospc_naming_it(disk_with_room, tmp_path):
    disk_with_room(20_000)
    with pytest.raises(OSError) as raised:
        train_sac(TASK, TINY, seed=0, checkpoint_dir=tmp_path)
    assert raised.value.errno == errno.ENOSPC
    assert raised.value.filename == str(checkpoint_path(tmp_path))
    assert list(tmp_path.iterdir()) == []


def test_the_entry_points_report_a_full_disk_during_a_checkpoint_in_one_line(disk_with_room, tmp_path, capsys):
    disk_with_room(20_000)
    entry_point = one_line_errors(lambda: train_sac(TASK, TINY, seed=0, checkpoint_dir=tmp_path))
    with pytest.raises(SystemExit) as raised:
        entry_point()
    assert raised.value.code == EXIT_DISK_FULL
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"error: disk full while writing {checkpoint_path(tmp_path)};")


def test_any_other_failure_of_the_write_propagates_unchanged_and_leaves_no_temporary_file(monkeypatch, tmp_path):
    bug = RuntimeError("a genuine bug")

    def save(obj, f, *args, **kwargs):
        f.write(b"some bytes")
        raise bug

    monkeypatch.setattr(torch, "save", save)
    with pytest.raises(RuntimeError) as raised:
        save_checkpoint(tmp_path, {"step": 1})
    assert raised.value is bug
    assert list(tmp_path.iterdir()) == []
