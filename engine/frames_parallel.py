"""Whole shots adapted on several cores: the frames are independent (each is solved from its
own start pose; tests/engine/test_adapt.py: one frame alone equals the whole shot's), so
:func:`run_frames` deals them out to worker threads, each running the compiled
:func:`engine.frames_nb.adapt_frames` (which releases the GIL) on its share with its own
output slots and its own copy of the only state a solve writes outside them, the humeri's
hold windows (engine.humerus_nb). The result is the same, bit for bit, as one call."""
from __future__ import annotations

import functools
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .frames_nb import adapt_frames

MAX_WORKERS = 4         # the shots' 67-74 frames: more threads, more hand-off than work
MIN_FRAMES = 12         # fewer frames to solve a worker: one call (a hand-off costs ~0.1 ms)
_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()       # the viewer's warm-up thread and its loop may both adapt


def worker_count() -> int:
    """Threads a whole shot is adapted on: the cores this process may use, at most MAX_WORKERS
    (``HITPOINT_THREADS`` overrides it; 1: one call on the caller's thread)."""
    env = os.environ.get("HITPOINT_THREADS", "").strip()
    if env.isdigit() and int(env) >= 1:
        return min(int(env), 64)
    return max(1, min(_cores(), MAX_WORKERS))


@functools.cache
def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not on Linux
        return os.cpu_count() or 1


def _outputs(K: int, J: int) -> tuple:
    """The kernel's output slots for K frames of J joints (its docstring lists them)."""
    return (np.empty((K, J, 4)), np.empty((K, J, 4)), np.empty((K, J, 3)), np.empty(K),
            np.empty((K, 3)), np.empty(K), np.empty(K), np.empty(K))


def _own_holds(chains: tuple) -> tuple:
    """The arm chains' tuples (engine.step_nb.Chain's fields, the hold last) with a private
    copy of each hold: its window is rewritten every frame."""
    return tuple(ch[:-1] + (tuple(a.copy() for a in ch[-1]),) for ch in chains)


def _workers_pool(helpers: int) -> ThreadPoolExecutor:
    """The shared pool, with room for ``helpers`` threads besides the caller's."""
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < helpers:
            if _pool is not None:       # a larger HITPOINT_THREADS: the old pool's threads go
                _pool.shutdown(wait=False)
            _pool_size = max(helpers, MAX_WORKERS - 1)
            _pool = ThreadPoolExecutor(_pool_size, thread_name_prefix="hitpoint-adapt")
        return _pool


def run_frames(frames: np.ndarray, num_joints: int, args: tuple, chains: tuple, rest: tuple) -> tuple:
    """:func:`engine.frames_nb.adapt_frames` of ``frames (K,)`` with args = (desired, blends,
    shot, start), chains = (left, right), rest = (opts, face): its outputs for the K frames,
    computed on up to :func:`worker_count` threads (frames dealt out in turn, so the costly
    ones round the hit are shared)."""
    K = len(frames)
    workers = 1
    if K >= 2 * MIN_FRAMES:     # (one frame, scrubbing: straight to the kernel)
        active = int(np.count_nonzero(args[1][frames] > 0.0))      # the rest stay the start pose: no work
        workers = min(worker_count(), active // MIN_FRAMES)
    if workers <= 1:
        out = _outputs(K, num_joints)
        adapt_frames(frames, *args, *chains, *rest, out)
        return out
    pool = _workers_pool(workers - 1)
    shares = [np.ascontiguousarray(frames[w::workers]) for w in range(workers)]
    outs = [_outputs(len(sh), num_joints) for sh in shares]
    jobs = [pool.submit(adapt_frames, shares[w], *args, *_own_holds(chains), *rest, outs[w])
            for w in range(1, workers)]
    adapt_frames(shares[0], *args, *chains, *rest, outs[0])
    for job in jobs:
        job.result()
    out = _outputs(K, num_joints)
    for w in range(workers):
        for whole, part in zip(out, outs[w]):
            whole[w::workers] = part
    return out
