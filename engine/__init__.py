"""Hitpoint engine: numpy-only animation maths, BVH I/O, IK adaptation and PCA.

Never imports the app, glfw, moderngl or imgui.

numba's disk cache is put, once here, in a directory named by a hash of the engine's
sources (:func:`numba_cache_dir`): numba checks only the timestamp of the file that
defines a kernel, so a kernel whose callee in another module changed would otherwise be
loaded stale. Any edit to any engine module gives a fresh directory; directories of
other sources, unused for an hour, are pruned. A user's ``NUMBA_CACHE_DIR`` is kept as
the place, with the keyed directory inside it.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import sys
import time
from pathlib import Path

CACHE_PREFIX = "hitpoint-engine-"
PRUNE_AFTER_S = 3600.0     # a cache of other sources unused this long is deleted


def sources_key(folder: Path) -> str:
    """Hash (16 hex digits) of the names and contents of the engine's ``*.py`` files."""
    h = hashlib.blake2b(digest_size=8)
    for f in sorted(folder.glob("*.py")):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def _writable_base(here: Path) -> Path:
    """Where the keyed cache directories live: the user's NUMBA_CACHE_DIR, else the
    engine's __pycache__ (one per checkout), else the user's cache folder."""
    user = os.environ.get("NUMBA_CACHE_DIR", "")
    if user:
        base = Path(user)
        # a child process inherits the keyed directory set by its parent
        return base.parent if base.name.startswith(CACHE_PREFIX) else base
    for base in (here / "__pycache__",
                 Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "hitpoint"):
        try:
            base.mkdir(parents=True, exist_ok=True)
            if os.access(base, os.W_OK):
                return base
        except OSError:
            continue
    return here / "__pycache__"


def _prune(base: Path, keep: Path) -> None:
    """Delete the other keyed directories in ``base`` that no process has written for an hour."""
    now = time.time()
    try:
        for d in base.glob(CACHE_PREFIX + "*"):
            if d != keep and d.is_dir() and now - d.stat().st_mtime > PRUNE_AFTER_S:
                shutil.rmtree(d, ignore_errors=True)
    except OSError:
        pass


def numba_cache_dir() -> Path:
    """Set (once, before any kernel is defined) and return numba's cache directory."""
    here = Path(__file__).resolve().parent
    base = _writable_base(here)
    path = base / (CACHE_PREFIX + sources_key(here))
    os.environ["NUMBA_CACHE_DIR"] = str(path)
    if "numba" in sys.modules:      # numba read its config already: tell it too
        from numba.core import config
        config.CACHE_DIR = str(path)
    _prune(base, path)
    return path


NUMBA_CACHE_DIR = numba_cache_dir()
