"""The shadow pass: the sun's depth maps and the receiver quads that darken the ground.

A coarse copy of the batsman (``BatsmanShadow`` in the glb) and a near ball cast into a
small map fitted tightly round them, redrawn only when the pose or the ball moves; the
stumps cast into their own map, drawn with the static scene. A receiver quad under each
shadow multiplies the ground by it, depth-tested after the opaque meshes."""
from __future__ import annotations

import moderngl
import numpy as np

from . import props
from .gl import DynamicBuffer, depth_writes, set_uniform
from .programs import SUN_DIR
from .skinning import skinned_box_corners
from .transforms import look_at

IDENTITY = np.eye(4, dtype=np.float32)
CUBE = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T     # (8,3) unit cube corners
SHADOW_SIZE = 256          # the batsman's shadow map, fitted tightly around him (~1 cm a texel)
STATIC_SHADOW_SIZE = 512   # the stumps'
BALL_CASTS_WITHIN_CM = 400  # a ball further than this from the batsman casts no shadow


def _shadow_target(ctx, size: int, coverage: bool = False):
    """A sun depth map (compare mode on) and its framebuffer; with ``coverage`` also an R8
    colour target the casters mark (the ground under them reads it: ``receiver_coverage.frag``)."""
    tex = ctx.depth_texture((size, size))
    tex.compare_func = "<="
    tex.repeat_x = tex.repeat_y = False
    colour = []
    if coverage:
        cov = ctx.texture((size, size), 1)
        cov.filter = (moderngl.LINEAR, moderngl.LINEAR)
        cov.repeat_x = cov.repeat_y = False
        colour = [cov]
    return tex, ctx.framebuffer(color_attachments=colour, depth_attachment=tex)


class ShadowPass:
    """Draws the sun's maps and the receivers; ``light`` is the batsman map's (view-projection,
    ground quad or None) after ``update``."""

    def __init__(self, ctx, progs, posed, ball, wickets, wickets_mesh, joint_boxes):
        self.ctx, self.p = ctx, progs
        self.posed, self.ball, self.wickets, self._joint_boxes = posed, ball, wickets, joint_boxes
        self.tex, self.fbo = _shadow_target(ctx, SHADOW_SIZE, coverage=True)
        self.coverage = self.fbo.color_attachments[0]
        self.static_tex, self.static_fbo = _shadow_target(ctx, STATIC_SHADOW_SIZE)
        self.receiver_buf = DynamicBuffer(ctx, 6 * 12)
        self.receiver = ctx.vertex_array(progs.receiver, [(self.receiver_buf.buffer, "3f", "in_pos")])
        self.receiver_cov = ctx.vertex_array(progs.receiver_cov, [(self.receiver_buf.buffer, "3f", "in_pos")])
        lo, hi = wickets_mesh.positions.min(0), wickets_mesh.positions.max(0)
        near_stumps = np.array(np.meshgrid(*zip(lo, (hi[0], hi[1], min(hi[2], 50.0))))).reshape(3, -1).T
        self.static_fit = fit_sun(near_stumps, STATIC_SHADOW_SIZE)   # the batting end's stumps
        self.light = (self.static_fit[0], None)
        self._key = ()
        self._ball = None          # the ball in the map (None: it casts none)

    def update(self, view) -> tuple:
        """The batsman's (and a near ball's) map, redrawn only when the pose or the ball moved.
        Returns (light view-projection, ground quad ``(6,3)`` under the shadow or None)."""
        body = None if view.skin_matrices is None else skinned_box_corners(view.skin_matrices, self._joint_boxes)
        ball = None if view.ball_position is None else np.asarray(view.ball_position, float)
        if ball is not None and body is not None and np.linalg.norm(ball - body.mean(0)) >= BALL_CASTS_WITHIN_CM:
            ball = None
        key = (None if view.skin_matrices is None else np.asarray(view.skin_matrices, np.float32).tobytes(),
               None if ball is None else ball.astype(np.float32).tobytes())
        if key != self._key:
            self._ball = ball
            pts = ([] if body is None else [body]) + ([] if ball is None else [ball + 4.0 * CUBE])
            self.light = fit_sun(np.concatenate(pts), SHADOW_SIZE) if pts else (self.static_fit[0], None)
            self._draw_map(self.fbo, SHADOW_SIZE, self.light[0], view.skin_matrices, ball, False)
            self._key = key
        return self.light

    def draw_stumps_map(self) -> None:
        self._draw_map(self.static_fbo, STATIC_SHADOW_SIZE, self.static_fit[0], None, None, True)

    def _draw_map(self, fbo, size: int, light_vp, skin_matrices, ball, wickets: bool) -> None:
        """Depth from the sun into ``fbo``: the posed batsman, the ball, the stumps."""
        ctx, depth = self.ctx, self.p.depth
        fbo.use()
        ctx.viewport = (0, 0, size, size)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.polygon_offset = (2.0, 4.0)
        set_uniform(depth, "u_view_proj", light_vp)
        set_uniform(depth, "u_model", IDENTITY)
        if skin_matrices is not None:
            self.posed.update(skin_matrices)
            self.posed.shadow.render()
        if wickets:
            self.wickets.depth.render()
        if ball is not None:
            set_uniform(depth, "u_model", props.translation(ball))
            self.ball.depth.render()
        ctx.polygon_offset = (0.0, 0.0)

    def draw_receiver(self, quad: np.ndarray, stumps: bool = False) -> None:
        """Multiply the ground by a map inside ``quad`` (6 points on y = 0) only, depth-tested
        so things standing on the ground are not darkened: the batsman's by one bilinear tap of
        his coverage texture, the stumps' (``stumps``) by 4 PCF taps of theirs."""
        self.receiver_buf.update(np.asarray(quad, np.float32).tobytes())
        ctx = self.ctx
        if stumps:
            self.static_tex.use(0)
            set_uniform(self.p.receiver, "u_shadow_texel", 1.0 / STATIC_SHADOW_SIZE)
            vao = self.receiver
        else:
            self.coverage.use(3)
            set_uniform(self.p.receiver_cov, "u_coverage", 3)
            vao = self.receiver_cov
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.DST_COLOR, moderngl.ZERO
        ctx.depth_func = "<="
        depth_writes(ctx, False)
        ctx.polygon_offset = (-1.0, -4.0)
        vao.render(vertices=6)
        ctx.polygon_offset = (0.0, 0.0)
        depth_writes(ctx, True)
        ctx.depth_func = "<"
        ctx.disable(moderngl.BLEND)


# world -> sun axes, and the transpose
_SUN_ROTATION = np.ascontiguousarray(look_at(SUN_DIR, (0.0, 0.0, 0.0)).astype(float)[:3, :3])
_SUN_ROTATION_T = np.ascontiguousarray(_SUN_ROTATION.T)


def fit_sun(points: np.ndarray, size: int, margin: float = 6.0) -> tuple[np.ndarray, np.ndarray]:
    """Orthographic sun view-projection ``(4,4)`` tightly holding ``points (N,3)`` and their
    shadows on the ground, and the ground quad ``(6,3)`` (y = 0) that those shadows fall in.

    The square's side is rounded up to 16 cm steps and its centre snapped to whole texels so
    the shadow's edges do not shimmer while the pose moves. Plain numpy: a few hundred points
    take ~0.1 ms, and a compiled version cost 10 s of compiling before a fresh install's
    first frame."""
    pts = np.asarray(points, float).reshape(-1, 3)
    sun = np.asarray(SUN_DIR, float)
    ground = pts - (pts[:, 1:2] / sun[1]) * sun          # the points slid down the sun's rays
    ground[:, 1] = 0.0
    both = np.concatenate([pts, ground])
    light_view = np.eye(4)                               # look_at(centre + 2000 sun, centre)
    light_view[:3, :3] = _SUN_ROTATION
    light_view[:3, 3] = -(_SUN_ROTATION @ (pts.mean(0) + sun * 2000.0))
    in_light = both @ _SUN_ROTATION_T + light_view[:3, 3]
    lo, hi = in_light.min(0) - margin, in_light.max(0) + margin
    half = np.ceil(max(hi[0] - lo[0], hi[1] - lo[1]) / 32.0) * 16.0
    texel = 2 * half / size
    cx, cy = np.round(0.5 * (lo[:2] + hi[:2]) / texel) * texel
    near, far = -hi[2] - margin, -lo[2] + margin
    proj = np.zeros((4, 4))
    proj[0, 0] = proj[1, 1] = 1 / half
    proj[0, 3], proj[1, 3] = -cx / half, -cy / half
    proj[2, 2], proj[2, 3] = -2 / (far - near), -(far + near) / (far - near)
    proj[3, 3] = 1.0
    # the ground quad: a rectangle along the sun's azimuth (shadows stretch that way)
    a0, a1 = sun[[0, 2]] / np.hypot(sun[0], sun[2])
    u = ground[:, 0] * a0 + ground[:, 2] * a1
    v = -ground[:, 0] * a1 + ground[:, 2] * a0
    u0, v0, u1, v1 = u.min() - margin, v.min() - margin, u.max() + margin, v.max() + margin
    uv = np.array([(u0, v0), (u1, v0), (u1, v1), (u0, v1)])
    corners = np.zeros((4, 3))
    corners[:, 0] = uv[:, 0] * a0 - uv[:, 1] * a1
    corners[:, 2] = uv[:, 0] * a1 + uv[:, 1] * a0
    vp = proj @ light_view
    return vp.astype(np.float32), corners[np.array([0, 1, 2, 0, 2, 3])].astype(np.float32)
