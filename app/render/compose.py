"""Frame composition: the 3D scene and the UI into one offscreen frame, then (with a
window) drawn to the screen.

The 3D viewport is the left part of the window above the timeline: at render scale 1 the
renderer draws straight into the frame at the viewport's corner; at a lower render scale
into a smaller framebuffer that is stretched into place. The panel and timeline windows
are opaque and the scene never draws under them, so nothing needs clearing.

The plain path presents the whole frame. On software GL (``app.softgl``), where the
window keeps its back buffer, only what changed since the last present is drawn and shown
(``app.softgl.present``).
"""
from __future__ import annotations

import moderngl
import numpy as np

from app import softgl
from app.render.gl import can_copy_regions
from app.softgl import kernels
from app.softgl.present import FrameDamage

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
    def __init__(self, ctx: moderngl.Context, software_gl: bool | None = None):
        self.ctx = ctx
        self.software_gl = softgl.enabled(ctx) if software_gl is None else bool(software_gl)
        self.frame: moderngl.Framebuffer | None = None    # window-sized: scene + UI
        self.scaled: moderngl.Framebuffer | None = None   # scene at render scale < 1
        self.viewport_px = (0, 0, 1, 1)                   # GL pixels, bottom-left origin
        self.direct = True                                # the scene is drawn into ``frame``
        self.frame_generation = 0                         # bumped when ``frame`` is recreated
        self.damage = FrameDamage()       # software GL: what changed in ``frame`` since the last present
        self.last_present = None          # the regions the last present drew (None: the whole frame)
        quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4").tobytes())
        self._blit = ctx.vertex_array(ctx.program(vertex_shader=_BLIT_VS, fragment_shader=_BLIT_FS),
                                      [(quad, "2f", "in_pos")])
        self._present = ctx.vertex_array(ctx.program(vertex_shader=_BLIT_VS, fragment_shader=_PRESENT_FS),
                                         [(quad, "2f", "in_pos")])

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
        k = fw / max(window_size[0], 1)        # framebuffer pixels per window pixel (HiDPI)
        x, y, w, h = (round(v * k) for v in viewport)
        self.viewport_px = (x, fh - y - h, max(w, 1), max(h, 1))
        # straight into the frame at scale 1 (away from its origin only where GL can copy regions)
        self.direct = scale >= 0.999 and (self.viewport_px[:2] == (0, 0) or can_copy_regions())
        if self.direct:
            return tuple(self.viewport_px[2:])
        size = (max(round(w * scale), 1), max(round(h * scale), 1))
        if self.scaled is None or self.scaled.size != size:
            _release(self.scaled)
            color = self.ctx.texture(size, 4)
            color.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.scaled = self.ctx.framebuffer([color], self.ctx.depth_renderbuffer(size))
        return size

    @property
    def scene_origin(self) -> tuple[int, int]:
        """Where the renderer draws the scene in the framebuffer it is given: at the
        viewport's corner in the frame (scale 1), else at the origin of ``scaled``."""
        return tuple(self.viewport_px[:2]) if self.direct else (0, 0)

    def draw_scene(self, render, changed=lambda: None) -> None:
        """``render(fbo)`` draws the scene at ``scene_origin`` into ``fbo`` (False: it failed).
        ``changed()``, asked after a render on software GL, says what it drew over which static
        layer: (static key or None, ``ChangedRegion``) or None (see ``SceneRenderer.changed``)."""
        ctx = self.ctx
        if self.direct:
            drawn = render(self.frame)
            if self.software_gl:
                self.damage.scene_drawn(changed() if drawn else None, self.viewport_px)
            return
        self.damage.add([self.viewport_px])          # stretched into place every frame
        render(self.scaled)
        self.frame.use()
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        ctx.viewport = self.viewport_px
        self.scaled.color_attachments[0].use(0)
        self._blit.render(moderngl.TRIANGLE_STRIP)
        ctx.viewport = (0, 0, self.frame.width, self.frame.height)

    def present(self, window) -> None:
        """Draw the frame to a visible window and show it (no-op headless). On software GL,
        where the window keeps its back buffer, only what changed since the last present."""
        partial = self.software_gl and getattr(window, "preserves_back_buffer", False) and kernels.ready()
        if window.glfw is None or not window.visible:
            self.damage.take(resolve=False)
            return
        regions = self.damage.take(resolve=partial)      # None: the whole frame
        self.last_present = regions
        ctx = self.ctx
        ctx.screen.use()
        ctx.viewport = (0, 0, self.frame.width, self.frame.height)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self.frame.color_attachments[0].use(0)
        for rect in [(0, 0, *self.frame.size)] if regions is None else regions:
            ctx.scissor = rect
            self._present.render(moderngl.TRIANGLE_STRIP)
        ctx.scissor = None
        if regions is None or not window.show_regions(regions):
            window.swap()

    def release(self) -> None:
        for fbo in (self.frame, self.scaled):
            _release(fbo)
        self.frame = self.scaled = None
