"""The software-GL profile's compiled kernels (UI damage, screen boxes, present merging) and
whether they may be called yet. On a fresh install numba compiles them in ~6-8 s (measured
2026-12-02 in an Xvfb window); called from the window's thread that held back the first frame.
So until they are ready the tricks that need them stand aside (the UI is drawn whole, the
frame presented whole, the ghost drawn in the scene) and the engine's warm-up compiles them
behind the window: in its child process into numba's disk cache, then loaded by its thread.
Ready at once when the disk cache already holds them (every start after the first)."""
from __future__ import annotations

import threading

import numpy as np
from numba.core.dispatcher import Dispatcher

from app.softgl import present, screen_box, ui_damage

_ready = threading.Event()


def dispatchers() -> list[Dispatcher]:
    """Every compiled function of the profile's modules."""
    return [v for m in (ui_damage, screen_box, present) for v in vars(m).values()
            if isinstance(v, Dispatcher) and v.py_func.__module__ == m.__name__]


def ready() -> bool:
    """May the kernels be called without compiling in the caller's thread?"""
    if not _ready.is_set() and cached():
        _ready.set()                 # checked on disk once per start at most, then remembered
    return _ready.is_set()


def cached() -> bool:
    """Does numba's disk cache hold every kernel for the sources as they are?"""
    return all(k._cache._cache_file._load_index() for k in dispatchers())


def compile_all() -> None:
    """Each kernel called once through its public wrapper with the types the viewer passes
    (so the disk cache holds the signatures the window will ask for), then ready."""
    words = np.zeros((6, 5), np.uint32)
    words[:, :2] = np.array([[0, 0], [40, 0], [0, 30], [10, 10], [60, 10], [10, 50]], np.float32).view(np.uint32)
    geo = ui_damage.UiGeometry(words=words, positions=np.ascontiguousarray(words[:, :2]).view(np.float32),
                               indices=np.arange(6, dtype=np.uint32).reshape(-1, 3), tri_cmd=np.array([0, 1]),
                               clips=np.array([[0, 0, 100, 100]] * 2, np.float32), textures=np.array([1, 1], np.int64))
    ui_damage.DamageTracker().plan(geo, (0.0, 0.0, 100.0, 100.0), [(0.0, 0.0, 50.0, 100.0)], "warm-up")
    points = np.array([[0.0, 0.0, -10.0], [1.0, 1.0, -20.0]])
    screen_box.segments_rect(points, points[::-1], np.eye(4))
    screen_box.project_rect(points, np.eye(4))
    present.merge_rects([(0, 0, 10, 10), (5, 5, 10, 10)])
    _ready.set()
