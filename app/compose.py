"""Frame composition: the 3D scene and the UI into one offscreen frame, then
(with a window) copied to the screen - only what changed, where the window keeps
its back buffer.

The 3D viewport is the left part of the window above the timeline: at render
scale 1 the renderer draws straight into the frame at the viewport's corner
(no intermediate copy), and an unchanged scene is restored from a cached copy
instead of being drawn again. At a lower render scale the scene goes to a
smaller framebuffer that is stretched into place. The panel and timeline
windows are opaque and the scene never draws under them, so nothing needs
clearing.
"""
from __future__ import annotations

import time

import moderngl
import numpy as np
from numba import njit

from app.render.gl import can_copy_regions, copy_rect

_BLIT_VS = """
#version 330
in vec2 in_pos; out vec2 uv;
void main() { uv = in_pos * 0.5 + 0.5; gl_Position = vec4(in_pos, 0.0, 1.0); }
"""
_BLIT_FS = """
#version 330
uniform sampler2D tex; in vec2 uv; out vec4 color;
void main() { color = vec4(texture(tex, uv).rgb, 1.0); }
"""
_PRESENT_FS = """
#version 330
uniform sampler2D tex; out vec4 color;
void main() { color = texelFetch(tex, ivec2(gl_FragCoord.xy), 0); }
"""
BACKGROUND = (0.11, 0.12, 0.14, 1.0)


def _release(fbo) -> None:
    if fbo is None:
        return
    for a in list(fbo.color_attachments) + [fbo.depth_attachment]:
        if a is not None:
            a.release()
    fbo.release()


class Compositor:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.frame: moderngl.Framebuffer | None = None    # window-sized: scene + UI
        self.cache: moderngl.Framebuffer | None = None    # copy of the last scene (scale 1)
        self.scaled: moderngl.Framebuffer | None = None   # scene at render scale < 1
        self.scene_key: str | None = None                 # what cache/scaled holds
        self.drawn_key: str | None = None                 # direct: last scene drawn, uncached
        self.viewport_px = (0, 0, 1, 1)                   # GL pixels, bottom-left origin
        self.frame_generation = 0                         # bumped when ``frame`` is recreated
        # what changed in ``frame`` since the last present (GL pixel rectangles), for windows
        # that keep their back buffer: only that is drawn to the screen (a full-window draw
        # costs ~6 ms on llvmpipe here)
        self.damage = FrameDamage()
        self._shown_key = None       # the scene whose image the frame holds (None: unknown)
        self._shown_static = None    # and, if it was rendered over the static layer, (static key, ChangedRegion)
        self._cache_static = None    # the same for the image in ``cache``
        self.last_present = None     # the regions the last present drew (None: the whole frame)
        self._present_way = None     # _present_by_draw or _present_by_blit, chosen at the first present
        prog = ctx.program(vertex_shader=_BLIT_VS, fragment_shader=_BLIT_FS)
        quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4").tobytes())
        self._blit = ctx.vertex_array(prog, [(quad, "2f", "in_pos")])
        present = ctx.program(vertex_shader=_BLIT_VS, fragment_shader=_PRESENT_FS)
        self._present = ctx.vertex_array(present, [(quad, "2f", "in_pos")])

    def resize(self, frame_size: tuple[int, int], viewport, window_size, scale: float) -> tuple[int, int]:
        """Fit the framebuffers to the window; returns the scene's pixel size."""
        fw, fh = max(int(frame_size[0]), 1), max(int(frame_size[1]), 1)
        if self.frame is None or self.frame.size != (fw, fh):
            _release(self.frame)
            self.frame = self.ctx.framebuffer([self.ctx.texture((fw, fh), 4)],
                                              self.ctx.depth_renderbuffer((fw, fh)))
            self.frame.use()
            self.frame.clear(*BACKGROUND)
            self.frame_generation += 1
            self.damage.everything()
            self.invalidate()
        k = fw / max(window_size[0], 1)        # framebuffer pixels per window pixel (HiDPI)
        x, y, w, h = (round(v * k) for v in viewport)
        self.viewport_px = (x, fh - y - h, max(w, 1), max(h, 1))
        # straight into the frame at scale 1 (away from its origin only where GL can copy regions)
        self.direct = scale >= 0.999 and (self.viewport_px[:2] == (0, 0) or can_copy_regions())
        size = self.viewport_px[2:] if self.direct else (max(round(w * scale), 1), max(round(h * scale), 1))
        target_attr = "cache" if self.direct else "scaled"
        target = getattr(self, target_attr)
        if target is None or target.size != tuple(size):
            _release(target)
            color = self.ctx.texture(tuple(size), 4)
            color.filter = (moderngl.LINEAR, moderngl.LINEAR)
            depth = None if self.direct else self.ctx.depth_renderbuffer(tuple(size))
            setattr(self, target_attr, self.ctx.framebuffer([color], depth))
            self.invalidate()
        return tuple(size)

    @property
    def scene_origin(self) -> tuple[int, int]:
        """Where the renderer draws the scene in the framebuffer it is given: at the
        viewport's corner in the frame (scale 1), else at the origin of ``scaled``."""
        return tuple(self.viewport_px[:2]) if self.direct else (0, 0)

    def invalidate(self) -> None:
        self.scene_key = None       # what the cache holds (direct) / what ``scaled`` holds
        self.drawn_key = None       # direct: the scene last drawn into the frame (not cached)
        self._shown_key = self._shown_static = self._cache_static = None

    def draw_scene(self, key: str | None, render, changed=lambda: None) -> None:
        """``render(fbo)`` draws the scene at origin into ``fbo``; skipped (the
        cached image is used) when ``key`` equals the last one cached. ``changed()``, asked
        after a render, says what it drew over which static layer: (static key or None,
        ``ChangedRegion``) or None when unknown (see ``SceneRenderer._note_changed``).

        At scale 1 the scene is drawn straight into the frame, and copied into the
        cache only when a scene repeats (the first idle frame after a drag or a
        playback draws it once more and keeps it): while the scene changes every
        frame (dragging, playing) no frame pays for a full-frame copy it never reuses."""
        ctx = self.ctx
        if self.direct:
            if key is not None and key == self.scene_key:
                copy_rect(ctx, self.frame, self.cache, self.scene_origin)   # restore the unchanged scene
                self._showing(key, self._cache_static)
                return
            repeat = key is not None and key == self.drawn_key
            self.drawn_key = None
            if render(self.frame):
                self.drawn_key = key
                self._showing(key, changed())
                if repeat:
                    copy_rect(ctx, self.cache, self.frame, src_origin=self.scene_origin,
                              depth=False)                         # keep it for idle frames
                    self.scene_key, self._cache_static = key, self._shown_static
            elif self.scene_key is not None:
                copy_rect(ctx, self.frame, self.cache, self.scene_origin)    # the last cached good image
                self._showing(self.scene_key, self._cache_static)
            else:
                self._showing(None, None)
            return
        self.damage.add([self.viewport_px])          # stretched into place every frame
        if key is None or key != self.scene_key:
            self.scene_key = key if render(self.scaled) else None
        self.frame.use()
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        ctx.viewport = self.viewport_px
        self.scaled.color_attachments[0].use(0)
        self._blit.render(moderngl.TRIANGLE_STRIP)
        ctx.viewport = (0, 0, self.frame.width, self.frame.height)

    def _showing(self, key, static) -> None:
        """The frame's scene region now holds the image of scene ``key`` (None: unknown),
        rendered over ``static`` = (static layer key, ``ChangedRegion``) (None: not known)."""
        if key is None or key != self._shown_key:
            old, new = self._shown_static, static
            if old is not None and new is not None and old[0] is not None and old[0] == new[0]:
                # both over the same static layer: only what was drawn over it differs
                self.damage.add([c for c in (old[1], new[1]) if c is not None])
            else:
                self.damage.add([self.viewport_px])
        self._shown_key, self._shown_static = key, static

    def present(self, window) -> None:
        """Copy the frame to a visible window and show it (no-op headless), by a blit or a
        textured draw, whichever was faster here (``_faster_present``). Where the window
        keeps its back buffer between swaps, only what changed since the last present is
        copied, and shown without sending the rest to the X server (``show_regions``)."""
        if window.glfw is None or not window.visible:
            self.damage.take(resolve=False)
            return
        regions = self.damage.take()
        if not getattr(window, "preserves_back_buffer", False):
            regions = None
        self.last_present = regions            # what the last present drew (None: everything)
        if self._present_way is None:
            self._present_way = self._faster_present()
        self._present_way([(0, 0, *self.frame.size)] if regions is None else regions)
        show = getattr(window, "show_regions", None)
        if regions is None or show is None or not show(regions):
            window.swap()

    def _present_by_draw(self, regions) -> None:
        ctx = self.ctx
        ctx.screen.use()
        ctx.viewport = (0, 0, self.frame.width, self.frame.height)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self.frame.color_attachments[0].use(0)
        for rect in regions:
            ctx.scissor = rect
            self._present.render(moderngl.TRIANGLE_STRIP)
        ctx.scissor = None

    def _present_by_blit(self, regions) -> None:
        for x, y, w, h in regions:
            copy_rect(self.ctx, self.ctx.screen, self.frame, (x, y), (x, y), depth=False, size=(w, h))

    def _faster_present(self):
        """Which of a textured draw and a blit copies the frame to the window faster here
        (llvmpipe converts the pixel format either way; which wins differs between machines):
        each timed twice over the whole frame, once, before the first present."""
        if not can_copy_regions():
            return self._present_by_draw
        whole = [(0, 0, *self.frame.size)]
        best = {}
        for way in (self._present_by_draw, self._present_by_blit) * 2:
            self.ctx.finish()
            t0 = time.perf_counter()
            way(whole)
            self.ctx.finish()
            best[way] = min(best.get(way, np.inf), time.perf_counter() - t0)
        return min(best, key=best.get)

    def release(self) -> None:
        for fbo in (self.frame, self.cache, self.scaled):
            _release(fbo)
        self.frame = self.cache = self.scaled = None


class FrameDamage:
    """Rectangles (x, y, w, h, GL pixels) of the frame that changed since the last present,
    or objects whose ``box()`` gives one or None (``SceneRenderer.changed``: worked out only
    if presented). ``take`` hands over those and the ones before them (what a frame drew
    over - a popup over the scene - changes back in the next one), merged where close."""

    def __init__(self):
        self._now: list = []
        self._before: list = []
        self._all = True           # everything changed (a new frame)

    def add(self, rects) -> None:
        self._now.extend(rects)

    def everything(self) -> None:
        self._all = True

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
