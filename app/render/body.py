"""The body pass: the skinned batsman (one of his levels of detail) with his shadow on the
ground, then the ball and the target disc."""
from __future__ import annotations

import moderngl
import numpy as np

from . import props
from .gl import set_uniform
from .shadow import IDENTITY
from .skinning import MeshGPU, PosedBody, skinned_box_corners

LOD_MIN_PX = (520, 380)    # screen heights (px) from which levels 0, 1, ... are drawn; below: the last
LOD_HYSTERESIS = 0.08      # a level changes only 8 % past a threshold (no flicker while he moves)
HIGHLIGHT_EMISSIVE = (0.35, 0.30, 0.05)    # the target under the mouse


class BodyPass:
    """``levels``: the batsman's meshes, finest first. The finest is pixel-lit, the coarser
    ones vertex-lit with the shadow per pixel; the ball stays pixel-lit (a sharp highlight
    over a few pixels), the flat target vertex-lit (per-pixel shadow taps cost ~1 ms here)."""

    def __init__(self, ctx, progs, skin_progs, num_joints, levels, caster_mesh, ball_mesh, joint_boxes):
        self.ctx, self.p, self.levels = ctx, progs, levels
        self.posed = PosedBody(ctx, skin_progs, num_joints, levels, caster_mesh, (progs.static, progs.body_lit),
                               progs.depth)
        self.ball = MeshGPU(ctx, ball_mesh, progs.static, progs.depth)
        self.target = MeshGPU(ctx, props.target_disc(), progs.vertex_lit, progs.depth)
        self._joint_boxes = joint_boxes
        self._auto_level = 0        # the last level chosen by size (see detail_level)

    def draw(self, frame, shadow_quad) -> None:
        """The posed batsman, his shadow over the ground (receiver ``shadow_quad`` or None),
        the ball and the target."""
        ctx, p, view = self.ctx, self.p, frame.view
        ctx.enable(moderngl.CULL_FACE)    # every mesh is closed with outward winding
        set_uniform(p.static, "u_mode", 0)
        if view.skin_matrices is not None:
            self.posed.update(view.skin_matrices, frame.level)
            set_uniform(p.body_lit, "u_model", IDENTITY)
            set_uniform(p.static, "u_model", IDENTITY)
            self.posed.lit.render()
        if view.show_pitch and shadow_quad is not None:
            ctx.disable(moderngl.CULL_FACE)
            frame.shadow.draw_receiver(shadow_quad)       # after him: early-z skips what he covers
            ctx.enable(moderngl.CULL_FACE)
        if view.ball_position is not None:
            set_uniform(p.static, "u_model", props.translation(view.ball_position))
            self.ball.lit.render()
        if view.target_position is not None:
            set_uniform(p.vertex_lit, "u_model", props.target_model(view.target_position, view.target_normal))
            if view.target_highlight:
                set_uniform(p.vertex_lit, "u_emissive", HIGHLIGHT_EMISSIVE)
            self.target.lit.render()
            set_uniform(p.vertex_lit, "u_emissive", (0.0, 0.0, 0.0))
        ctx.disable(moderngl.CULL_FACE)

    def detail_level(self, view, vp: np.ndarray, by_size: bool) -> int:
        """The batsman's level of detail: ``view.detail`` if set, else with ``by_size`` by how
        tall his (and his ghost's) boxes stand on screen (``LOD_MIN_PX``), else the finest."""
        last = len(self.levels) - 1
        if view.detail is not None:
            return min(max(int(view.detail), 0), last)
        skins = [m for m in (view.skin_matrices, view.ghost_skin_matrices) if m is not None]
        if not by_size or last == 0 or not skins:
            return 0
        corners = np.concatenate([skinned_box_corners(m, self._joint_boxes) for m in skins])
        clip = np.concatenate([corners, np.ones((len(corners), 1))], 1) @ vp.astype(float).T
        if np.any(clip[:, 3] <= 1e-3):
            return 0                                  # the camera is in among him: close up
        ndc_y = clip[:, 1] / clip[:, 3]
        height_px = (ndc_y.max() - ndc_y.min()) * 0.5 * view.size[1]

        def level_at(scale: float) -> int:
            return min(next((i for i, px in enumerate(LOD_MIN_PX) if height_px >= px * scale),
                            len(LOD_MIN_PX)), last)
        # stay on the current level until the height is clearly past a threshold
        level = min(max(self._auto_level, level_at(1 - LOD_HYSTERESIS)), level_at(1 + LOD_HYSTERESIS))
        self._auto_level = level
        return level
