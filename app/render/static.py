"""The static scene pass: the ground (painter's order) with the stumps' shadow, the stumps,
uneven terrain where the view has one (``SceneView.terrain``), the stadium and the sky."""
from __future__ import annotations

import moderngl
import numpy as np

from . import props
from .gl import set_uniform
from .programs import frame_uniforms
from .shadow import IDENTITY
from .skinning import MeshGPU, vao

BACKGROUND = (0.60, 0.74, 0.90)


class StaticPass:
    def __init__(self, ctx, progs, shadow):
        self.ctx, self.p, self.shadow = ctx, progs, shadow
        self.wickets_mesh = props.wickets()
        self.wickets = MeshGPU(ctx, self.wickets_mesh, progs.static, progs.depth)
        gpos, gcol = props.ground()
        spos, scol = props.stadium()
        self._buffers = [ctx.buffer(a.astype("f4").tobytes()) for a in (gpos, gcol, spos, scol)]
        g0, g1, s0, s1 = self._buffers
        self.ground = vao(ctx, progs.ground, [(g0, "3f", "in_pos"), (g1, "3f", "in_color")])
        self.stadium = vao(ctx, progs.ground, [(s0, "3f", "in_pos"), (s1, "3f", "in_color")])
        self.sky = ctx.vertex_array(progs.sky, [])
        self._terrain = (None, None)     # (the view's terrain Mesh, its buffers)

    def draw(self, frame, fbo, origin=(0, 0)) -> None:
        """Into ``fbo`` at ``origin`` (its view rectangle cleared first); the stumps' shadow
        map is drawn here too."""
        ctx, p, view = self.ctx, self.p, frame.view
        if frame.shadows:
            self.shadow.draw_stumps_map()
        fbo.use()
        ctx.viewport = (*origin, *view.size)
        fbo.clear(*BACKGROUND, 1.0, depth=1.0, viewport=ctx.viewport)
        frame_uniforms(p, frame.vp, frame.eye, self.shadow.static_fit[0], frame.shadows and view.terrain is None,
                       self.shadow.static_tex)          # (the stumps' shadow falls on the pitch only)
        if view.show_pitch:
            ctx.depth_func = "1"
            self.ground.render()
            ctx.depth_func = "<"
            if frame.shadows:
                self.shadow.draw_receiver(self.shadow.static_fit[1], stumps=True)
        set_uniform(p.static, "u_mode", 0)
        set_uniform(p.static, "u_model", IDENTITY)
        if view.terrain is None:         # the stumps stand on the pitch, not on a terrain
            ctx.enable(moderngl.CULL_FACE)
            self.wickets.lit.render()
            ctx.disable(moderngl.CULL_FACE)
        if view.terrain is not None:
            self._terrain_gpu(view.terrain).lit.render()
        if view.show_pitch:
            self.stadium.render()    # flat-lit, after the near geometry so early-z skips hidden parts
        ctx.depth_func = "<="
        set_uniform(p.sky, "u_inv_view_proj", np.linalg.inv(frame.vp.astype(float)).astype(np.float32))
        self.sky.render(vertices=3)
        ctx.depth_func = "<"

    def _terrain_gpu(self, mesh) -> MeshGPU:
        """The terrain's buffers, made when the view's terrain mesh is new."""
        if self._terrain[0] is not mesh:
            self._terrain = (mesh, MeshGPU(self.ctx, mesh, self.p.static, self.p.depth))
        return self._terrain[1]
