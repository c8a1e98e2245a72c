"""The overlay pass: thick lines and round points (geometry shaders), blended, drawn over
the scene: polylines, crosses and skeletons (on top of the meshes by default)."""
from __future__ import annotations

import moderngl
import numpy as np

from .gl import DynamicBuffer, depth_writes, set_uniform


def _rgba(c) -> tuple:
    c = tuple(float(x) for x in c)
    return c if len(c) == 4 else c + (1.0,)


class OverlayPass:
    def __init__(self, ctx, progs):
        self.ctx, self.p = ctx, progs
        self.line_buf = DynamicBuffer(ctx)
        self.point_buf = DynamicBuffer(ctx)
        self._vaos = {}

    @staticmethod
    def _line_vertices(view) -> tuple[np.ndarray, np.ndarray]:
        """Vertex rows (x,y,z,r,g,b,a,width) for depth-tested lines and for on-top lines."""
        tested, on_top = [], []

        def seg(a, b, rgba, width, out):
            n = len(a)
            v = np.empty((2 * n, 8), np.float32)
            v[0::2, :3], v[1::2, :3] = a, b
            v[:, 3:7] = rgba
            v[:, 7] = width
            out.append(v)

        for pts, rgba, width in view.polylines:
            pts = np.asarray(pts, float)
            if len(pts) >= 2:
                seg(pts[:-1], pts[1:], _rgba(rgba), width, tested)
        for pts, rgba, size in view.crosses:
            pts = np.asarray(pts, float).reshape(-1, 3)
            for axis in np.eye(3):
                seg(pts - axis * size / 2, pts + axis * size / 2, _rgba(rgba), 3.0, tested)
        for pos, parents, rgba in view.skeleton_lines:
            pos, parents = np.asarray(pos, float), np.asarray(parents)
            child = np.nonzero(parents >= 0)[0]
            seg(pos[parents[child]], pos[child], _rgba(rgba), view.skeleton_width_px,
                on_top if view.skeleton_on_top else tested)
        cat = lambda L: np.concatenate(L) if L else np.zeros((0, 8), np.float32)
        return cat(tested), cat(on_top)

    @staticmethod
    def _point_vertices(view) -> np.ndarray:
        rows = []
        for pts, rgba, size in view.points:
            pts = np.asarray(pts, float).reshape(-1, 3)
            v = np.empty((len(pts), 8), np.float32)
            v[:, :3], v[:, 3:7], v[:, 7] = pts, _rgba(rgba), size
            rows.append(v)
        for pos, _, rgba in view.skeleton_lines:
            pos = np.asarray(pos, float)
            v = np.empty((len(pos), 8), np.float32)
            c = np.array(_rgba(rgba))
            v[:, :3], v[:, 3:7], v[:, 7] = pos, c, view.skeleton_width_px * 2.2
            rows.append(v)
        return np.concatenate(rows) if rows else np.zeros((0, 8), np.float32)

    def _vao(self, prog, dyn: DynamicBuffer):
        """The VAO over ``dyn`` (rebuilt when the buffer was replaced by a larger one)."""
        cached = self._vaos.get(id(dyn))
        if cached is None or cached[0] != dyn.generation:
            vao = self.ctx.vertex_array(prog, [(dyn.buffer, "3f 4f 1f", "in_pos", "in_color", "in_width")])
            self._vaos[id(dyn)] = cached = (dyn.generation, vao)
        return cached[1]

    def draw(self, frame) -> tuple:
        """Draw the lines and points; returns their vertex rows (x, y, z, r, g, b, a, width):
        lines ``(2N, 8)`` in pairs, points ``(M, 8)``."""
        ctx, view, size = self.ctx, frame.view, frame.view.size
        tested, on_top = self._line_vertices(view)
        points = self._point_vertices(view)
        if not (len(tested) or len(on_top) or len(points)):
            return tested, points
        lines = np.concatenate([tested, on_top])
        for p in (self.p.line, self.p.point):
            set_uniform(p, "u_view_proj", frame.vp)
            set_uniform(p, "u_viewport", (float(size[0]), float(size[1])))
        depth_writes(ctx, False)
        if len(lines):
            self.line_buf.update(lines.tobytes())
            vao = self._vao(self.p.line, self.line_buf)
            if len(tested):
                vao.render(moderngl.LINES, vertices=len(tested))
            if len(on_top):
                ctx.disable(moderngl.DEPTH_TEST)
                vao.render(moderngl.LINES, vertices=len(on_top), first=len(tested))
                ctx.enable(moderngl.DEPTH_TEST)
        if len(points):
            self.point_buf.update(points.tobytes())
            vao = self._vao(self.p.point, self.point_buf)
            n_user = sum(len(np.asarray(p[0]).reshape(-1, 3)) for p in view.points)
            if n_user:
                vao.render(moderngl.POINTS, vertices=n_user)
            if len(points) > n_user:
                if view.skeleton_on_top:
                    ctx.disable(moderngl.DEPTH_TEST)
                vao.render(moderngl.POINTS, vertices=len(points) - n_user, first=n_user)
                ctx.enable(moderngl.DEPTH_TEST)
        depth_writes(ctx, True)
        return lines, points
