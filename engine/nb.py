"""The engine's one numba decorator, :func:`kernel`, and the version key of its cache.

numba caches a compiled function on disk and reuses it while the function's
own source file is unchanged; it does not look at the files of the functions
it inlined. Our kernels call into each other across modules (a solver in
adapt.py inlines the quaternion maths of quat_nb.py), so after an edit of
quat_nb.py numba would keep running the old code inside adapt's kernels.

Rather than deleting cache files at import time, every kernel of the engine
is cached under one explicit version key: the hash of all the modules listed
in KERNEL_MODULES. Editing any of them recompiles every kernel once (the
old entries are simply never matched again); nothing else in the cache, and
no other package's numba functions, are touched. The key is given to numba
through its cache-locator interface (a locator only for files of this
folder), so NUMBA_CACHE_DIR and the usual __pycache__ placement still apply.
"""
from __future__ import annotations

import hashlib
import os

from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))

# every engine module that defines or calls compiled code (add a new one here)
KERNEL_MODULES = ("nb.py", "quat_nb.py", "kinematics_nb.py", "solve_nb.py", "ccd.py", "dls.py",
                  "adapt.py", "cleanup.py", "pca.py", "ballistics.py")

_stamp_cache: dict = {}


def version_key() -> bytes:
    """sha256 of the kernel modules' sources (re-hashed when a file changes)."""
    paths = [os.path.join(HERE, m) for m in KERNEL_MODULES]
    stats = tuple((os.stat(p).st_mtime_ns, os.stat(p).st_size) if os.path.exists(p) else None
                  for p in paths)
    if stats not in _stamp_cache:
        h = hashlib.sha256()
        for p in paths:
            if os.path.exists(p):
                with open(p, "rb") as f:
                    h.update(f.read())
        _stamp_cache.clear()
        _stamp_cache[stats] = h.digest()
    return _stamp_cache[stats]


def _keyed(base):
    """``base`` locator for this folder's files, stamped with :func:`version_key`."""
    class EngineLocator(base):
        def get_source_stamp(self):
            return version_key()

        @classmethod
        def from_function(cls, py_func, py_file):
            if os.path.dirname(os.path.abspath(py_file)) != HERE:
                return None
            return super().from_function(py_func, py_file)
    EngineLocator.__name__ = EngineLocator.__qualname__ = f"Engine{base.__name__}"
    return EngineLocator


def _install_locators() -> None:
    try:
        from numba.core import caching
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
        ours = [_keyed(caching.UserProvidedCacheLocator), _keyed(caching.InTreeCacheLocator)]
    except (ImportError, AttributeError):      # another numba: its own per-file check applies
        return
    if not any(getattr(c, "__name__", "").startswith("Engine") for c in impl._locator_classes):
        impl._locator_classes = ours + list(impl._locator_classes)


_install_locators()


def kernel(fn):
    """``numba.njit(cache=True)``: every compiled function of the engine."""
    return njit(cache=True)(fn)


def inline_kernel(fn):
    """A small helper inlined into its callers at numba's level, so the reference
    counts of the arrays it reads from a namedtuple cancel out there (a call
    would pay an atomic increment and decrement per array)."""
    return njit(cache=True, inline="always")(fn)
