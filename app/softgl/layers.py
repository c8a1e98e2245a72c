"""Cached layers of the scene (software GL): what holds still while the target is dragged
is drawn once into an offscreen framebuffer and reused.

* ``StaticLayer``: sky, ground with the stumps' shadow, stadium and stumps, for one camera
  and size, drawn with 4x MSAA (single-sampled while the camera moves) and resolved, then
  copied into each frame (colour and depth);
* ``GhostLayer``: the translucent ghost's nearest surface (colour with alpha, depth) for one
  camera and source pose, blended in over its screen box where it is nearer than the scene.
"""
from __future__ import annotations

import moderngl
import numpy as np

from app.render.gl import copy_rect, depth_writes, set_uniform
from app.softgl.screen_box import pixel_box, project_rect
from app.render.skinning import skinned_box_corners

STATIC_MSAA = 4


class Layer:
    """An offscreen framebuffer kept between frames, with the key of what it holds."""

    def __init__(self):
        self.key = None
        self.fbo = self.color = self.depth = None
        self._shape = None

    def framebuffer(self, ctx, size: tuple[int, int], samples: int, textures: bool):
        """The framebuffer for ``size``/``samples`` (recreated when they change); forgets the key."""
        shape = (size, samples, textures)
        if shape != self._shape:
            self.release()
            if textures:
                self.color = ctx.texture(size, 4)
                self.depth = ctx.depth_texture(size)
                self.depth.compare_func = ""
                for t in (self.color, self.depth):
                    t.filter = (moderngl.NEAREST, moderngl.NEAREST)
            else:
                self.color = ctx.renderbuffer(size, 4, samples=samples)
                self.depth = ctx.depth_renderbuffer(size, samples=samples)
            self.fbo = ctx.framebuffer(color_attachments=[self.color], depth_attachment=self.depth)
            self._shape = shape
        self.key = None
        return self.fbo

    def release(self) -> None:
        for obj in (self.fbo, self.color, self.depth):
            if obj is not None:
                obj.release()
        self.fbo = self.color = self.depth = None
        self._shape = self.key = None


class StaticLayer(Layer):
    def __init__(self, ctx, static_pass):
        super().__init__()
        self.ctx, self.static_pass = ctx, static_pass
        self._msaa = Layer()

    def copy_into(self, frame, target) -> bool:
        """Copy the static scene of ``frame``'s camera into ``target`` at ``frame.origin``
        (drawn first if the camera, size or switches changed); False when ``target`` cannot
        take a depth copy (the screen, no depth attachment)."""
        ctx, view = self.ctx, frame.view
        if target is ctx.screen or getattr(target, "depth_attachment", None) is None:
            return False
        samples = int(getattr(target, "samples", 0) or 0)
        size = tuple(view.size)
        msaa = min(STATIC_MSAA, ctx.max_samples) if samples == 0 and not view.camera_moving else 0
        key = (size, samples, msaa, np.asarray(view.view, np.float32).tobytes(),
               np.asarray(view.proj, np.float32).tobytes(), bool(view.show_pitch), frame.shadows, id(view.terrain))
        if key != self.key:
            fbo = self.framebuffer(ctx, size, samples, textures=False)
            if msaa > 1:        # drawn multisampled, resolved into the layer (colour and depth)
                self.static_pass.draw(frame, self._msaa.framebuffer(ctx, size, msaa, False))
                ctx.copy_framebuffer(fbo, self._msaa.fbo)
            else:
                self.static_pass.draw(frame, fbo)
            self.key = key
        copy_rect(ctx, target, self.fbo, frame.origin)
        return True


class GhostLayer(Layer):
    def __init__(self, ctx, progs, ghost_pass, joint_boxes):
        super().__init__()
        self.ctx, self.p, self.ghost_pass, self._joint_boxes = ctx, progs, ghost_pass, joint_boxes
        self.rect = None         # NDC box of the ghost (None: out of view)
        self.vao = ctx.vertex_array(progs.ghost, [])

    def update(self, frame) -> None:
        """Redraw the ghost's nearest surface if the camera, size, source pose or level changed."""
        view = frame.view
        ghost = np.asarray(view.ghost_skin_matrices, np.float32)
        key = (tuple(view.size), frame.vp.tobytes(), ghost.tobytes(), float(view.ghost_alpha), frame.level)
        if key == self.key:
            return
        ctx = self.ctx
        fbo = self.framebuffer(ctx, tuple(view.size), 0, textures=True)
        fbo.use()
        ctx.viewport = (0, 0, *view.size)
        self.rect = project_rect(skinned_box_corners(ghost, self._joint_boxes), frame.vp)
        # only the ghost's box is ever read (the composite covers self.rect): clear and draw
        # just there - a whole-viewport clear cost more than the ghost
        box = pixel_box(self.rect, view.size, 2) if self.rect is not None else None
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0, viewport=box)
        ctx.scissor = box
        set_uniform(self.p.static, "u_view_proj", frame.vp)
        set_uniform(self.p.static, "u_eye", frame.eye)
        self.ghost_pass.draw(frame, fbo)
        ctx.scissor = None
        self.key = key

    def composite(self, origin) -> None:
        """Blend the cached ghost over the bound target where it is nearer than the scene."""
        if self.rect is None:
            return                                        # no pixel of ghost in view
        self.color.use(1)
        self.depth.use(2)
        for name, value in (("u_ghost_color", 1), ("u_ghost_depth", 2), ("u_rect", self.rect),
                            ("u_origin", tuple(int(v) for v in origin))):
            set_uniform(self.p.ghost, name, value)
        self.ctx.depth_func = "<"
        depth_writes(self.ctx, False)
        self.vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        depth_writes(self.ctx, True)
