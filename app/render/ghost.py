"""The ghost pass: the source pose, translucent, skinned into buffers of its own."""
from __future__ import annotations

import moderngl

from .gl import color_writes, depth_writes, set_uniform
from .shadow import IDENTITY
from .skinning import PosedBody


class GhostPass:
    def __init__(self, ctx, progs, skin_progs, num_joints, levels):
        self.ctx, self.p = ctx, progs
        self.posed = PosedBody(ctx, skin_progs, num_joints, levels, None, (progs.static,), progs.depth)

    @staticmethod
    def wanted(view) -> bool:
        return view.ghost_skin_matrices is not None and view.ghost_alpha > 0

    def draw(self, frame, fbo) -> None:
        """A depth pre-pass (no colour), then only the nearest surface shaded and blended
        (blending set by the caller); the camera's uniforms must be set."""
        ctx, p, view = self.ctx, self.p, frame.view
        self.posed.update(view.ghost_skin_matrices, frame.level)
        ctx.enable(moderngl.CULL_FACE)
        set_uniform(p.depth, "u_view_proj", frame.vp)
        set_uniform(p.depth, "u_model", IDENTITY)
        color_writes(ctx, False)
        self.posed.shadow.render()
        color_writes(ctx, True)
        ctx.depth_func = "<="
        depth_writes(ctx, False)
        set_uniform(p.static, "u_model", IDENTITY)
        set_uniform(p.static, "u_mode", 1)
        set_uniform(p.static, "u_alpha", float(view.ghost_alpha))
        self.posed.lit.render()
        set_uniform(p.static, "u_mode", 0)
        set_uniform(p.static, "u_alpha", 1.0)
        depth_writes(ctx, True)
        ctx.depth_func = "<"
        ctx.disable(moderngl.CULL_FACE)
