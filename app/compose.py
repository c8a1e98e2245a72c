"""Frame composition: the 3D scene and the UI into one offscreen frame, then
(with a window) one blit to the screen.

The 3D viewport is the left part of the window above the timeline: at render
scale 1 the renderer draws straight into the frame at the viewport's corner
(no intermediate copy), and an unchanged scene is restored from a cached copy
instead of being drawn again. At a lower render scale the scene goes to a
smaller framebuffer that is stretched into place. The panel and timeline
windows are opaque and the scene never draws under them, so nothing needs
clearing.
"""
from __future__ import annotations

import moderngl
import numpy as np

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

    def draw_scene(self, key: str | None, render) -> None:
        """``render(fbo)`` draws the scene at origin into ``fbo``; skipped (the
        cached image is used) when ``key`` equals the last one cached.

        At scale 1 the scene is drawn straight into the frame, and copied into the
        cache only when a scene repeats (the first idle frame after a drag or a
        playback draws it once more and keeps it): while the scene changes every
        frame (dragging, playing) no frame pays for a full-frame copy it never reuses."""
        ctx = self.ctx
        if self.direct:
            if key is not None and key == self.scene_key:
                copy_rect(ctx, self.frame, self.cache, self.scene_origin)   # restore the unchanged scene
                return
            repeat = key is not None and key == self.drawn_key
            self.drawn_key = None
            if render(self.frame):
                self.drawn_key = key
                if repeat:
                    copy_rect(ctx, self.cache, self.frame, src_origin=self.scene_origin,
                              depth=False)                         # keep it for idle frames
                    self.scene_key = key
            elif self.scene_key is not None:
                copy_rect(ctx, self.frame, self.cache, self.scene_origin)    # the last cached good image
            return
        if key is None or key != self.scene_key:
            self.scene_key = key if render(self.scaled) else None
        self.frame.use()
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        ctx.viewport = self.viewport_px
        self.scaled.color_attachments[0].use(0)
        self._blit.render(moderngl.TRIANGLE_STRIP)
        ctx.viewport = (0, 0, self.frame.width, self.frame.height)

    def present(self, window) -> None:
        """Draw the frame to a visible window and swap (no-op headless). A draw, not a
        blit: the window's buffer has another pixel format, and llvmpipe's blit between
        formats costs twice a textured full-window draw."""
        if window.glfw is None or not window.visible:
            return
        ctx = self.ctx
        ctx.screen.use()
        ctx.viewport = (0, 0, self.frame.width, self.frame.height)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self.frame.color_attachments[0].use(0)
        self._present.render(moderngl.TRIANGLE_STRIP)
        window.swap()

    def release(self) -> None:
        for fbo in (self.frame, self.cache, self.scaled):
            _release(fbo)
        self.frame = self.cache = self.scaled = None
