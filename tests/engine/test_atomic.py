"""engine.atomic: a write either replaces the file whole or leaves the old one;
a killed writer leaves only a temporary file, which the next write removes."""
from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from engine import atomic

from tests.conftest import ROOT

SLOW_WRITER = """
import sys, time
from engine.atomic import atomic_output
with atomic_output(sys.argv[1]) as tmp:
    with open(tmp, "wb") as f:
        for i in range(100000):
            f.write(b"x" * 65536)
            f.flush()
            if i == 4:
                print("writing", flush=True)
            time.sleep(0.01)
"""


def temp_files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_kill_9_mid_write_keeps_the_old_file_and_the_next_write_cleans_up(tmp_path):
    target = tmp_path / "big.bin"
    target.write_bytes(b"old")
    child = subprocess.Popen([sys.executable, "-c", SLOW_WRITER, str(target)], cwd=ROOT,
                             stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "writing"
        os.kill(child.pid, signal.SIGKILL)
    finally:
        child.wait(timeout=30)
    assert target.read_bytes() == b"old"
    left = temp_files(tmp_path)
    assert len(left) == 1 and left[0].startswith(f".big.bin.{child.pid}.") and left[0].endswith(".tmp.bin")
    assert (tmp_path / left[0]).stat().st_size > 0          # it was killed mid-write
    atomic.write_bytes(target, b"new")
    assert target.read_bytes() == b"new" and temp_files(tmp_path) == []


def test_orphans_without_a_pid_go_only_when_old(tmp_path):
    old, fresh = tmp_path / ".a.txt.abcd1234.tmp.txt", tmp_path / ".b.txt.wxyz_789.tmp.txt"
    old.write_text("x")
    fresh.write_text("y")
    os.utime(old, (time.time() - 2 * atomic.ORPHAN_AGE_S,) * 2)
    assert atomic.remove_orphans(tmp_path) == 1
    assert temp_files(tmp_path) == [fresh.name]


def test_a_live_writers_temp_file_is_left_alone_unless_stale(tmp_path):
    live = tmp_path / f".c.txt.{os.getpid()}.abcd1234.tmp.txt"
    live.write_text("x")
    other = tmp_path / ".notes.txt"        # not ours: never touched
    other.write_text("keep")
    os.utime(other, (0, 0))
    assert atomic.remove_orphans(tmp_path) == 0
    os.utime(live, (time.time() - 2 * atomic.STALE_TEMP_S,) * 2)
    assert atomic.remove_orphans(tmp_path) == 1
    assert temp_files(tmp_path) == [".notes.txt"]


def test_file_and_folder_are_synced(tmp_path, monkeypatch):
    synced = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (synced.append(os.readlink(f"/proc/self/fd/{fd}")), real(fd)))
    atomic.write_text(tmp_path / "s.txt", "data")
    assert len(synced) == 2 and synced[0].endswith(".tmp.txt") and synced[1] == str(tmp_path)


def test_failed_write_names_the_target_and_leaves_nothing(tmp_path, monkeypatch):
    target = tmp_path / "x.json"
    target.write_text("old")

    def full(path, flags=os.O_RDONLY):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(atomic, "_fsync", full)
    with pytest.raises(OSError) as e:
        atomic.write_text(target, "new")
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(target)
    assert target.read_text() == "old" and temp_files(tmp_path) == []


def test_missing_folder_is_refused_not_made(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        atomic.write_text(tmp_path / "no" / "such" / "x.txt", "x")
    assert list(tmp_path.iterdir()) == []


def test_permissions_follow_the_umask(tmp_path):
    mask = os.umask(0o027)
    try:
        atomic.write_text(tmp_path / "p.txt", "x")
    finally:
        os.umask(mask)
    assert (tmp_path / "p.txt").stat().st_mode & 0o777 == 0o640


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=2048), st.sampled_from([None, ValueError, KeyboardInterrupt, OSError]))
def test_write_replaces_whole_or_keeps_the_old(tmp_path_factory, data, failure):
    folder = tmp_path_factory.mktemp("w", numbered=True)
    target = folder / "f.bin"
    target.write_bytes(b"old")
    try:
        with atomic.atomic_output(target) as tmp:
            tmp.write_bytes(data)
            if failure is not None:
                raise failure("boom")
    except (ValueError, KeyboardInterrupt, OSError):
        pass
    assert target.read_bytes() == (b"old" if failure else data)
    assert temp_files(folder) == []
