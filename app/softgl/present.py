"""Partial presents (software GL): a window that keeps its back buffer between swaps (Mesa's
software GL copies it to the window; GPU drivers usually flip buffers) needs only what
changed since the last present drawn to it, and shown with glXCopySubBufferMESA without
sending the rest of the window to the X server. A full-window draw costs ~6 ms on llvmpipe
at 1280x720, the X server's copy ~2 ms more."""
from __future__ import annotations

import ctypes

import numpy as np
from numba import njit


def keeps_back_buffer(window) -> bool:
    """Does the back buffer keep its pixels across a swap (software GL copies it to the
    window; GPU drivers usually flip buffers)? Then a frame needs to draw only what
    changed. Two swaps of two shades of the background, and a look at the back buffer."""
    shades = ((0.11, 0.12, 0.14), (0.13, 0.12, 0.14))
    try:
        for r, g, b in shades:
            window.ctx.screen.use()
            window.ctx.screen.clear(r, g, b, 1.0)
            window.swap()
        pixel = window.ctx.screen.read(viewport=(0, 0, 1, 1), components=3)
    except Exception:     # any doubt: present the whole frame every time
        return False
    return abs(pixel[0] - round(shades[1][0] * 255)) <= 1 and abs(pixel[0] - round(shades[0][0] * 255)) > 1


def sub_buffer_copier(window):
    """glXCopySubBufferMESA bound to this window, or None (not GLX, not Mesa): shows
    rectangles of the back buffer without sending the whole window to the X server
    (~2 ms of the server's CPU a frame at 1280x720 under Xvfb)."""
    try:
        gl = ctypes.CDLL("libGL.so.1")
        gl.glXQueryExtensionsString.restype = ctypes.c_char_p
        gl.glXQueryExtensionsString.argtypes = [ctypes.c_void_p, ctypes.c_int]
        display = window.glfw.get_x11_display()
        display = getattr(display, "value", display)
        if b"GLX_MESA_copy_sub_buffer" not in (gl.glXQueryExtensionsString(display, 0) or b"").split():
            return None
        gl.glXGetProcAddressARB.restype = ctypes.c_void_p
        address = gl.glXGetProcAddressARB(b"glXCopySubBufferMESA")
        drawable = int(window.glfw.get_glx_window(window.handle))
    except Exception:
        return None
    if not address or not drawable:
        return None
    copy = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                            ctypes.c_int, ctypes.c_int)(address)
    return lambda x, y, w, h: copy(display, drawable, int(x), int(y), int(w), int(h))

class FrameDamage:
    """Rectangles (x, y, w, h, GL pixels) of the frame that changed since the last present,
    or objects whose ``box()`` gives one or None (``SceneRenderer.changed``: worked out only
    if presented). ``take`` hands over those and the ones before them (what a frame drew
    over - a popup over the scene - changes back in the next one), merged where close."""

    def __init__(self):
        self._now: list = []
        self._before: list = []
        self._all = True           # everything changed (a new frame)
        self._shown_static = None  # the scene in the frame: (static layer key, ChangedRegion) or None

    def add(self, rects) -> None:
        self._now.extend(rects)

    def scene_drawn(self, static, viewport_px) -> None:
        """The scene was drawn over ``static`` = (static layer key, ``ChangedRegion``) (None: not
        known): over the same layer as the last one, only what both drew over it changed."""
        old = self._shown_static
        if old is not None and static is not None and old[0] is not None and old[0] == static[0]:
            self.add([c for c in (old[1], static[1]) if c is not None])
        else:
            self.add([viewport_px])
        self._shown_static = static

    def everything(self) -> None:
        self._all = True
        self._shown_static = None

    def take(self, resolve: bool = True) -> list | None:
        """The regions to present (None: all of it); starts the next frame's list."""
        regions = None
        if resolve and not self._all:
            boxes = [r.box() if hasattr(r, "box") else r for r in self._now + self._before]
            regions = merge_rects([tuple(int(v) for v in b) for b in boxes if b is not None and b[2] > 0 and b[3] > 0])
        self._before, self._now, self._all = self._now, [], False
        return regions


def merge_rects(rects: list, waste: int = 4096) -> list:
    """Rectangles (x, y, w, h) merged into bounding boxes wherever the box of two covers at
    most ``waste`` pixels more than they do (a few draws instead of many small ones, without
    drawing much that did not change). Overlaps are drawn twice: the same pixels."""
    if not rects:
        return []
    boxes = np.array([[x, y, x + w, y + h] for x, y, w, h in rects], np.int64)
    boxes = boxes[np.lexsort((boxes[:, 0], boxes[:, 1]))]
    for _ in range(2):              # the second pass folds boxes the first left apart
        boxes = _fold(boxes, waste)
    return [(int(x0), int(y0), int(x1 - x0), int(y1 - y0)) for x0, y0, x1, y1 in boxes]


@njit(cache=True)
def _fold(boxes, waste):
    """Each box into the first kept box it fits with, else kept: (M,4) of (x0, y0, x1, y1).
    Compiled: a frame has a few dozen, and in Python this cost a millisecond."""
    out = np.empty_like(boxes)
    m = 0
    for i in range(boxes.shape[0]):
        b = boxes[i]
        for k in range(m):
            o = out[k]
            x0, y0, x1, y1 = min(o[0], b[0]), min(o[1], b[1]), max(o[2], b[2]), max(o[3], b[3])
            if (x1 - x0) * (y1 - y0) <= (o[2] - o[0]) * (o[3] - o[1]) + (b[2] - b[0]) * (b[3] - b[1]) + waste:
                o[0], o[1], o[2], o[3] = x0, y0, x1, y1
                break
        else:
            out[m] = b
            m += 1
    return out[:m].copy()
