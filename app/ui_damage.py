"""Damage tracking for the immediate-mode UI: redraw only the parts of the
docked panel whose draw commands changed since the last frame.

ImGui rebuilds every vertex every frame, and on software GL (llvmpipe) filling
the panel's ~270k pixels costs ~3 ms, most of a frame budget. But between two
frames of a drag only a few readout lines and the blend plot change. The frame
buffer keeps last frame's pixels where nothing else draws (the panel area, the
``keep`` rectangle), so there it is enough to redraw horizontal bands whose
sequence of triangles changed; everywhere else (the timeline and popups over
the 3D view, which is redrawn each frame) the UI is drawn in full.

Redrawing a band with the scissor set to it gives the same pixels as a full
redraw: every triangle touching the band is drawn again, in the original order,
over the panel's opaque window background.

Pure numpy on flat arrays; ``app.imgui_gl`` turns the batches into GL draws.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BAND_PX = 8.0      # band height in display pixels: one text line is ~2 bands
_MIX = np.random.default_rng(0x41A7).integers(1, 2**63, size=32, dtype=np.uint64) | np.uint64(1)
_STEP = np.uint64(0x9E3779B97F4A7C15)


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


def triangle_rects(geo: UiGeometry) -> np.ndarray:
    """Screen rectangles ``(T, 4)`` each triangle can touch: its bounding box
    cut by its command's clip rectangle (empty when x1 <= x0 or y1 <= y0)."""
    a, b, c = (geo.positions[geo.indices[:, k]] for k in range(3))   # (T, 2) each
    lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
    clip = geo.clips[geo.tri_cmd]
    return np.concatenate([np.maximum(lo, clip[:, :2]), np.minimum(hi, clip[:, 2:])], 1)


def triangle_hashes(geo: UiGeometry) -> np.ndarray:
    """A 64-bit hash ``(T,)`` of each triangle's vertices, clip and texture: a
    random odd-weighted sum of its 32-bit words (any change of one word changes it)."""
    vertex = geo.words.astype(np.uint64) @ _MIX[:5]                  # (N,) wraps mod 2**64
    vertex ^= vertex >> np.uint64(29)
    clip_words = np.ascontiguousarray(geo.clips, np.float32).view(np.uint32).astype(np.uint64)
    command = clip_words @ _MIX[5:9] + geo.textures.astype(np.uint64) * _MIX[9]   # (C,)
    i = geo.indices
    h = vertex[i[:, 0]] * _MIX[10] + vertex[i[:, 1]] * _MIX[11] + vertex[i[:, 2]] * _MIX[12] \
        + command[geo.tri_cmd]
    return h ^ (h >> np.uint64(31))


def band_signatures(rects: np.ndarray, hashes: np.ndarray, keep: tuple) -> np.ndarray:
    """Per band of ``BAND_PX`` rows of the ``keep`` rectangle (x0, y0, x1, y1),
    a hash ``(B,)`` of the ordered sequence of triangles touching it."""
    x0, y0, x1, y1 = keep
    n_bands = max(int(np.ceil((y1 - y0) / BAND_PX)), 1)
    inside = (rects[:, 0] < x1) & (rects[:, 2] > x0) & (rects[:, 1] < y1) & (rects[:, 3] > y0) \
        & (rects[:, 2] > rects[:, 0]) & (rects[:, 3] > rects[:, 1])
    tri = np.flatnonzero(inside)
    lo = np.clip(((rects[tri, 1] - y0) // BAND_PX).astype(np.int64), 0, n_bands - 1)
    hi = np.clip(((rects[tri, 3] - y0 - 1e-3) // BAND_PX).astype(np.int64), 0, n_bands - 1)
    span = hi - lo + 1
    pair_tri = np.repeat(tri, span)                      # (P,) triangle of each (band, triangle) pair
    pair_band = np.repeat(lo, span) + (np.arange(span.sum()) - np.repeat(np.cumsum(span) - span, span))
    order = np.argsort(pair_band, kind="stable")        # by band, then draw order
    pair_tri, pair_band = pair_tri[order], pair_band[order]
    starts = np.searchsorted(pair_band, np.arange(n_bands))
    rank = (np.arange(len(pair_band)) - starts[pair_band]).astype(np.uint64)
    # position-dependent mix: the same triangles in another order hash differently
    terms = hashes[pair_tri] * (rank * _STEP + np.uint64(1)) + rank
    sig = np.zeros(n_bands, np.uint64)
    used = np.flatnonzero(np.diff(np.concatenate([[-1], pair_band])))     # first pair of each band
    if len(used):
        sig[pair_band[used]] = np.add.reduceat(terms, used)
    return sig ^ np.bincount(pair_band, minlength=n_bands).astype(np.uint64) * _MIX[20]


def dirty_rects(old: np.ndarray | None, new: np.ndarray, keep: tuple) -> list[tuple]:
    """Rectangles (x0, y0, x1, y1) over the runs of bands whose signature changed
    (all of ``keep`` when there is no previous frame to compare with)."""
    x0, y0, x1, y1 = keep
    if old is None or old.shape != new.shape:
        return [tuple(keep)]
    changed = np.concatenate([[False], old != new, [False]])
    edges = np.flatnonzero(changed[1:] != changed[:-1])
    return [(x0, y0 + a * BAND_PX, x1, min(y0 + b * BAND_PX, y1)) for a, b in zip(edges[0::2], edges[1::2])]


def outside(keep: tuple, display: tuple) -> list[tuple]:
    """Up to four rectangles covering ``display`` (x0, y0, x1, y1) minus ``keep``."""
    dx0, dy0, dx1, dy1 = display
    kx0, ky0, kx1, ky1 = (min(max(v, lo), hi) for v, lo, hi in zip(keep, (dx0, dy0) * 2, (dx1, dy1) * 2))
    parts = [(dx0, dy0, dx1, ky0), (dx0, ky1, dx1, dy1), (dx0, ky0, kx0, ky1), (kx1, ky0, dx1, ky1)]
    return [r for r in parts if r[2] > r[0] and r[3] > r[1]]


def batches(geo: UiGeometry, rects: np.ndarray, regions: list[tuple]) -> tuple[np.ndarray, list[Batch]]:
    """The triangles to draw for ``regions``: an index array ``(K,) uint32`` and
    the batches drawing it, each scissored to (its command's clip) ∩ (its region)."""
    chunks, out, first = [], [], 0
    for rx0, ry0, rx1, ry1 in regions:
        hit = np.flatnonzero((rects[:, 0] < rx1) & (rects[:, 2] > rx0) & (rects[:, 1] < ry1)
                             & (rects[:, 3] > ry0) & (rects[:, 2] > rects[:, 0]) & (rects[:, 3] > rects[:, 1]))
        if not len(hit):
            continue
        cmd = geo.tri_cmd[hit]
        cuts = np.flatnonzero(np.diff(cmd)) + 1
        for run in np.split(np.arange(len(hit)), cuts):
            c = int(cmd[run[0]])
            cx0, cy0, cx1, cy1 = geo.clips[c]
            rect = (max(cx0, rx0), max(cy0, ry0), min(cx1, rx1), min(cy1, ry1))
            if rect[2] <= rect[0] or rect[3] <= rect[1]:
                continue
            out.append(Batch(first, 3 * len(run), rect, int(geo.textures[c])))
            first += 3 * len(run)
            chunks.append(geo.indices[hit[run]].reshape(-1))
    idx = np.concatenate(chunks).astype(np.uint32) if chunks else np.zeros(0, np.uint32)
    return idx, out


class DamageTracker:
    """Remembers last frame's band signatures inside ``keep`` and plans the
    draws of the next frame: everything outside ``keep``, the changed bands inside."""

    def __init__(self):
        self._key = None
        self._signatures = None
        self.last_dirty_fraction = 1.0     # of the keep area redrawn by the last plan (stats, tests)

    def invalidate(self) -> None:
        self._key = self._signatures = None

    def plan(self, geo: UiGeometry, display: tuple, keep: tuple | None, key) -> tuple[np.ndarray, list[Batch]]:
        """Index array and batches for this frame. ``key`` names the target's
        identity and size: a different key (or ``keep`` None) means a full redraw."""
        rects = triangle_rects(geo)
        if keep is None or keep[2] <= keep[0] or keep[3] <= keep[1]:
            self.invalidate()
            self.last_dirty_fraction = 1.0
            return batches(geo, rects, [display])
        keep = tuple(float(v) for v in keep)
        full_key = (key, keep, tuple(display))
        sig = band_signatures(rects, triangle_hashes(geo), keep)
        old = self._signatures if full_key == self._key else None
        dirty = dirty_rects(old, sig, keep)
        self._key, self._signatures = full_key, sig
        area = sum((r[3] - r[1]) for r in dirty) / max(keep[3] - keep[1], 1e-9)
        self.last_dirty_fraction = float(area)
        return batches(geo, rects, outside(keep, display) + dirty)
