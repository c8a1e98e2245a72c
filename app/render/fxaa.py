"""The antialias pass (``view.antialias``): FXAA over the whole view of a single-sampled
target, reading a copy of it (multisampled targets need none)."""
from __future__ import annotations

import moderngl

from .gl import copy_rect, set_uniform

WHOLE_VIEW = (-1.0, -1.0, 1.0, 1.0)     # NDC


class AntialiasPass:
    def __init__(self, ctx, progs):
        self.ctx, self.p = ctx, progs
        self.vao = ctx.vertex_array(progs.fxaa, [])
        self._copy = None         # a colour-only framebuffer of the view's size

    def draw(self, frame, target) -> None:
        ctx, size = self.ctx, tuple(frame.view.size)
        if self._copy is None or self._copy.size != size:
            if self._copy is not None:
                self._copy.color_attachments[0].release()
                self._copy.release()
            texture = ctx.texture(size, 4)
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            texture.repeat_x = texture.repeat_y = False
            self._copy = ctx.framebuffer([texture])
        copy_rect(ctx, self._copy, target, src_origin=frame.origin, depth=False, size=size)
        target.use()
        ctx.viewport = (*frame.origin, *size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self._copy.color_attachments[0].use(0)
        set_uniform(self.p.fxaa, "u_color", 0)
        set_uniform(self.p.fxaa, "u_texel", (1.0 / size[0], 1.0 / size[1]))
        set_uniform(self.p.fxaa, "u_rect", WHOLE_VIEW)
        self.vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        ctx.enable(moderngl.DEPTH_TEST)
