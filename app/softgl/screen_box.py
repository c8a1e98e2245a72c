"""Screen boxes of what the scene draws, for the software-GL tricks that touch only part of
the frame: the ghost layer's box and the region a render changed over the static layer
(``ChangedRegion``: what a window keeping its back buffer needs to present)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from app.render.skinning import skinned_box_corners

def project_rect(points: np.ndarray, vp: np.ndarray) -> tuple | None:
    """NDC rectangle (x0, y0, x1, y1) holding the solid spanned by world ``points (N,3)``; the
    whole viewport when it crosses the near plane, None when off screen (or all behind)."""
    r = segments_rect(points, points, vp, filled=True)
    return None if r is None or r[2] <= r[0] or r[3] <= r[1] else r


def segments_rect(starts: np.ndarray, ends: np.ndarray, vp: np.ndarray, filled: bool = False) -> tuple | None:
    """NDC rectangle (x0, y0, x1, y1) holding what shows of the segments ``starts (N,3)`` ->
    ``ends (N,3)`` (a point: start = end), or None when nothing does.

    Lines are clipped to GL's near plane (the ball's path from the bowler runs behind the
    eye and shows only up to it) and then to the screen (a long line's box is the part one
    sees). ``filled``: the points span one solid (a box's corners): the box of all of them,
    the whole screen when some lie behind the near plane, None when all do. Compiled: it
    runs every frame."""
    box = _ndc_box(np.ascontiguousarray(starts, float).reshape(-1, 3),
                   np.ascontiguousarray(ends, float).reshape(-1, 3), vp.astype(float), filled)
    return None if box[0] > box[2] else (float(box[0]), float(box[1]), float(box[2]), float(box[3]))


@njit(cache=True)
def _ndc_box(starts, ends, m, filled):
    out = np.array([np.inf, np.inf, -np.inf, -np.inf])
    a, b = np.empty(4), np.empty(4)
    behind = 0
    for i in range(starts.shape[0]):
        for r in range(4):
            a[r] = m[r, 0] * starts[i, 0] + m[r, 1] * starts[i, 1] + m[r, 2] * starts[i, 2] + m[r, 3]
            b[r] = m[r, 0] * ends[i, 0] + m[r, 1] * ends[i, 1] + m[r, 2] * ends[i, 2] + m[r, 3]
        da, db = a[2] + a[3], b[2] + b[3]           # >= 0 in front of the near plane
        if filled and (da < 0 or db < 0):
            behind += 1
            continue
        if da < 0 and db < 0:
            continue
        if da < 0 or db < 0:                        # cut at the plane
            t = da / (da - db)
            for r in range(4):
                c = a[r] + t * (b[r] - a[r])
                if da < 0:
                    a[r] = c
                else:
                    b[r] = c
        x0, y0 = a[0] / max(a[3], 1e-9), a[1] / max(a[3], 1e-9)
        dx, dy = b[0] / max(b[3], 1e-9) - x0, b[1] / max(b[3], 1e-9) - y0
        t0, t1 = 0.0, 1.0
        if not filled:                              # Liang-Barsky against the screen's square
            for p, d in ((x0, dx), (y0, dy)):
                if abs(d) < 1e-12:
                    if abs(p) > 1.0:
                        t0, t1 = 1.0, 0.0
                else:
                    ta, tb = (-1.0 - p) / d, (1.0 - p) / d
                    t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
            if t0 > t1:
                continue
        for t in (t0, t1):
            x, y = x0 + t * dx, y0 + t * dy
            out[0], out[1] = min(out[0], x), min(out[1], y)
            out[2], out[3] = max(out[2], x), max(out[3], y)
    if behind and behind < starts.shape[0]:         # a solid through the plane: all of the screen
        return np.array([-1.0, -1.0, 1.0, 1.0])
    if out[0] > out[2]:
        return out
    for k in range(4):
        out[k] = min(max(out[k], -1.0), 1.0)
    return out


def pixel_box(rect, size, grow: int) -> tuple | None:
    """Pixel box (x, y, w, h) of an NDC rectangle, ``grow`` pixels wider, inside ``size``;
    None when it is 10 pixels or less across."""
    x0, y0, x1, y1 = _pixel_corners(rect, size, grow)
    return (x0, y0, x1 - x0, y1 - y0) if x1 - x0 > 10 and y1 - y0 > 10 else None


def _pixel_corners(rect, size, grow: int) -> tuple:
    """(x0, y0, x1, y1) pixels of an NDC rectangle, ``grow`` pixels wider, inside ``size``."""
    w, h = size
    return (max(math.floor((rect[0] + 1) * 0.5 * w) - grow, 0),
            max(math.floor((rect[1] + 1) * 0.5 * h) - grow, 0),
            min(math.ceil((rect[2] + 1) * 0.5 * w) + grow, w),
            min(math.ceil((rect[3] + 1) * 0.5 * h) + grow, h))


CUBE = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T     # (8,3) unit cube corners
BALL_RADIUS_CM, TARGET_RADIUS_CM = 4.0, 32.0      # boxes round the ball and the target disc


def changed_region(view, vp, joint_boxes, shadow_quad, lines, points) -> "ChangedRegion":
    """What a render of ``view`` drew over its static layer: the batsman and his ghost, the
    ball, the target, his shadow on the ground (``shadow_quad`` or None) and the overlays'
    vertex rows ``lines``, ``points``."""
    skins = [m for m in (view.skin_matrices, view.ghost_skin_matrices) if m is not None]
    solids = [np.asarray(p, float) + r * CUBE for p, r in ((view.ball_position, BALL_RADIUS_CM),
                                                           (view.target_position, TARGET_RADIUS_CM)) if p is not None]
    if shadow_quad is not None:
        solids.append(np.asarray(shadow_quad, float))
    return ChangedRegion(view.size, view.origin, vp, skins, joint_boxes, solids, lines, points)


class ChangedRegion:
    """What one render drew over its static layer: ``box()`` is (x, y, w, h) in target
    pixels holding all of it, or None. Worked out only when asked (once): headless runs,
    which present nothing, never ask."""

    def __init__(self, size, origin, vp, skins, joint_boxes, solids, lines, points):
        self._inputs = (size, origin, vp, skins, joint_boxes, solids, lines, points)
        self._box = False

    def box(self) -> tuple | None:
        if self._box is not False:
            return self._box
        size, origin, vp, skins, joint_boxes, solids, lines, points = self._inputs
        solids = solids + [skinned_box_corners(m, joint_boxes) for m in skins]   # batsman, ghost
        rects = [segments_rect(pts, pts, vp, filled=True) for pts in solids]
        rects += [segments_rect(lines[0::2, :3], lines[1::2, :3], vp),
                  segments_rect(points[:, :3], points[:, :3], vp)]
        widest = float(max(lines[:, 7].max(initial=0.0), points[:, 7].max(initial=0.0)))
        # 12 px at least: FXAA reaches a few pixels past what moves, a point's disc 6 px past its centre
        box = _union_box([r for r in rects if r is not None], size, int(np.ceil(max(widest, 12.0))))
        self._box = None if box is None else (box[0] + origin[0], box[1] + origin[1], *box[2:])
        self._inputs = None
        return self._box


def _union_box(rects: list, size, grow: int) -> tuple | None:
    """Pixel box (x, y, w, h) holding NDC rectangles ``rects``, ``grow`` pixels wider, inside
    ``size``; None for no rectangles."""
    if not rects:
        return None
    x0, y0, x1, y1 = _pixel_corners((min(r[0] for r in rects), min(r[1] for r in rects),
                                     max(r[2] for r in rects), max(r[3] for r in rects)), size, grow)
    return (x0, y0, x1 - x0, y1 - y0) if x1 > x0 and y1 > y0 else None
