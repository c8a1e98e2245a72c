"""Write files atomically: a temporary file beside the target, flushed to disk,
then a rename (and the folder flushed), so a failure, a crash or a power cut
never leaves a half-written or lost file. A writer killed mid-write leaves only
its temporary file ``.NAME.PID.XXXXXXXX.tmp.SUFFIX``; the next write to that
folder removes it."""
from __future__ import annotations

import contextlib
import errno
import os
import re
import tempfile
import time
from pathlib import Path

# A temporary file whose writer is still alive is left alone unless it has not
# changed for this long (its pid then belongs to another process).
STALE_TEMP_S = 600.0
# Temporary files from before the pid was in the name: removed after this long.
ORPHAN_AGE_S = 60.0
# One scan of a folder for orphans per process per this many seconds (an export
# writes thousands of frames into one folder).
RESCAN_S = 60.0

_TEMP = re.compile(r"^\..+?\.(?:(\d+)\.)?[a-z0-9_]{8}\.tmp(?:\.[^.]*)?$")
_scanned: dict[str, float] = {}
_writing: set[str] = set()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:        # someone else's process: alive
        return True
    return True


def _is_orphan(entry: os.DirEntry, now: float) -> bool:
    m = _TEMP.match(entry.name)
    if m is None or entry.path in _writing:
        return False
    age = now - entry.stat(follow_symlinks=False).st_mtime
    if m.group(1) is None:
        return age > ORPHAN_AGE_S
    return not _pid_alive(int(m.group(1))) or age > STALE_TEMP_S


def remove_orphans(folder: str | os.PathLike) -> int:
    """Remove the temporary files killed writers left in ``folder``; how many."""
    now, removed = time.time(), 0
    with contextlib.suppress(OSError), os.scandir(folder) as entries:
        for entry in entries:
            with contextlib.suppress(OSError):
                if entry.name.startswith(".") and entry.is_file(follow_symlinks=False) and _is_orphan(entry, now):
                    os.unlink(entry.path)
                    removed += 1
    return removed


def _remove_orphans_now_and_then(folder: Path) -> None:
    key, now = os.path.abspath(folder), time.monotonic()
    if now - _scanned.get(key, -RESCAN_S) >= RESCAN_S:
        _scanned[key] = now
        remove_orphans(folder)


def _fsync(path, flags: int = os.O_RDONLY) -> None:
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _named_for(e: OSError, target: Path) -> OSError:
    """The error naming the target rather than its temporary file (or nothing)."""
    ours = e.filename is None or os.path.basename(str(e.filename)).startswith(f".{target.name}.")
    if e.errno and ours:
        return OSError(e.errno, e.strerror or os.strerror(e.errno), str(target))
    return e


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike):
    """Yield a temporary path in the target's folder; on success it replaces
    ``path`` (with normal 0666 & ~umask permissions), on error it is removed.
    An OSError (full disk, read-only folder) names ``path``."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(errno.ENOENT, f"folder {folder} does not exist", str(target))
    _remove_orphans_now_and_then(folder)
    tmp, done = "", False
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{target.name}.{os.getpid()}.",
                                   suffix=".tmp" + target.suffix)
        os.close(fd)
        _writing.add(tmp)
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        _fsync(tmp)                       # the data is on disk before the name points at it
        os.replace(tmp, target)
        done = True
        with contextlib.suppress(OSError):    # some file systems cannot sync a folder
            _fsync(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError as e:
        raise _named_for(e, target) from None
    finally:
        _writing.discard(tmp)
        if tmp and not done:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def write_text(path: str | os.PathLike, text: str) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
