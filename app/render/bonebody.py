"""A body for a skeleton that has no mesh of its own (a user's capture): a capsule
along every bone, rigidly skinned to the bone's joint, a sphere for the head and
the implement drawn as a bat in the lead hand. trimesh builds the shapes."""
from __future__ import annotations

import numpy as np
import trimesh

from app.render.mesh import Mesh
from engine.skeleton import bind_positions

SKIN = (0.86, 0.70, 0.58, 1.0)
KIT = (0.93, 0.93, 0.90, 1.0)          # cricket whites
WILLOW = (0.85, 0.72, 0.48, 1.0)
BONE_RADIUS = (0.09, 2.0, 6.0)         # radius = 9 % of the bone's length, within [2, 6] cm
HEAD_RADIUS_CM = 10.0
BAT_BLADE_CM = (56.0, 10.8, 4.0)       # length, width, thickness of a bat's blade
BAT_HANDLE_CM = 30.0
BAT_TOP_CM = 5.0                       # the handle's top above the lead hand
MIN_BONE_CM = 1.0                      # shorter bones (CMU's zero-length joints) get no capsule


def _oriented(mesh, start: np.ndarray, end: np.ndarray):
    """A trimesh shape built along +Z from 0 to |end - start|, moved onto the segment."""
    d = end - start
    T = trimesh.geometry.align_vectors([0, 0, 1], d / np.linalg.norm(d))
    T[:3, 3] = start
    mesh.apply_transform(T)
    return mesh


def _part(mesh, joint: int, color) -> tuple:
    V = len(mesh.vertices)
    return (np.asarray(mesh.vertices, np.float32), np.asarray(mesh.vertex_normals, np.float32),
            np.tile(np.asarray(color, np.float32), (V, 1)), np.asarray(mesh.faces, np.uint32),
            np.full(V, joint, np.int32))


def _bones(rig, bind: np.ndarray, parts: list) -> None:
    skel = rig.skeleton
    implement = rig.bat_joint
    for j in range(1, skel.num_joints):
        p = int(skel.parents[j])
        length = float(np.linalg.norm(bind[j] - bind[p]))
        if j == implement or length < MIN_BONE_CM:
            continue
        k, lo, hi = BONE_RADIUS
        r = float(np.clip(k * length, lo, hi))
        cap = trimesh.creation.capsule(height=length, radius=r, count=[10, 10])
        cap.apply_translation([0, 0, length / 2])      # capsule() is centred on the origin
        parts.append(_part(_oriented(cap, bind[p], bind[j]), p, KIT))


def _head(rig, roles_head: int | None, bind: np.ndarray, parts: list) -> None:
    if roles_head is None:
        return
    ball = trimesh.creation.icosphere(subdivisions=2, radius=HEAD_RADIUS_CM)
    ball.apply_translation(bind[roles_head] + [0, HEAD_RADIUS_CM * 0.6, 0])
    parts.append(_part(ball, roles_head, SKIN))


def _bat(rig, bind: np.ndarray, axis_world: np.ndarray, parts: list) -> None:
    """Handle from the lead hand along ``axis_world`` (rest pose), then the blade."""
    hand = int(rig.skeleton.parents[rig.bat_joint])
    axis = axis_world / np.linalg.norm(axis_world)
    top = bind[hand] - axis * BAT_TOP_CM
    handle = trimesh.creation.cylinder(radius=1.6, height=BAT_HANDLE_CM, sections=10)
    handle.apply_translation([0, 0, BAT_HANDLE_CM / 2])
    parts.append(_part(_oriented(handle, top, top + axis * BAT_HANDLE_CM), hand, WILLOW))
    length, width, thick = BAT_BLADE_CM
    blade = trimesh.creation.box(extents=[width, thick, length])
    blade.apply_translation([0, 0, length / 2])
    start = top + axis * BAT_HANDLE_CM
    parts.append(_part(_oriented(blade, start, start + axis * length), hand, WILLOW))


def bone_body(rig, head: int | None, bat_axis: np.ndarray | None) -> Mesh:
    """The body mesh (rest pose, cm) of ``rig``; ``head`` the head joint (or None);
    ``bat_axis`` the bat's direction in the rest pose (None: no bat)."""
    bind = bind_positions(rig.skeleton)
    parts: list = []
    _bones(rig, bind, parts)
    _head(rig, head, bind, parts)
    if bat_axis is not None:
        _bat(rig, bind, np.asarray(bat_axis, float), parts)
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])[:-1]
    V = int(sum(len(p[0]) for p in parts))
    joints = np.zeros((V, 4), np.int32)
    joints[:, 0] = np.concatenate([p[4] for p in parts])
    weights = np.zeros((V, 4), np.float32)
    weights[:, 0] = 1.0
    return Mesh(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                np.concatenate([p[2] for p in parts]), np.full(V, 0.25, np.float32),
                np.concatenate([p[3] + o for p, o in zip(parts, offsets)]).astype(np.uint32),
                joints, weights)
