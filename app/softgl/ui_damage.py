"""Damage tracking for the immediate-mode UI: redraw only the parts of the
docked panel whose draw commands changed since the last frame.

ImGui rebuilds every vertex every frame, and on software GL (llvmpipe) filling
the panel's ~270k pixels costs ~3 ms, most of a frame budget. But between two
frames of a drag only a few readout lines and the blend plot change. The frame
buffer keeps last frame's pixels where nothing else draws (the panel and the
timeline: the ``keeps`` rectangles), so there it is enough to redraw horizontal bands whose
sequence of triangles changed; everywhere else (popups and tooltips over
the 3D view, which is redrawn each frame) the UI is drawn in full.

Redrawing a band with the scissor set to it gives the same pixels as a full
redraw: every triangle touching the band is drawn again, in the original order,
over the panel's opaque window background.

Pure numpy on flat arrays; ``app.imgui_gl`` turns the batches into GL draws (software GL only: see ``app.softgl``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

BAND_PX = 8.0      # band height in display pixels: one text line is ~2 bands
_MIX = np.random.default_rng(0x41A7).integers(1, 2**63, size=32, dtype=np.uint64) | np.uint64(1)


@dataclass
class UiGeometry:
    """One frame's UI triangles, flattened over all draw lists and commands.

    ``words (N, 5) uint32`` raw vertices (pos 2f, uv 2f, colour 4 bytes);
    ``positions (N, 2) float32`` in display pixels; ``indices (T, 3) uint32``
    into the vertices, in draw order; ``tri_cmd (T,) int`` the command of each
    triangle; per command ``clips (C, 4) float32`` (x0, y0, x1, y1) and
    ``textures (C,) int64``."""
    words: np.ndarray
    positions: np.ndarray
    indices: np.ndarray
    tri_cmd: np.ndarray
    clips: np.ndarray
    textures: np.ndarray


@dataclass
class Batch:
    """Draw triangles ``first .. first + count`` of the batch index array
    (in index units) with the scissor ``rect`` (x0, y0, x1, y1, display pixels)
    and texture ``texture``."""
    first: int
    count: int
    rect: tuple
    texture: int
    bounds: tuple = ()     # (x0, y0, x1, y1) what the triangles can touch inside ``rect``


def triangle_rects(geo: UiGeometry) -> np.ndarray:
    """Screen rectangles ``(T, 4)`` each triangle can touch: its bounding box
    cut by its command's clip rectangle (empty when x1 <= x0 or y1 <= y0)."""
    return _triangle_rects(geo.positions, geo.indices, geo.tri_cmd.astype(np.int64), geo.clips)


def triangle_hashes(geo: UiGeometry) -> np.ndarray:
    """A 64-bit hash ``(T,)`` of each triangle's vertices, clip and texture: a
    random odd-weighted sum of its 32-bit words (any change of one word changes it)."""
    clip_words = np.ascontiguousarray(geo.clips, np.float32).view(np.uint32).astype(np.uint64)
    command = clip_words @ _MIX[5:9] + geo.textures.astype(np.uint64) * _MIX[9]   # (C,), wraps mod 2**64
    return _triangle_hashes(geo.words, geo.indices, geo.tri_cmd.astype(np.int64), command, _MIX)


def band_signatures(rects: np.ndarray, hashes: np.ndarray, keep: tuple) -> np.ndarray:
    """Per band of ``BAND_PX`` rows of the ``keep`` rectangle (x0, y0, x1, y1),
    a hash ``(B,)`` of the ordered sequence of triangles touching it."""
    x0, y0, x1, y1 = (float(v) for v in keep)
    n_bands = max(int(np.ceil((y1 - y0) / BAND_PX)), 1)
    return _band_signatures(rects, hashes, x0, y0, x1, y1, BAND_PX, n_bands)


# The per-triangle loops are compiled: numpy's per-call overhead on a few thousand
# triangles cost more (~1.5 ms a frame) than the pixels the tracking saves.
@njit(cache=True, nogil=True)
def _triangle_rects(positions, indices, tri_cmd, clips):
    T = indices.shape[0]
    out = np.empty((T, 4), np.float32)
    for t in range(T):
        a, b, c = indices[t, 0], indices[t, 1], indices[t, 2]
        k = tri_cmd[t]
        out[t, 0] = max(min(positions[a, 0], positions[b, 0], positions[c, 0]), clips[k, 0])
        out[t, 1] = max(min(positions[a, 1], positions[b, 1], positions[c, 1]), clips[k, 1])
        out[t, 2] = min(max(positions[a, 0], positions[b, 0], positions[c, 0]), clips[k, 2])
        out[t, 3] = min(max(positions[a, 1], positions[b, 1], positions[c, 1]), clips[k, 3])
    return out


@njit(cache=True, nogil=True)
def _triangle_hashes(words, indices, tri_cmd, command, mix):
    T, W = indices.shape[0], words.shape[1]
    out = np.empty(T, np.uint64)
    for t in range(T):
        h = command[tri_cmd[t]]
        for corner in range(3):
            v = indices[t, corner]
            for w in range(W):
                h += np.uint64(words[v, w]) * mix[10 + 5 * corner + w]
        out[t] = h ^ (h >> np.uint64(31))
    return out


@njit(cache=True, nogil=True)
def _band_signatures(rects, hashes, x0, y0, x1, y1, band_px, n_bands):
    sig = np.zeros(n_bands, np.uint64)
    count = np.zeros(n_bands, np.uint64)
    step = np.uint64(0x9E3779B97F4A7C15)
    for t in range(rects.shape[0]):
        rx0, ry0, rx1, ry1 = rects[t, 0], rects[t, 1], rects[t, 2], rects[t, 3]
        if rx1 <= rx0 or ry1 <= ry0 or rx0 >= x1 or rx1 <= x0 or ry0 >= y1 or ry1 <= y0:
            continue
        lo = min(max(int((ry0 - y0) // band_px), 0), n_bands - 1)
        hi = min(max(int((ry1 - y0 - 1e-3) // band_px), 0), n_bands - 1)
        for b in range(lo, hi + 1):
            sig[b] = sig[b] * step + hashes[t]      # order matters: a rolling hash per band
            count[b] += np.uint64(1)
    return sig ^ (count * step)


def dirty_rects(old: np.ndarray | None, new: np.ndarray, keep: tuple) -> list[tuple]:
    """Rectangles (x0, y0, x1, y1) over the runs of bands whose signature changed
    (all of ``keep`` when there is no previous frame to compare with)."""
    x0, y0, x1, y1 = keep
    if old is None or old.shape != new.shape:
        return [tuple(keep)]
    changed = np.concatenate([[False], old != new, [False]])
    edges = np.flatnonzero(changed[1:] != changed[:-1])
    return [(x0, y0 + a * BAND_PX, x1, min(y0 + b * BAND_PX, y1)) for a, b in zip(edges[0::2], edges[1::2])]


def outside(keeps: list[tuple], display: tuple) -> list[tuple]:
    """Rectangles covering ``display`` (x0, y0, x1, y1) minus every rectangle of
    ``keeps`` (which must not overlap one another)."""
    parts = [tuple(display)]
    for keep in keeps:
        parts = [piece for r in parts for piece in _subtract(r, keep)]
    return parts


def _subtract(r: tuple, keep: tuple) -> list[tuple]:
    """Up to four rectangles covering ``r`` minus ``keep``."""
    dx0, dy0, dx1, dy1 = r
    kx0, ky0, kx1, ky1 = (min(max(v, lo), hi) for v, lo, hi in zip(keep, (dx0, dy0) * 2, (dx1, dy1) * 2))
    if kx1 <= kx0 or ky1 <= ky0:
        return [tuple(r)]
    parts = [(dx0, dy0, dx1, ky0), (dx0, ky1, dx1, dy1), (dx0, ky0, kx0, ky1), (kx1, ky0, dx1, ky1)]
    return [p for p in parts if p[2] > p[0] and p[3] > p[1]]


def batches(geo: UiGeometry, rects: np.ndarray, regions: list[tuple]) -> tuple[np.ndarray, list[Batch]]:
    """The triangles to draw for ``regions``: an index array ``(K,) uint32`` and
    the batches drawing it, each scissored to (its command's clip) ∩ (its region)."""
    if not regions:
        return np.zeros(0, np.uint32), []
    region_arr = np.asarray(regions, np.float32).reshape(-1, 4)
    idx, runs, run_boxes = _select(rects, geo.tri_cmd.astype(np.int64), geo.indices, region_arr)
    out = []
    for (first, count, c, r), box in zip(runs, run_boxes):
        cx0, cy0, cx1, cy1 = (float(v) for v in geo.clips[c])
        rx0, ry0, rx1, ry1 = regions[r]
        rect = (max(cx0, rx0), max(cy0, ry0), min(cx1, rx1), min(cy1, ry1))
        if rect[2] > rect[0] and rect[3] > rect[1]:
            bounds = (max(rect[0], float(box[0])), max(rect[1], float(box[1])),
                      min(rect[2], float(box[2])), min(rect[3], float(box[3])))
            out.append(Batch(int(first), int(count), rect, int(geo.textures[c]), bounds))
    return idx, out


@njit(cache=True, nogil=True)
def _select(rects, tri_cmd, indices, regions):
    """Per region, the triangles touching it in draw order, cut into runs of one
    command: the index array and rows (first index, index count, command, region)."""
    T, R = rects.shape[0], regions.shape[0]
    idx = np.empty(3 * T * R, np.uint32)
    runs = np.empty((T * R, 4), np.int64)
    boxes = np.empty((T * R, 4), np.float32)       # per run: the box of its triangles
    n_idx = n_runs = 0
    for r in range(R):
        rx0, ry0, rx1, ry1 = regions[r, 0], regions[r, 1], regions[r, 2], regions[r, 3]
        current = -1
        for t in range(T):
            x0, y0, x1, y1 = rects[t, 0], rects[t, 1], rects[t, 2], rects[t, 3]
            if not (x0 < rx1 and x1 > rx0 and y0 < ry1 and y1 > ry0 and x1 > x0 and y1 > y0):
                continue
            if tri_cmd[t] != current:
                current = tri_cmd[t]
                runs[n_runs, 0], runs[n_runs, 1], runs[n_runs, 2], runs[n_runs, 3] = n_idx, 0, current, r
                boxes[n_runs, 0], boxes[n_runs, 1], boxes[n_runs, 2], boxes[n_runs, 3] = x0, y0, x1, y1
                n_runs += 1
            for k in range(3):
                idx[n_idx + k] = indices[t, k]
            n_idx += 3
            runs[n_runs - 1, 1] += 3
            b = boxes[n_runs - 1]
            b[0], b[1], b[2], b[3] = min(b[0], x0), min(b[1], y0), max(b[2], x1), max(b[3], y1)
    return idx[:n_idx].copy(), runs[:n_runs].copy(), boxes[:n_runs].copy()


class DamageTracker:
    """Remembers last frame's band signatures inside the ``keeps`` rectangles and
    plans the draws of the next frame: everything outside them, the changed bands inside."""

    def __init__(self):
        self._key = None
        self._signatures = None
        self.last_dirty_fraction = 1.0     # of the keep area redrawn by the last plan (stats, tests)

    def invalidate(self) -> None:
        self._key = self._signatures = None

    def plan(self, geo: UiGeometry, display: tuple, keeps, key) -> tuple[np.ndarray, list[Batch]]:
        """Index array and batches for this frame. ``keeps`` are the rectangles
        (x0, y0, x1, y1; not overlapping) nothing but the UI draws into, or None;
        ``key`` names the target's identity and size: a different key (or no
        ``keeps``) means a full redraw."""
        rects = triangle_rects(geo)
        keeps = [tuple(float(v) for v in k) for k in (keeps or ()) if k[2] > k[0] and k[3] > k[1]]
        if not keeps:
            self.invalidate()
            self.last_dirty_fraction = 1.0
            return batches(geo, rects, [display])
        full_key = (key, tuple(keeps), tuple(display))
        hashes = triangle_hashes(geo)
        signatures = [band_signatures(rects, hashes, k) for k in keeps]
        old = self._signatures if full_key == self._key else [None] * len(keeps)
        dirty = [r for o, s, k in zip(old, signatures, keeps) for r in dirty_rects(o, s, k)]
        self._key, self._signatures = full_key, signatures
        area = sum((r[2] - r[0]) * (r[3] - r[1]) for r in dirty)
        self.last_dirty_fraction = float(area / max(sum((k[2] - k[0]) * (k[3] - k[1]) for k in keeps), 1e-9))
        return batches(geo, rects, outside(keeps, display) + dirty)
