"""Scene renderer: shadowed, lit, skinned batsman on a cricket ground, with overlays.

One ``SceneRenderer`` per GL context, tuned for Mesa llvmpipe (software GL: every
triangle and every shaded pixel costs CPU time):

* the static scene (sky, ground with the stumps' baked shadow, stadium, stumps) is
  drawn once per camera and size into a colour + depth layer and copied in per
  frame (dragging the target never moves the camera);
* the batsman is skinned once per pose on the GL side: a transform-feedback pass
  (``skin.vert``) reads static vertex buffers and one bone-matrix uniform block and
  writes skinned positions and normals into a buffer that the static programs draw
  (lit pass, shadow caster, ghost); a coarse copy of him (``BatsmanShadow`` in the glb) casts
  his shadow into a small map fitted tightly around him, redrawn only when the
  pose or the ball moves, and a receiver quad under his shadow darkens the
  (cached) ground, depth-tested after the opaque meshes;
* the translucent ghost's nearest surface (colour, alpha, depth) is a layer redrawn
  only when the source pose or the camera changes, blended in over its screen box;
* overlays: thick lines and round points via geometry shaders.

Matrices use the column-vector convention: ``p_clip = proj @ view @ p_world``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from . import props
from .gl import DynamicBuffer, copy_rect, depth_writes, mat_bytes, program, set_uniform, shader_source

IDENTITY = np.eye(4, dtype=np.float32)
_CUBE = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T     # (8,3) unit cube corners
LOD_MIN_PX = (520, 380)    # screen heights (px) from which levels 0, 1, ... are drawn; below: the last
LOD_HYSTERESIS = 0.08      # a level changes only 8 % past a threshold (no flicker while he moves)
GHOST_TILE_PX = 8          # the ghost composite covers the 8x8 pixel tiles its layer fills
SHADOW_SIZE = 256          # the batsman's shadow map, fitted tightly around him (~1 cm a texel)
STATIC_SHADOW_SIZE = 512    # the stumps' (drawn into the cached static layer)
BACKGROUND = (0.60, 0.74, 0.90)

# Lighting: a high sun on the off side, a little behind the batsman's front.
SUN_DIR = np.array([-0.55, 0.78, -0.30]) / np.linalg.norm([-0.55, 0.78, -0.30])
FILL_DIR = np.array([0.6, 0.35, 0.55]) / np.linalg.norm([0.6, 0.35, 0.55])
LIGHTING = {
    "u_sun_dir": tuple(SUN_DIR), "u_sun_color": (1.75, 1.66, 1.52),
    "u_fill_dir": tuple(FILL_DIR), "u_fill_color": (0.26, 0.28, 0.34),
    "u_sky_ambient": (0.30, 0.36, 0.47), "u_ground_ambient": (0.17, 0.20, 0.13),
    "u_haze_color": (0.80, 0.87, 0.95), "u_haze_density": 1.0 / 22000.0,
}
ZENITH, HORIZON = (0.24, 0.46, 0.82), (0.80, 0.87, 0.95)


@dataclass
class SceneView:
    view: np.ndarray              # (4,4) world->camera, float32, column-vector convention
    proj: np.ndarray              # (4,4)
    size: tuple[int, int]         # (w, h) pixels
    skin_matrices: np.ndarray | None  # (J,4,4) float32, engine.skeleton.skinning_matrices; None: no batsman
    ghost_skin_matrices: np.ndarray | None = None  # source pose, drawn translucent
    ghost_alpha: float = 0.25
    skeleton_lines: list = ()     # [(global_positions (J,3), parents (J,), rgba)]
    ball_position: np.ndarray | None = None
    target_position: np.ndarray | None = None     # red-and-white target disc
    target_normal: tuple = (0, 0, 1)
    target_highlight: bool = False
    crosses: list = ()            # [(points (N,3), rgba, size_cm)] e.g. nine FK hit points
    points: list = ()             # [(points (N,3), rgba, size_px)]
    polylines: list = ()          # [(points (N,3), rgba, width_px)]
    show_pitch: bool = True
    # optional extras
    origin: tuple[int, int] = (0, 0)  # lower-left corner of the view in the target (GL pixels)
    shadows: bool = True
    skeleton_width_px: float = 3.0
    skeleton_on_top: bool = True  # skeleton lines ignore depth (visible inside the mesh)
    antialias: bool = False       # single-sampled targets: FXAA over what moves
    static_antialias: bool = True  # single-sampled targets: the cached static scene drawn with 4x MSAA
    detail: int | None = None     # the batsman's level of detail (0 finest); None: by his size on screen


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """World->camera ``(4,4)`` float32 looking from ``eye`` at ``target``."""
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    if np.linalg.norm(s) < 1e-9:
        s = np.cross(f, (1.0, 0.0, 0.0))
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m.astype(np.float32)


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL perspective projection ``(4,4)`` float32."""
    t = 1.0 / np.tan(np.radians(fovy_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = t / aspect, t
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m.astype(np.float32)


def orthographic(half_w: float, half_h: float, near: float, far: float) -> np.ndarray:
    m = np.eye(4)
    m[0, 0], m[1, 1] = 1 / half_w, 1 / half_h
    m[2, 2], m[2, 3] = -2 / (far - near), -(far + near) / (far - near)
    return m.astype(np.float32)


def offscreen_context():
    """A standalone (headless, EGL) moderngl context, GL 3.3 core or newer."""
    import moderngl
    return moderngl.create_standalone_context(backend="egl", require=330)


def _skin_program(ctx, num_joints: int, with_normals: bool):
    """The transform-feedback skinning program (``shaders/skin.vert``, no rasterisation)."""
    src = shader_source("skin.vert").replace(
        "#version 330", f"#version 330\n#define NUM_JOINTS {num_joints}\n#define WITH_NORMALS {int(with_normals)}", 1)
    prog = ctx.program(vertex_shader=src, varyings=["out_pos", "out_normal"] if with_normals else ["out_pos"])
    prog["Bones"].binding = 0
    return prog


def _project_rect(points: np.ndarray, vp: np.ndarray) -> tuple | None:
    """NDC rectangle (x0, y0, x1, y1) holding the solid spanned by world ``points (N,3)``; the
    whole viewport when it crosses the near plane, None when off screen (or all behind)."""
    r = _segments_rect(points, points, vp, filled=True)
    return None if r is None or r[2] <= r[0] or r[3] <= r[1] else r


def _segments_rect(starts: np.ndarray, ends: np.ndarray, vp: np.ndarray, filled: bool = False) -> tuple | None:
    """NDC rectangle (x0, y0, x1, y1) holding what shows of the segments ``starts (N,3)`` ->
    ``ends (N,3)`` (a point: start = end), or None when nothing does.

    Lines are clipped to GL's near plane (the ball's path from the bowler runs behind the
    eye and shows only up to it) and then to the screen (a long line's box is the part one
    sees). ``filled``: the points span one solid (a box's corners): the box of all of them,
    the whole screen when some lie behind the near plane, None when all do. Compiled: it
    runs every frame."""
    box = _ndc_box(np.ascontiguousarray(starts, float).reshape(-1, 3),
                   np.ascontiguousarray(ends, float).reshape(-1, 3), vp.astype(float), filled)
    return None if box[0] > box[2] else (float(box[0]), float(box[1]), float(box[2]), float(box[3]))


@njit(cache=True)
def _ndc_box(starts, ends, m, filled):
    out = np.array([np.inf, np.inf, -np.inf, -np.inf])
    a, b = np.empty(4), np.empty(4)
    behind = 0
    for i in range(starts.shape[0]):
        for r in range(4):
            a[r] = m[r, 0] * starts[i, 0] + m[r, 1] * starts[i, 1] + m[r, 2] * starts[i, 2] + m[r, 3]
            b[r] = m[r, 0] * ends[i, 0] + m[r, 1] * ends[i, 1] + m[r, 2] * ends[i, 2] + m[r, 3]
        da, db = a[2] + a[3], b[2] + b[3]           # >= 0 in front of the near plane
        if filled and (da < 0 or db < 0):
            behind += 1
            continue
        if da < 0 and db < 0:
            continue
        if da < 0 or db < 0:                        # cut at the plane
            t = da / (da - db)
            for r in range(4):
                c = a[r] + t * (b[r] - a[r])
                if da < 0:
                    a[r] = c
                else:
                    b[r] = c
        x0, y0 = a[0] / max(a[3], 1e-9), a[1] / max(a[3], 1e-9)
        dx, dy = b[0] / max(b[3], 1e-9) - x0, b[1] / max(b[3], 1e-9) - y0
        t0, t1 = 0.0, 1.0
        if not filled:                              # Liang-Barsky against the screen's square
            for p, d in ((x0, dx), (y0, dy)):
                if abs(d) < 1e-12:
                    if abs(p) > 1.0:
                        t0, t1 = 1.0, 0.0
                else:
                    ta, tb = (-1.0 - p) / d, (1.0 - p) / d
                    t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
            if t0 > t1:
                continue
        for t in (t0, t1):
            x, y = x0 + t * dx, y0 + t * dy
            out[0], out[1] = min(out[0], x), min(out[1], y)
            out[2], out[3] = max(out[2], x), max(out[3], y)
    if behind and behind < starts.shape[0]:         # a solid through the plane: all of the screen
        return np.array([-1.0, -1.0, 1.0, 1.0])
    if out[0] > out[2]:
        return out
    for k in range(4):
        out[k] = min(max(out[k], -1.0), 1.0)
    return out


def _pixel_box(rect, size, grow: int) -> tuple | None:
    """Pixel box (x, y, w, h) of an NDC rectangle, ``grow`` pixels wider, inside ``size``;
    None when it is 10 pixels or less across."""
    x0, y0, x1, y1 = _pixel_corners(rect, size, grow)
    return (x0, y0, x1 - x0, y1 - y0) if x1 - x0 > 10 and y1 - y0 > 10 else None


def _pixel_corners(rect, size, grow: int) -> tuple:
    """(x0, y0, x1, y1) pixels of an NDC rectangle, ``grow`` pixels wider, inside ``size``."""
    w, h = size
    return (max(math.floor((rect[0] + 1) * 0.5 * w) - grow, 0),
            max(math.floor((rect[1] + 1) * 0.5 * h) - grow, 0),
            min(math.ceil((rect[2] + 1) * 0.5 * w) + grow, w),
            min(math.ceil((rect[3] + 1) * 0.5 * h) + grow, h))


class ChangedRegion:
    """What one render drew over its static layer: ``box()`` is (x, y, w, h) in target
    pixels holding all of it, or None. Worked out only when asked (once): headless runs,
    which present nothing, never ask."""

    def __init__(self, size, origin, vp, skins, joint_boxes, solids, lines, points):
        self._inputs = (size, origin, vp, skins, joint_boxes, solids, lines, points)
        self._box = False

    def box(self) -> tuple | None:
        if self._box is not False:
            return self._box
        size, origin, vp, skins, joint_boxes, solids, lines, points = self._inputs
        solids = solids + [skinned_box_corners(m, joint_boxes) for m in skins]   # batsman, ghost
        rects = [_segments_rect(pts, pts, vp, filled=True) for pts in solids]
        rects += [_segments_rect(lines[0::2, :3], lines[1::2, :3], vp),
                  _segments_rect(points[:, :3], points[:, :3], vp)]
        widest = float(max(lines[:, 7].max(initial=0.0), points[:, 7].max(initial=0.0)))
        # 12 px at least: FXAA's boxes reach 9 px past what moves, a point's disc 6 px past its centre
        box = _union_box([r for r in rects if r is not None], size, int(np.ceil(max(widest, 12.0))))
        self._box = None if box is None else (box[0] + origin[0], box[1] + origin[1], *box[2:])
        self._inputs = None
        return self._box


def _union_box(rects: list, size, grow: int) -> tuple | None:
    """Pixel box (x, y, w, h) holding NDC rectangles ``rects``, ``grow`` pixels wider, inside
    ``size``; None for no rectangles."""
    if not rects:
        return None
    x0, y0, x1, y1 = _pixel_corners((min(r[0] for r in rects), min(r[1] for r in rects),
                                     max(r[2] for r in rects), max(r[3] for r in rects)), size, grow)
    return (x0, y0, x1 - x0, y1 - y0) if x1 > x0 and y1 > y0 else None


def _vao(ctx, prog, buffers, index_buffer=None):
    """Vertex array binding only the attributes the compiled program kept."""
    content = [entry for entry in buffers if all(name in prog for name in entry[2:])]
    return ctx.vertex_array(prog, content, index_buffer=index_buffer)


class _MeshGPU:
    """Static buffers of one rigid mesh, with a lit VAO and a depth-only VAO."""

    def __init__(self, ctx, mesh, lit_prog, depth_prog):
        self.buffers = [ctx.buffer(np.ascontiguousarray(a, dtype=dt).tobytes()) for a, dt in (
            (mesh.positions, "f4"), (mesh.normals, "f4"), (mesh.colors, "f4"), (mesh.gloss, "f4"))]
        self.ibo = ctx.buffer(np.ascontiguousarray(mesh.indices, dtype="u4").tobytes())
        pos, nrm, col, gl = self.buffers
        attrs = [(pos, "3f", "in_pos"), (nrm, "3f", "in_normal"), (col, "4f", "in_color"), (gl, "1f", "in_gloss")]
        self.lit = _vao(ctx, lit_prog, attrs, self.ibo)
        self.depth = _vao(ctx, depth_prog, [(pos, "3f", "in_pos")], self.ibo)


class _Skinner:
    """Linear-blend skinning on the GL side: one transform-feedback pass per pose
    (``shaders/skin.vert``) reads static buffers (bind positions, normals, joints, weights)
    and the bone-matrix uniform block, and writes skinned positions (and normals) into a
    buffer that the draw passes read like a rigid mesh."""

    def __init__(self, ctx, prog, mesh, with_normals: bool):
        self.count = len(mesh.positions)
        self.static = [ctx.buffer(np.ascontiguousarray(a, dtype=dt).tobytes()) for a, dt in (
            (mesh.positions, "f4"), (mesh.joints, "i4"), (mesh.weights, "f4"))]
        attrs = [(self.static[0], "3f", "in_pos"), (self.static[1], "4i", "in_joints"),
                 (self.static[2], "4f", "in_weights")]
        if with_normals:
            self.static.append(ctx.buffer(np.ascontiguousarray(mesh.normals, dtype="f4").tobytes()))
            attrs.append((self.static[3], "3f", "in_normal"))
        self.vao = _vao(ctx, prog, attrs)
        self.stride = 24 if with_normals else 12
        self.out = ctx.buffer(reserve=self.count * self.stride)   # (V, 3[+3]) float32, interleaved
        self.key = None      # the bone matrices (bytes) the buffer was skinned with

    def skin(self) -> None:
        """Skin with the matrices currently in the bound bone block."""
        import moderngl
        self.vao.transform(self.out, moderngl.POINTS, vertices=self.count)

    def read(self) -> np.ndarray:
        """The skinned vertices ``(V, 3)`` or ``(V, 6)`` (position, normal) read back (tests)."""
        return np.frombuffer(self.out.read(), np.float32).reshape(self.count, -1)


class _PosedBody:
    """The batsman skinned on the GL side once per pose (``_Skinner``), drawn by the static
    programs: one of his levels of detail lit, and the coarse shadow caster (skinned with it).

    ``levels`` are the drawn meshes, finest first; ``update(..., level)`` skins only the
    level about to be drawn (llvmpipe shades 4x4 pixel blocks, so a mesh whose triangles
    are a few pixels big costs several times its pixels: far away, the coarser level)."""

    def __init__(self, ctx, skin_progs, num_joints, body_meshes, caster_mesh, lit_progs, depth_prog):
        """``lit_progs``: per level, the program of its lit pass (the last one repeats)."""
        self.bones = ctx.buffer(reserve=num_joints * 64)   # (J,4,4) float32: this body's bone block
        self.levels = [_BodyLevel(ctx, skin_progs[True], m, lit_progs[min(i, len(lit_progs) - 1)], depth_prog)
                       for i, m in enumerate(body_meshes)]
        self.caster = _Skinner(ctx, skin_progs[False], caster_mesh, False) if caster_mesh is not None else None
        if self.caster is not None:
            self.caster_ibo = ctx.buffer(np.ascontiguousarray(caster_mesh.indices, dtype="u4").tobytes())
            self.caster_vao = _vao(ctx, depth_prog, [(self.caster.out, "3f", "in_pos")], self.caster_ibo)
        self.level = 0
        self._bones_key = None

    @property
    def body(self) -> "_Skinner":
        """The skinner of the level last updated."""
        return self.levels[self.level].skinner

    @property
    def mesh(self):
        return self.levels[self.level].mesh

    @property
    def lit(self):
        return self.levels[self.level].lit

    @property
    def shadow(self):
        """Depth-only VAO: the coarse caster if there is one, else the drawn level."""
        return self.caster_vao if self.caster is not None else self.levels[self.level].depth

    def update(self, skin_matrices: np.ndarray, level: int | None = None) -> None:
        """Make ``level`` (default: the current one) and the caster hold the pose
        ``skin_matrices (J,4,4)``: one bone-block upload per pose, each mesh skinned once."""
        self.level = self.level if level is None else min(max(int(level), 0), len(self.levels) - 1)
        m = np.ascontiguousarray(skin_matrices, np.float32)
        key = m.tobytes()
        targets = [self.levels[self.level].skinner] + ([self.caster] if self.caster is not None else [])
        stale = [t for t in targets if t.key != key]
        if not stale:
            return
        if self._bones_key != key:
            self.bones.orphan()
            self.bones.write(mat_bytes(m))
            self._bones_key = key
        self.bones.bind_to_uniform_block(0)
        for t in stale:
            t.skin()
            t.key = key


class _BodyLevel:
    """One level of detail of the batsman: its skinner and, over the skinned buffer, the
    VAOs of its lit pass (``lit_prog``: pixel- or vertex-lit) and of the depth-only program."""

    def __init__(self, ctx, skin_prog, mesh, lit_prog, depth_prog):
        self.mesh = mesh
        self.skinner = _Skinner(ctx, skin_prog, mesh, True)
        self.static = [ctx.buffer(np.ascontiguousarray(a, dtype="f4").tobytes()) for a in (mesh.colors, mesh.gloss)]
        self.ibo = ctx.buffer(np.ascontiguousarray(mesh.indices, dtype="u4").tobytes())
        out = self.skinner.out
        attrs = [(out, "3f 3f", "in_pos", "in_normal"), (self.static[0], "4f", "in_color"),
                 (self.static[1], "1f", "in_gloss")]
        self.lit = _vao(ctx, lit_prog, attrs, self.ibo)
        self.depth = _vao(ctx, depth_prog, [(out, "3f 12x", "in_pos")], self.ibo)


class SceneRenderer:
    def __init__(self, ctx, rig, glb_path=None):
        """Load ``assets/batsman.glb`` (or ``glb_path``) and the shaders; build static geometry."""
        from app.mesh import load_glb
        from engine.skeleton import bind_positions

        self.ctx = ctx
        self.rig = rig
        self.bind_positions = bind_positions(rig.skeleton)
        meshes = load_glb(glb_path, rig)
        self.body_mesh, self.ball_mesh = meshes["Batsman"], meshes["Ball"]

        self.p_static = program(ctx, "static.vert", "lit.frag")
        self.p_vertex_lit = program(ctx, "lit_vertex.vert", "vertex_color.frag")
        self.p_body_lit = program(ctx, "lit_vertex.vert", "vertex_lit_shadow.frag", defines=("PIXEL_SHADOW",))
        self.p_depth_static = program(ctx, "depth_static.vert", "depth.frag")
        self.p_ground = program(ctx, "ground.vert", "ground.frag")
        self.p_receiver = program(ctx, "receiver.vert", "receiver.frag")
        self.p_receiver_cov = program(ctx, "receiver.vert", "receiver_coverage.frag")
        self.p_sky = program(ctx, "sky.vert", "sky.frag")
        self.p_line = program(ctx, "line.vert", "line.frag", "line.geom")
        self.p_point = program(ctx, "line.vert", "point.frag", "point.geom")
        self.p_ghost = program(ctx, "ghost_composite.vert", "ghost_composite.frag")
        self.p_ghost_tiles = program(ctx, "ghost_tiles.vert", "ghost_composite.frag")

        self.shadow_mesh = meshes.get("BatsmanShadow")
        if self.shadow_mesh is not None and self.shadow_mesh.joints is None:
            self.shadow_mesh = None
        self.body_levels = [self.body_mesh]        # finest first; a missing level ends the chain
        for name in ("BatsmanLod1", "BatsmanLod2"):
            level = meshes.get(name)
            if level is None or level.joints is None:
                break
            self.body_levels.append(level)
        # the posed batsman; the coarse copy casts the shadow (a third of the triangles, the same outline)
        J = rig.skeleton.num_joints
        skin_progs = {n: _skin_program(ctx, J, n) for n in (True, False)}
        # the finest level pixel-lit, the coarser ones vertex-lit with the shadow per pixel
        # (lit_vertex.vert with PIXEL_SHADOW, vertex_lit_shadow.frag)
        lit_progs = (self.p_static, self.p_body_lit)
        self.posed = _PosedBody(ctx, skin_progs, J, self.body_levels, self.shadow_mesh, lit_progs,
                                self.p_depth_static)
        self.ghost_posed = _PosedBody(ctx, skin_progs, J, self.body_levels, None, lit_progs[:1],
                                      self.p_depth_static)
        # the ball stays pixel-lit (a sharp highlight over a few pixels); the flat target is
        # vertex-lit like the distant batsman (its per-pixel shadow taps cost ~1 ms a frame)
        self.ball = _MeshGPU(ctx, self.ball_mesh, self.p_static, self.p_depth_static)
        self.wickets_mesh = props.wickets()
        self.wickets = _MeshGPU(ctx, self.wickets_mesh, self.p_static, self.p_depth_static)
        self.target = _MeshGPU(ctx, props.target_disc(), self.p_vertex_lit, self.p_depth_static)

        gpos, gcol = props.ground()
        self.ground_bufs = [ctx.buffer(gpos.astype("f4").tobytes()), ctx.buffer(gcol.astype("f4").tobytes())]
        self.ground = _vao(ctx, self.p_ground, [(self.ground_bufs[0], "3f", "in_pos"),
                                                (self.ground_bufs[1], "3f", "in_color")])
        spos, scol = props.stadium()
        self.stadium_bufs = [ctx.buffer(spos.tobytes()), ctx.buffer(scol.tobytes())]
        self.stadium = _vao(ctx, self.p_ground, [(self.stadium_bufs[0], "3f", "in_pos"),
                                                 (self.stadium_bufs[1], "3f", "in_color")])
        self.sky = ctx.vertex_array(self.p_sky, [])

        self.shadow_tex, self.shadow_fbo = _shadow_target(ctx, SHADOW_SIZE, coverage=True)
        self.shadow_coverage = self.shadow_fbo.color_attachments[0]
        self.static_shadow_tex, self.static_shadow_fbo = _shadow_target(ctx, STATIC_SHADOW_SIZE)

        self.receiver_buf = DynamicBuffer(ctx, 6 * 12)
        self.receiver = ctx.vertex_array(self.p_receiver, [(self.receiver_buf.buffer, "3f", "in_pos")])
        self.receiver_cov = ctx.vertex_array(self.p_receiver_cov, [(self.receiver_buf.buffer, "3f", "in_pos")])
        self.line_buf = DynamicBuffer(ctx)
        self.point_buf = DynamicBuffer(ctx)
        self._overlay_vaos = {}
        self._offscreen = {}
        self.ghost_vao = ctx.vertex_array(self.p_ghost, [])
        self.ghost_tile_buf = DynamicBuffer(ctx)
        self._joint_boxes = joint_boxes(self.body_mesh, rig.skeleton.num_joints)
        self._auto_level = 0        # the last level chosen by size (see _detail_level)
        self._static = _Layer()     # sky, ground, stadium, wickets for one camera and size
        self._ghost = _Layer()      # the translucent ghost's nearest surface (colour + depth)
        self._posed_layer = _Layer()  # the static layer with the batsman and his shadow, for one pose
        self._last_pose_key = None
        self._aa = _Layer()         # FXAA source: copies of the frame round what moves
        self._aa_pixels = None      # the staging buffer for those copies
        self.p_fxaa = program(ctx, "fxaa.vert", "fxaa.frag")
        self.fxaa_vao = ctx.vertex_array(self.p_fxaa, [])
        lo, hi = self.wickets_mesh.positions.min(0), self.wickets_mesh.positions.max(0)
        near_stumps = np.array(np.meshgrid(*zip(lo, (hi[0], hi[1], min(hi[2], 50.0))))).reshape(3, -1).T
        self._static_fit = fit_sun(near_stumps, STATIC_SHADOW_SIZE)   # the batting end's stumps
        self._shadow_fit = (self._static_fit[0], None)
        self._shadow_key = ()
        self._shadow_ball = None    # the ball in the shadow map (None: it casts none)
        self.static_key = None      # the static layer under the last render (None: drawn whole)
        self.changed = None         # what it drew over it (ChangedRegion), see _note_changed
        self._static_setup()

    # ------------------------------------------------------------------ setup
    def _static_setup(self):
        for p in (self.p_static, self.p_vertex_lit, self.p_body_lit, self.p_ground, self.p_receiver):
            for k, v in LIGHTING.items():
                set_uniform(p, k, v)
            set_uniform(p, "u_shadow_texel", 1.0 / SHADOW_SIZE)   # receiver: set per use
            set_uniform(p, "u_shadow_map", 0)
        light, tint = ground_light()
        set_uniform(self.p_ground, "u_light", light)
        for p in (self.p_receiver, self.p_receiver_cov):
            set_uniform(p, "u_shadow_tint", tint)
        for p in (self.p_static, self.p_vertex_lit, self.p_body_lit):
            set_uniform(p, "u_mode", 0)
            set_uniform(p, "u_alpha", 1.0)
            set_uniform(p, "u_tint", (1.0, 1.0, 1.0))
            set_uniform(p, "u_emissive", (0.0, 0.0, 0.0))
            set_uniform(p, "u_ghost_color", tuple(np.power((0.55, 0.78, 1.0), 2.2)))
        set_uniform(self.p_sky, "u_sun_dir", tuple(SUN_DIR))
        set_uniform(self.p_sky, "u_zenith", ZENITH)
        set_uniform(self.p_sky, "u_horizon", HORIZON)

    def joint_positions(self, skin_matrices: np.ndarray) -> np.ndarray:
        """World joint positions ``(J,3)`` recovered from skinning matrices."""
        m = np.asarray(skin_matrices, float)
        return np.einsum("jab,jb->ja", m[:, :3, :3], self.bind_positions) + m[:, :3, 3]

    # ------------------------------------------------------------------ shadows
    def _casting_ball(self, view: SceneView, body: np.ndarray | None) -> np.ndarray | None:
        """The ball's position if it casts a shadow (near the batsman, whose skinned box
        corners are ``body``; anywhere when there is no batsman), else None."""
        if view.ball_position is None:
            return None
        b = np.asarray(view.ball_position, float)
        return b if body is None or np.linalg.norm(b - body.mean(0)) < 400 else None

    @staticmethod
    def _caster_points(body, ball) -> np.ndarray:
        """Points ``(N,3)`` bounding the dynamic shadow casters: the corners of the batsman's
        skinned per-joint boxes ``body`` (or None) and a box round the casting ``ball`` (or None)."""
        pts = [] if body is None else [body]
        if ball is not None:
            pts.append(ball + 4.0 * _CUBE)
        return np.concatenate(pts) if pts else np.zeros((0, 3))

    def _update_shadow(self, view: SceneView):
        """The batsman's (and a near ball's) shadow map, redrawn only when the pose or the ball
        moved. Returns (light view-projection, ground quad ``(6,3)`` under the shadow or None)."""
        body = None if view.skin_matrices is None else skinned_box_corners(view.skin_matrices, self._joint_boxes)
        ball = self._casting_ball(view, body)
        key = (None if view.skin_matrices is None else np.asarray(view.skin_matrices, np.float32).tobytes(),
               None if ball is None else ball.astype(np.float32).tobytes())
        if key != self._shadow_key:
            self._shadow_ball = ball
            pts = self._caster_points(body, ball)
            if len(pts):
                self._shadow_fit = fit_sun(pts, SHADOW_SIZE)
            else:
                self._shadow_fit = (self._static_fit[0], None)
            self._draw_shadow_map(self.shadow_fbo, SHADOW_SIZE, self._shadow_fit[0], view, False)
            self._shadow_key = key
        return self._shadow_fit

    def _draw_shadow_map(self, fbo, size: int, light_vp: np.ndarray, view: SceneView | None, wickets: bool) -> None:
        """Depth from the sun into ``fbo``: the batsman and the ball of ``view``, or the stumps."""
        ctx = self.ctx
        fbo.use()
        ctx.viewport = (0, 0, size, size)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.polygon_offset = (2.0, 4.0)
        set_uniform(self.p_depth_static, "u_view_proj", light_vp)
        set_uniform(self.p_depth_static, "u_model", IDENTITY)
        if view is not None and view.skin_matrices is not None:
            self.posed.update(view.skin_matrices)
            self.posed.shadow.render()
        if wickets:
            self.wickets.depth.render()
        ball = self._shadow_ball if view is not None else None
        if ball is not None:
            set_uniform(self.p_depth_static, "u_model", props.translation(ball))
            self.ball.depth.render()
        ctx.polygon_offset = (0.0, 0.0)

    def _draw_receiver(self, quad: np.ndarray, shadow_tex, size: int, coverage=None) -> None:
        """Multiply the ground by the shadow map inside ``quad`` (6 points on y = 0) only,
        depth-tested so things standing on the ground (stumps) are not darkened. With a
        ``coverage`` texture (the batsman's map) one bilinear tap of it, else 4 PCF taps."""
        import moderngl

        self.receiver_buf.update(np.asarray(quad, np.float32).tobytes())
        ctx = self.ctx
        if coverage is not None:
            coverage.use(3)
            set_uniform(self.p_receiver_cov, "u_coverage", 3)
            vao = self.receiver_cov
        else:
            shadow_tex.use(0)
            set_uniform(self.p_receiver, "u_shadow_texel", 1.0 / size)
            vao = self.receiver
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

    # ------------------------------------------------------------------ passes
    def _frame_uniforms(self, vp, eye, light_vp, shadows: bool, shadow_tex) -> None:
        shadow_tex.use(0)
        for p in (self.p_static, self.p_vertex_lit, self.p_body_lit, self.p_ground, self.p_receiver,
                  self.p_receiver_cov):
            set_uniform(p, "u_view_proj", vp)
            set_uniform(p, "u_eye", eye)
            set_uniform(p, "u_light_vp", light_vp)
            set_uniform(p, "u_shadow_on", 1.0 if shadows else 0.0)

    def _draw_static(self, view: SceneView, fbo, vp, eye, shadows: bool, origin=(0, 0)) -> None:
        """Ground (painter's order) with the stumps' shadow, the stumps, stadium and sky into
        ``fbo`` (cleared first). The stumps' shadow map is drawn here too."""
        import moderngl

        ctx = self.ctx
        light_vp, quad = self._static_fit
        if shadows:
            self._draw_shadow_map(self.static_shadow_fbo, STATIC_SHADOW_SIZE, light_vp, None, True)
        fbo.use()
        ctx.viewport = (*origin, *view.size)
        fbo.clear(*BACKGROUND, 1.0, depth=1.0, viewport=ctx.viewport)
        self._frame_uniforms(vp, eye, light_vp, shadows, self.static_shadow_tex)
        if view.show_pitch:
            ctx.depth_func = "1"
            self.ground.render()
            ctx.depth_func = "<"
            if shadows:
                self._draw_receiver(quad, self.static_shadow_tex, STATIC_SHADOW_SIZE)
        ctx.enable(moderngl.CULL_FACE)
        set_uniform(self.p_static, "u_mode", 0)
        set_uniform(self.p_static, "u_model", np.eye(4, dtype=np.float32))
        self.wickets.lit.render()
        ctx.disable(moderngl.CULL_FACE)
        if view.show_pitch:
            self.stadium.render()    # flat-lit, after the near geometry so early-z skips hidden parts
        ctx.depth_func = "<="
        set_uniform(self.p_sky, "u_inv_view_proj", np.linalg.inv(vp.astype(float)).astype(np.float32))
        self.sky.render(vertices=3)
        ctx.depth_func = "<"

    def _static_layer(self, view: SceneView, target, vp, eye, shadows: bool, aa: bool = False):
        """The static scene for this camera and size, drawn once into an offscreen framebuffer
        of the target's sample count (with ``aa``, a single-sampled target: drawn with 4x MSAA
        and resolved); None when ``target`` cannot take a depth blit."""
        if target is self.ctx.screen or getattr(target, "depth_attachment", None) is None:
            return None
        samples = int(getattr(target, "samples", 0) or 0)
        msaa = min(4, self.ctx.max_samples) if aa and samples == 0 else 0
        key = (tuple(view.size), samples, np.asarray(view.view, np.float32).tobytes(),
               np.asarray(view.proj, np.float32).tobytes(), bool(view.show_pitch), shadows, msaa)
        layer = self._static
        if layer.key != key:
            fbo = layer.framebuffer(self.ctx, tuple(view.size), samples, textures=False)
            if msaa > 1:
                tmp = _Layer()
                self._draw_static(view, tmp.framebuffer(self.ctx, tuple(view.size), msaa, False), vp, eye, shadows)
                self.ctx.copy_framebuffer(fbo, tmp.fbo)      # resolve colour and depth
                tmp.release()
            else:
                self._draw_static(view, fbo, vp, eye, shadows)
            layer.key = key
        return layer.fbo

    def render(self, view: SceneView, fbo=None) -> None:
        """Draw the scene into ``fbo`` (default: the screen). Into a single-sampled ``fbo``
        the cached static layer is drawn with 4x MSAA and resolved (once per camera) when
        ``view.static_antialias`` is set, and with ``view.antialias`` the moving things
        (batsman, ghost, ball, target) get an FXAA pass over their screen boxes only (copied
        out of the frame into a texture the pass reads). The screen, a target without depth,
        or a multisampled ``fbo`` (``render_image``: MSAA over everything) is drawn into
        directly."""
        import moderngl

        ctx = self.ctx
        target = fbo if fbo is not None else ctx.screen
        single = int(getattr(target, "samples", 0) or 0) == 0
        smooth_static = bool(view.static_antialias) and single
        direct = target is ctx.screen or getattr(target, "depth_attachment", None) is None
        if not (view.antialias and single) or direct:
            return self._render(view, target, smooth_static)
        size = tuple(view.size)
        self._render(view, target, smooth_static)
        boxes = [_pixel_box(r, size, 6) for r in self._moving_rects(view, self._vp, size)]
        boxes = [b for b in boxes if b is not None]
        if not boxes:
            return
        # copy just those boxes of the frame into a texture the FXAA pass reads (a full-frame
        # copy or an offscreen frame would cost more than the filter itself)
        self._aa.framebuffer(ctx, size, 0, textures=True)     # (re)sized with the frame
        source = self._aa.color
        source.filter = (moderngl.LINEAR, moderngl.LINEAR)
        for box in boxes:
            nbytes = box[2] * box[3] * 4
            if self._aa_pixels is None or self._aa_pixels.size < nbytes:
                self._aa_pixels = ctx.buffer(reserve=max(nbytes, 1 << 20))
            ox, oy = view.origin
            target.read_into(self._aa_pixels, viewport=(box[0] + ox, box[1] + oy, box[2], box[3]),
                             components=4, alignment=1)
            source.write(self._aa_pixels, viewport=box, alignment=1)
        target.use()
        ctx.viewport = (*view.origin, *size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        source.use(0)
        set_uniform(self.p_fxaa, "u_color", 0)
        set_uniform(self.p_fxaa, "u_texel", (1.0 / size[0], 1.0 / size[1]))
        for x, y, w, h in boxes:
            # the filter's taps reach 4 pixels: draw 5 pixels inside the copied box
            set_uniform(self.p_fxaa, "u_rect", tuple(float(v) for v in (
                2 * (x + 5) / size[0] - 1, 2 * (y + 5) / size[1] - 1,
                2 * (x + w - 5) / size[0] - 1, 2 * (y + h - 5) / size[1] - 1)))
            self.fxaa_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        ctx.enable(moderngl.DEPTH_TEST)

    def _moving_rects(self, view: SceneView, vp: np.ndarray, size) -> list:
        """NDC rectangles (x0, y0, x1, y1), a few pixels wider, round what moves between
        frames: the batsman with his ghost, the ball, the target."""
        pad = 3.0 * 2.0 / np.asarray(size, float)
        found = []
        skins = [m for m in (view.skin_matrices, view.ghost_skin_matrices) if m is not None]
        if skins:
            found.append(_project_rect(np.concatenate(
                [skinned_box_corners(m, self._joint_boxes) for m in skins]), vp))
        if view.ball_position is not None:
            found.append(_project_rect(np.asarray(view.ball_position, float) + 4.0 * _CUBE, vp))
        if view.target_position is not None:
            found.append(_project_rect(np.asarray(view.target_position, float) + 32.0 * _CUBE, vp))
        return [(r[0] - pad[0], r[1] - pad[1], r[2] + pad[0], r[3] + pad[1]) for r in found if r is not None]

    def _render(self, view: SceneView, fbo, smooth_static: bool) -> None:
        """Draw the scene into ``fbo``, including the shadow pass.

        The static scene (sky, ground with the stumps' shadow, stadium, stumps) is drawn once
        per camera and size into a cached colour + depth layer and copied in. Per frame only
        the batsman's shadow map (redrawn when the pose or the ball moves) and its receiver
        quad over the ground, the batsman, ball, target, overlays and the ghost (a cached
        layer, redrawn when the source pose or camera changes) are drawn over it. Cached
        stumps do not take the batsman's shadow.
        """
        import moderngl

        ctx = self.ctx
        target_fbo = fbo
        w, h = view.size
        vp = (np.asarray(view.proj, np.float32) @ np.asarray(view.view, np.float32))
        self._vp = vp
        eye = tuple(-np.asarray(view.view, float)[:3, :3].T @ np.asarray(view.view, float)[:3, 3])

        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        ctx.depth_func = "<"
        shadows = bool(view.shadows)
        self.posed.level = self.ghost_posed.level = self._detail_level(view, vp)
        static = self._static_layer(view, target_fbo, vp, eye, shadows, smooth_static)
        ghost = self._ghost_layer(view, vp, eye) if static is not None else None
        if static is None:
            self._draw_static(view, target_fbo, vp, eye, shadows, view.origin)
        light_vp, quad = self._update_shadow(view) if shadows else (self._static_fit[0], None)

        target_fbo.use()
        pose_key = None if static is None else (
            self._static.key, None if view.skin_matrices is None else np.asarray(view.skin_matrices, np.float32).tobytes(),
            self._shadow_key if shadows else None, self.posed.level, bool(view.show_pitch), shadows)
        layer = self._posed_layer
        held = pose_key is not None and layer.key == pose_key
        if held:
            copy_rect(ctx, target_fbo, layer.fbo, view.origin)    # static scene, batsman, his shadow
        elif static is not None:
            copy_rect(ctx, target_fbo, static, view.origin)
        ctx.viewport = (*view.origin, w, h)
        self._frame_uniforms(vp, eye, light_vp, shadows, self.shadow_tex)
        if not held:
            self._draw_batsman(view, quad)
            if pose_key is not None and pose_key == self._last_pose_key:
                # the same pose twice running (the target dragged at a frame where he holds still):
                # keep this much for the frames after, which then draw only what moves
                fbo = layer.framebuffer(ctx, (w, h), int(getattr(target_fbo, "samples", 0) or 0), textures=False)
                copy_rect(ctx, fbo, target_fbo, src_origin=view.origin)
                layer.key = pose_key
                target_fbo.use()
                ctx.viewport = (*view.origin, w, h)
        self._last_pose_key = pose_key
        # every mesh is closed with outward winding (the helmet has a lining): cull back faces
        ctx.enable(moderngl.CULL_FACE)
        set_uniform(self.p_static, "u_mode", 0)
        if view.ball_position is not None:
            set_uniform(self.p_static, "u_model", props.translation(view.ball_position))
            self.ball.lit.render()
        if view.target_position is not None:
            set_uniform(self.p_vertex_lit, "u_model", props.target_model(view.target_position, view.target_normal))
            if view.target_highlight:
                set_uniform(self.p_vertex_lit, "u_emissive", (0.35, 0.30, 0.05))
            self.target.lit.render()
            set_uniform(self.p_vertex_lit, "u_emissive", (0.0, 0.0, 0.0))
        ctx.disable(moderngl.CULL_FACE)

        # overlays and ghost (blended)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        overlay_lines, overlay_points = self._draw_overlays(view, vp, (w, h))
        self._note_changed(view, vp, static, quad if view.show_pitch else None, overlay_lines, overlay_points)
        if ghost is not None:
            self._composite_ghost(ghost, view.origin)
        elif view.ghost_skin_matrices is not None and view.ghost_alpha > 0:
            ctx.enable(moderngl.CULL_FACE)
            self._draw_ghost(view, target_fbo)
            ctx.disable(moderngl.CULL_FACE)
        ctx.disable(moderngl.BLEND)
        ctx.depth_func = "<"

    def _draw_batsman(self, view: SceneView, quad) -> None:
        """The posed batsman and, over the ground, his shadow (the receiver quad ``quad``)."""
        import moderngl

        ctx = self.ctx
        if view.skin_matrices is not None:
            ctx.enable(moderngl.CULL_FACE)
            set_uniform(self.p_static, "u_mode", 0)
            self.posed.update(view.skin_matrices)
            set_uniform(self.p_body_lit, "u_model", IDENTITY)
            set_uniform(self.p_static, "u_model", IDENTITY)
            self.posed.lit.render()
            ctx.disable(moderngl.CULL_FACE)
        if view.show_pitch and quad is not None:
            # after him: early-z skips the ground he covers
            self._draw_receiver(quad, self.shadow_tex, SHADOW_SIZE, self.shadow_coverage)

    def _note_changed(self, view: SceneView, vp, static, quad, lines, points) -> None:
        """Remember which static layer this render drew over (``static_key``; None when the
        scene was drawn whole) and what it drew over it (``changed``, a ``ChangedRegion``).
        A window presents only what changed from frame to frame."""
        self.static_key = self._static.key if static is not None else None
        skins = [m for m in (view.skin_matrices, view.ghost_skin_matrices) if m is not None]
        solids = [np.asarray(p, float) + r * _CUBE for p, r in ((view.ball_position, 4.0),
                                                                (view.target_position, 32.0)) if p is not None]
        if quad is not None:
            solids.append(np.asarray(quad, float))                     # his shadow on the ground
        self.changed = ChangedRegion(view.size, view.origin, vp, skins, self._joint_boxes, solids, lines, points)

    def _detail_level(self, view: SceneView, vp: np.ndarray) -> int:
        """The batsman's level of detail for this frame: ``view.detail`` if set, else by how
        tall his (and his ghost's) boxes stand on screen (``LOD_MIN_PX``)."""
        last = len(self.body_levels) - 1
        if view.detail is not None:
            return min(max(int(view.detail), 0), last)
        skins = [m for m in (view.skin_matrices, view.ghost_skin_matrices) if m is not None]
        if last == 0 or not skins:
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

    def _ghost_layer(self, view: SceneView, vp, eye):
        """The ghost's nearest surface (colour with alpha, depth) for this camera and pose, drawn
        only when they change (the source pose holds still while the target is dragged);
        None when there is no ghost."""
        import moderngl

        if view.ghost_skin_matrices is None or view.ghost_alpha <= 0:
            return None
        ghost = np.asarray(view.ghost_skin_matrices, np.float32)
        key = (tuple(view.size), vp.tobytes(), ghost.tobytes(), float(view.ghost_alpha), self.ghost_posed.level)
        layer = self._ghost
        if layer.key == key and layer.tiles is None:
            self._ghost_tiles(layer, tuple(view.size))     # drawn a frame ago: read, no waiting
        if layer.key != key:
            ctx = self.ctx
            fbo = layer.framebuffer(ctx, tuple(view.size), 0, textures=True)
            fbo.use()
            ctx.viewport = (0, 0, *view.size)
            layer.rect = self._screen_rect(ghost, vp)
            # only the ghost's box is ever read (the composite covers layer.rect): clear
            # and draw just there - a whole-viewport clear cost more than the ghost
            box = _pixel_box(layer.rect, view.size, 2) if layer.rect is not None else None
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0, viewport=box)
            ctx.scissor = box
            set_uniform(self.p_static, "u_view_proj", vp)
            set_uniform(self.p_static, "u_eye", eye)
            ctx.enable(moderngl.CULL_FACE)
            self._draw_ghost(view, fbo)
            ctx.disable(moderngl.CULL_FACE)
            ctx.scissor = None
            layer.key, layer.tiles = key, None
        return layer

    def _ghost_tiles(self, layer, size, tile: int = GHOST_TILE_PX) -> None:
        """Cover the ghost layer's pixels with any ghost (alpha > 0) by runs of ``tile``-pixel
        squares (NDC triangles in ``ghost_tile_buf``; ``layer.tiles`` their vertex count): on
        llvmpipe the composite costs ~25 ns a pixel, and the ghost fills ~30 % of its box."""
        box = _pixel_box(layer.rect, size, 2) if layer.rect is not None else None
        if box is None:
            layer.tiles = 0
            return
        x, y, w, h = box
        alpha = np.frombuffer(layer.fbo.read(viewport=box, components=4, alignment=1), np.uint8)
        alpha = alpha.reshape(h, w, 4)[..., 3] > 0
        rows, cols = -(-h // tile), -(-w // tile)
        padded = np.zeros((rows * tile, cols * tile), bool)
        padded[:h, :w] = alpha
        covered = padded.reshape(rows, tile, cols, tile).any(axis=(1, 3))
        quads = []
        for r in range(rows):
            edges = np.flatnonzero(np.diff(np.concatenate([[0], covered[r].astype(np.int8), [0]])))
            for c0, c1 in zip(edges[0::2], edges[1::2]):              # runs of covered tiles
                quads.append((x + c0 * tile, y + r * tile, min(x + c1 * tile, x + w), min(y + (r + 1) * tile, y + h)))
        if not quads:
            layer.tiles = 0
            return
        q = np.array(quads, float)
        nx0, nx1 = 2 * q[:, 0] / size[0] - 1, 2 * q[:, 2] / size[0] - 1
        ny0, ny1 = 2 * q[:, 1] / size[1] - 1, 2 * q[:, 3] / size[1] - 1
        corners = np.stack([np.stack([nx0, ny0], 1), np.stack([nx1, ny0], 1), np.stack([nx1, ny1], 1),
                            np.stack([nx0, ny0], 1), np.stack([nx1, ny1], 1), np.stack([nx0, ny1], 1)], 1)
        self.ghost_tile_buf.update(corners.astype(np.float32).tobytes())
        layer.tiles = len(quads) * 6

    def _screen_rect(self, skin_matrices: np.ndarray, vp: np.ndarray) -> tuple | None:
        """NDC rectangle (x0, y0, x1, y1) holding the skinned mesh, from its per-joint boxes
        (every skinned vertex is a convex blend of its joints' transformed boxes)."""
        return _project_rect(skinned_box_corners(skin_matrices, self._joint_boxes), vp)

    def _composite_ghost(self, layer, origin) -> None:
        """Blend the cached ghost over the frame where it is nearer than the scene."""
        import moderngl

        if layer.rect is None or layer.tiles == 0:
            return                                        # no pixel of ghost in view
        ctx = self.ctx
        layer.color.use(1)
        layer.depth.use(2)
        prog = self.p_ghost if layer.tiles is None else self.p_ghost_tiles
        set_uniform(prog, "u_ghost_color", 1)
        set_uniform(prog, "u_ghost_depth", 2)
        set_uniform(prog, "u_rect", layer.rect)
        set_uniform(prog, "u_origin", tuple(int(v) for v in origin))
        ctx.depth_func = "<"
        depth_writes(ctx, False)
        if layer.tiles is None:                           # its tiles are not known yet: the box
            self.ghost_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        else:
            self._overlay_vao("ghost tiles", self.p_ghost_tiles, self.ghost_tile_buf, "2f", ("in_pos",)).render(
                moderngl.TRIANGLES, vertices=layer.tiles)
        depth_writes(ctx, True)

    def _draw_ghost(self, view: SceneView, target_fbo) -> None:
        """The source pose, translucent: a depth pre-pass (no colour) so only its nearest
        surface is shaded; skinned (transform feedback) into its own buffers."""
        ctx = self.ctx
        ghost = self.ghost_posed
        ghost.update(view.ghost_skin_matrices)
        set_uniform(self.p_depth_static, "u_view_proj", self._vp)
        set_uniform(self.p_depth_static, "u_model", IDENTITY)
        target_fbo.color_mask = (False, False, False, False)
        ghost.shadow.render()
        target_fbo.color_mask = (True, True, True, True)
        ctx.depth_func = "<="
        depth_writes(ctx, False)
        set_uniform(self.p_static, "u_model", IDENTITY)
        set_uniform(self.p_static, "u_mode", 1)
        set_uniform(self.p_static, "u_alpha", float(view.ghost_alpha))
        ghost.lit.render()
        set_uniform(self.p_static, "u_mode", 0)
        set_uniform(self.p_static, "u_alpha", 1.0)
        depth_writes(ctx, True)

    # ------------------------------------------------------------------ overlays
    @staticmethod
    def _line_vertices(view: SceneView) -> tuple[np.ndarray, np.ndarray]:
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
    def _point_vertices(view: SceneView) -> np.ndarray:
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

    def _overlay_vao(self, key, prog, dyn: DynamicBuffer, layout="3f 4f 1f", names=("in_pos", "in_color", "in_width")):
        cached = self._overlay_vaos.get(key)
        if cached is None or cached[0] != dyn.generation:
            vao = self.ctx.vertex_array(prog, [(dyn.buffer, layout, *names)])
            self._overlay_vaos[key] = (dyn.generation, vao)
        return self._overlay_vaos[key][1]

    def _draw_overlays(self, view: SceneView, vp: np.ndarray, size) -> tuple:
        """Draw the lines and points; returns their vertex rows (x, y, z, r, g, b, a, width):
        lines ``(2N, 8)`` in pairs, points ``(M, 8)``."""
        import moderngl

        ctx = self.ctx
        tested, on_top = self._line_vertices(view)
        points = self._point_vertices(view)
        if not (len(tested) or len(on_top) or len(points)):
            return tested, points
        lines = np.concatenate([tested, on_top])
        for p in (self.p_line, self.p_point):
            set_uniform(p, "u_view_proj", vp)
            set_uniform(p, "u_viewport", (float(size[0]), float(size[1])))
        depth_writes(ctx, False)
        if len(lines):
            self.line_buf.update(lines.tobytes())
            vao = self._overlay_vao("lines", self.p_line, self.line_buf)
            if len(tested):
                vao.render(moderngl.LINES, vertices=len(tested))
            if len(on_top):
                ctx.disable(moderngl.DEPTH_TEST)
                vao.render(moderngl.LINES, vertices=len(on_top), first=len(tested))
                ctx.enable(moderngl.DEPTH_TEST)
        if len(points):
            self.point_buf.update(points.tobytes())
            vao = self._overlay_vao("points", self.p_point, self.point_buf)
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

    # ------------------------------------------------------------------ offscreen
    def offscreen_targets(self, size: tuple[int, int], samples: int = 4):
        """(msaa_fbo, resolve_fbo) for ``size``, created once per size."""
        key = (tuple(size), samples)
        if key not in self._offscreen:
            ctx = self.ctx
            samples = min(samples, ctx.max_samples)
            msaa = ctx.framebuffer(color_attachments=[ctx.renderbuffer(size, 4, samples=samples)],
                                   depth_attachment=ctx.depth_renderbuffer(size, samples=samples))
            resolve = ctx.framebuffer(color_attachments=[ctx.renderbuffer(size, 4)])
            self._offscreen[key] = (msaa, resolve)
        return self._offscreen[key]


def _shadow_target(ctx, size: int, coverage: bool = False):
    """A sun depth map (compare mode on) and its framebuffer; with ``coverage`` also an R8
    colour target the casters mark (the ground under them reads it: ``receiver_coverage.frag``)."""
    import moderngl

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


def skinned_box_corners(skin_matrices: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """World corners ``(J*8, 3)`` of the per-joint rest boxes ``(J,8,4)`` moved by their joints."""
    # a batched matmul: ~3x faster than the einsum it replaces (it runs several times a frame)
    return np.matmul(boxes, np.asarray(skin_matrices, float)[:, :3].transpose(0, 2, 1)).reshape(-1, 3)


_SUN_ROTATION = np.ascontiguousarray(look_at(SUN_DIR, (0.0, 0.0, 0.0)).astype(float)[:3, :3])  # world -> sun axes
_SUN_ROTATION_T = np.ascontiguousarray(_SUN_ROTATION.T)


def fit_sun(points: np.ndarray, size: int, margin: float = 6.0) -> tuple[np.ndarray, np.ndarray]:
    """Orthographic sun view-projection ``(4,4)`` tightly holding ``points (N,3)`` and their
    shadows on the ground, and the ground quad ``(6,3)`` (y = 0) that those shadows fall in.

    The square's side is rounded up to 16 cm steps and its centre snapped to whole texels so
    the shadow's edges do not shimmer while the pose moves. Compiled: it runs every frame
    the pose moves, and on a few hundred points numpy's per-call overhead dominated."""
    vp, corners = _fit_sun(np.ascontiguousarray(points, float), float(size), float(margin),
                           SUN_DIR, _SUN_ROTATION, _SUN_ROTATION_T)
    return vp.astype(np.float32), corners[np.array([0, 1, 2, 0, 2, 3])].astype(np.float32)


@njit(cache=True)
def _fit_sun(pts, size, margin, sun, rot, rot_t):
    n = pts.shape[0]
    both = np.empty((2 * n, 3))
    for i in range(n):                                  # the points, then slid down the sun's rays
        t = pts[i, 1] / sun[1]
        for k in range(3):
            both[i, k] = pts[i, k]
            both[n + i, k] = pts[i, k] - t * sun[k]
        both[n + i, 1] = 0.0
    centre = np.zeros(3)
    for i in range(n):
        centre += pts[i]
    centre /= n
    light_view = np.eye(4)                              # look_at(centre + 2000 sun, centre)
    light_view[:3, :3] = rot
    offset = -(rot @ (centre + sun * 2000.0))
    light_view[:3, 3] = offset
    ls = both @ rot_t + offset
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(3):
        lo[k] = ls[:, k].min() - margin
        hi[k] = ls[:, k].max() + margin
    half = np.ceil(max(hi[0] - lo[0], hi[1] - lo[1]) / 32.0) * 16.0
    texel = 2 * half / size
    cx = np.round(0.5 * (lo[0] + hi[0]) / texel) * texel
    cy = np.round(0.5 * (lo[1] + hi[1]) / texel) * texel
    near, far = -hi[2] - margin, -lo[2] + margin
    proj = np.zeros((4, 4))
    proj[0, 0] = proj[1, 1] = 1 / half
    proj[0, 3], proj[1, 3] = -cx / half, -cy / half
    proj[2, 2], proj[2, 3] = -2 / (far - near), -(far + near) / (far - near)
    proj[3, 3] = 1.0
    # the ground quad: a rectangle along the sun's azimuth (shadows stretch that way)
    norm = np.hypot(sun[0], sun[2])
    a0, a1 = sun[0] / norm, sun[2] / norm
    u0 = v0 = np.inf
    u1 = v1 = -np.inf
    for i in range(n, 2 * n):
        u = both[i, 0] * a0 + both[i, 2] * a1
        v = -both[i, 0] * a1 + both[i, 2] * a0
        u0, u1, v0, v1 = min(u0, u), max(u1, u), min(v0, v), max(v1, v)
    u0, v0, u1, v1 = u0 - margin, v0 - margin, u1 + margin, v1 + margin
    corners = np.zeros((4, 3))
    for j, (u, v) in enumerate(((u0, v0), (u1, v0), (u1, v1), (u0, v1))):
        corners[j, 0] = u * a0 - v * a1
        corners[j, 2] = u * a1 + v * a0
    return proj @ light_view, corners


class _Layer:
    """An offscreen framebuffer kept between frames, with the key of what it holds."""

    def __init__(self):
        self.key = None
        self.fbo = self.color = self.depth = None
        self.rect = None
        self.tiles = None       # the ghost layer: vertex count of its tiles (None: not known yet)
        self._shape = None

    def framebuffer(self, ctx, size: tuple[int, int], samples: int, textures: bool):
        """The framebuffer for ``size``/``samples`` (recreated when they change)."""
        shape = (size, samples, textures)
        if shape != self._shape:
            self.release()
            if textures:
                self.color = ctx.texture(size, 4)
                self.depth = ctx.depth_texture(size)
                self.depth.compare_func = ""
                import moderngl
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


def joint_boxes(mesh, num_joints: int) -> np.ndarray:
    """Per joint, the 8 corners ``(J, 8, 4)`` (homogeneous) of the rest-pose box of the
    vertices it influences (a degenerate box at the origin for joints without vertices)."""
    boxes = np.zeros((num_joints, 8, 4))
    boxes[..., 3] = 1.0
    for j in range(num_joints):
        used = np.any((mesh.joints == j) & (mesh.weights > 0), axis=1)
        if not used.any():
            continue
        lo, hi = mesh.positions[used].min(0), mesh.positions[used].max(0)
        for k in range(8):
            boxes[j, k, :3] = [(hi if (k >> a) & 1 else lo)[a] for a in range(3)]
    return boxes


def _aces(c):
    c = np.asarray(c, float)
    return np.sqrt(np.clip((c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14), 0, 1))


def ground_light() -> tuple[tuple, tuple]:
    """Linear irradiance on the flat ground, and the display-space ratio shadowed/lit (grass)."""
    L = {k: np.asarray(v, float) for k, v in LIGHTING.items() if k != "u_haze_density"}
    ambient = L["u_sky_ambient"] + L["u_fill_color"] * max(L["u_fill_dir"][1], 0)
    lit = ambient + L["u_sun_color"] * max(L["u_sun_dir"][1], 0)
    grass = np.power(props.GRASS, 2.2)
    return tuple(lit), tuple(_aces(grass * ambient) / _aces(grass * lit))


def _rgba(c) -> tuple:
    c = tuple(float(x) for x in c)
    return c if len(c) == 4 else c + (1.0,)


def render_image(renderer: SceneRenderer, view: SceneView, samples: int = 4) -> np.ndarray:
    """Render ``view`` offscreen with MSAA (4x by default); ``(h, w, 3)`` uint8, top row first.
    Stills draw the finest batsman unless ``view.detail`` says otherwise."""
    if view.detail is None:
        from dataclasses import replace
        view = replace(view, detail=0)
    w, h = view.size
    msaa, resolve = renderer.offscreen_targets((w, h), samples)
    renderer.render(view, msaa)
    renderer.ctx.copy_framebuffer(resolve, msaa)
    data = resolve.read(components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()
