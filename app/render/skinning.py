"""Linear-blend skinning on the GL side and the GPU buffers of the meshes the passes draw.

A transform-feedback pass (``shaders/skin.vert``) reads static buffers (bind positions,
normals, joints, weights) and one bone-matrix uniform block, and writes skinned positions
(and normals) into a buffer that the ordinary programs draw like a rigid mesh."""
from __future__ import annotations

import moderngl
import numpy as np

from .gl import mat_bytes, shader_source


def vao(ctx, prog, buffers, index_buffer=None):
    """Vertex array binding only the attributes the compiled program kept."""
    content = [entry for entry in buffers if all(name in prog for name in entry[2:])]
    return ctx.vertex_array(prog, content, index_buffer=index_buffer)


def skin_programs(ctx, num_joints: int) -> dict:
    """The skinning programs, with normals (drawn levels) and without (the shadow caster)."""
    progs = {}
    for with_normals in (True, False):
        src = shader_source("skin.vert").replace("#version 330", f"#version 330\n#define NUM_JOINTS {num_joints}"
                                                 f"\n#define WITH_NORMALS {int(with_normals)}", 1)
        prog = ctx.program(vertex_shader=src, varyings=["out_pos", "out_normal"] if with_normals else ["out_pos"])
        prog["Bones"].binding = 0
        progs[with_normals] = prog
    return progs


class MeshGPU:
    """Static buffers of one rigid mesh, with a lit VAO and a depth-only VAO."""

    def __init__(self, ctx, mesh, lit_prog, depth_prog):
        self.buffers = [ctx.buffer(np.ascontiguousarray(a, dtype=dt).tobytes()) for a, dt in (
            (mesh.positions, "f4"), (mesh.normals, "f4"), (mesh.colors, "f4"), (mesh.gloss, "f4"))]
        self.ibo = ctx.buffer(np.ascontiguousarray(mesh.indices, dtype="u4").tobytes())
        pos, nrm, col, gl = self.buffers
        attrs = [(pos, "3f", "in_pos"), (nrm, "3f", "in_normal"), (col, "4f", "in_color"), (gl, "1f", "in_gloss")]
        self.lit = vao(ctx, lit_prog, attrs, self.ibo)
        self.depth = vao(ctx, depth_prog, [(pos, "3f", "in_pos")], self.ibo)


class Skinner:
    """One skinned mesh: its transform-feedback VAO and the buffer it writes,
    ``(V, 3[+3]) float32`` interleaved (position, normal)."""

    def __init__(self, ctx, prog, mesh, with_normals: bool):
        self.count = len(mesh.positions)
        self.static = [ctx.buffer(np.ascontiguousarray(a, dtype=dt).tobytes()) for a, dt in (
            (mesh.positions, "f4"), (mesh.joints, "i4"), (mesh.weights, "f4"))]
        attrs = [(self.static[0], "3f", "in_pos"), (self.static[1], "4i", "in_joints"),
                 (self.static[2], "4f", "in_weights")]
        if with_normals:
            self.static.append(ctx.buffer(np.ascontiguousarray(mesh.normals, dtype="f4").tobytes()))
            attrs.append((self.static[3], "3f", "in_normal"))
        self.vao = vao(ctx, prog, attrs)
        self.out = ctx.buffer(reserve=self.count * (24 if with_normals else 12))
        self.key = None      # the bone matrices (bytes) the buffer was skinned with

    def skin(self) -> None:
        """Skin with the matrices currently in the bound bone block."""
        self.vao.transform(self.out, moderngl.POINTS, vertices=self.count)

    def read(self) -> np.ndarray:
        """The skinned vertices ``(V, 3)`` or ``(V, 6)`` (position, normal) read back (tests)."""
        return np.frombuffer(self.out.read(), np.float32).reshape(self.count, -1)


class BodyLevel:
    """One level of detail of the batsman: its skinner and, over the skinned buffer, the
    VAOs of its lit pass (``lit_prog``: pixel- or vertex-lit) and of the depth-only program."""

    def __init__(self, ctx, skin_prog, mesh, lit_prog, depth_prog):
        self.mesh = mesh
        self.skinner = Skinner(ctx, skin_prog, mesh, True)
        self.static = [ctx.buffer(np.ascontiguousarray(a, dtype="f4").tobytes()) for a in (mesh.colors, mesh.gloss)]
        self.ibo = ctx.buffer(np.ascontiguousarray(mesh.indices, dtype="u4").tobytes())
        out = self.skinner.out
        attrs = [(out, "3f 3f", "in_pos", "in_normal"), (self.static[0], "4f", "in_color"),
                 (self.static[1], "1f", "in_gloss")]
        self.lit = vao(ctx, lit_prog, attrs, self.ibo)
        self.depth = vao(ctx, depth_prog, [(out, "3f 12x", "in_pos")], self.ibo)


class PosedBody:
    """The batsman skinned once per pose: one of his levels of detail (finest first) lit,
    and the coarse shadow caster (skinned with it). ``update(..., level)`` skins only the
    level about to be drawn."""

    def __init__(self, ctx, skin_progs, num_joints, body_meshes, caster_mesh, lit_progs, depth_prog):
        """``lit_progs``: per level, the program of its lit pass (the last one repeats)."""
        self.bones = ctx.buffer(reserve=num_joints * 64)   # (J,4,4) float32: this body's bone block
        self.levels = [BodyLevel(ctx, skin_progs[True], m, lit_progs[min(i, len(lit_progs) - 1)], depth_prog)
                       for i, m in enumerate(body_meshes)]
        self.caster = Skinner(ctx, skin_progs[False], caster_mesh, False) if caster_mesh is not None else None
        if self.caster is not None:
            self.caster_ibo = ctx.buffer(np.ascontiguousarray(caster_mesh.indices, dtype="u4").tobytes())
            self.caster_vao = vao(ctx, depth_prog, [(self.caster.out, "3f", "in_pos")], self.caster_ibo)
        self.level = 0
        self._bones_key = None

    @property
    def body(self) -> Skinner:
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


def skinned_box_corners(skin_matrices: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """World corners ``(J*8, 3)`` of the per-joint rest boxes ``(J,8,4)`` moved by their joints."""
    # a batched matmul: ~3x faster than the einsum it replaces (it runs several times a frame)
    return np.matmul(boxes, np.asarray(skin_matrices, float)[:, :3].transpose(0, 2, 1)).reshape(-1, 3)
