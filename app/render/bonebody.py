"""A body for a skeleton that has no mesh of its own (a user's capture): a capsule
along every bone, rigidly skinned to the bone's joint, a sphere for the head and
the implement its profile names (a cricket bat or a golf club) in the lead hand.
trimesh builds the shapes."""
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
CLUB_SHAFT_CM = 100.0                  # a mid iron: grip to heel
CLUB_GRIP_CM = (26.0, 1.4)             # length and radius of the grip
CLUB_HEAD_CM = (9.0, 2.5, 5.0)         # toe-to-heel, thickness, height of the head
STEEL = (0.72, 0.74, 0.78, 1.0)
RUBBER = (0.12, 0.12, 0.13, 1.0)
IMPLEMENTS = ("bat", "club")           # the kinds drawn; any other kind is not drawn
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


def _rod(start: np.ndarray, axis: np.ndarray, length: float, radius: float):
    rod = trimesh.creation.cylinder(radius=radius, height=length, sections=10)
    rod.apply_translation([0, 0, length / 2])
    return _oriented(rod, start, start + axis * length)


def _bat(top: np.ndarray, axis: np.ndarray) -> list:
    """A cricket bat from ``top`` along ``axis``: the handle, then the blade."""
    length, width, thick = BAT_BLADE_CM
    blade = trimesh.creation.box(extents=[width, thick, length])
    blade.apply_translation([0, 0, length / 2])
    start = top + axis * BAT_HANDLE_CM
    return [(_rod(top, axis, BAT_HANDLE_CM, 1.6), WILLOW), (_oriented(blade, start, start + axis * length), WILLOW)]


def _club(top: np.ndarray, axis: np.ndarray) -> list:
    """A golf club from ``top`` along ``axis``: the grip, the shaft, the head at its end."""
    grip_length, grip_radius = CLUB_GRIP_CM
    toe, thick, height = CLUB_HEAD_CM
    head = trimesh.creation.box(extents=[toe, thick, height])
    head.apply_translation([toe / 2 - 1.0, 0, height / 2])       # the hosel at the shaft's end
    end = top + axis * CLUB_SHAFT_CM
    return [(_rod(top, axis, grip_length, grip_radius), RUBBER), (_rod(top, axis, CLUB_SHAFT_CM, 0.6), STEEL),
            (_oriented(head, end - axis * height, end), STEEL)]


def _implement(rig, bind: np.ndarray, kind: str, axis_world: np.ndarray, parts: list) -> None:
    """The implement ``kind`` held in the lead hand along ``axis_world`` (rest pose)."""
    hand = int(rig.skeleton.parents[rig.bat_joint])
    axis = axis_world / np.linalg.norm(axis_world)
    top = bind[hand] - axis * BAT_TOP_CM
    shapes = _club(top, axis) if kind == "club" else _bat(top, axis)
    parts.extend(_part(mesh, hand, color) for mesh, color in shapes)


def bone_body(rig, head: int | None, implement: dict | None = None) -> Mesh:
    """The body mesh (rest pose, cm) of ``rig``; ``head`` the head joint (or None);
    ``implement`` the rig's implement (``rig.bat``: its ``kind``, "bat" when unsaid, and
    ``axis``, its direction in the rest pose, and ``held``, false where the hands hold
    nothing); none drawn without an axis, when not held or for a kind not in IMPLEMENTS."""
    bind = bind_positions(rig.skeleton)
    parts: list = []
    _bones(rig, bind, parts)
    _head(rig, head, bind, parts)
    implement = implement or {}
    kind = implement.get("kind", "bat")
    if implement.get("axis") is not None and implement.get("held", True) and kind in IMPLEMENTS:
        _implement(rig, bind, kind, np.asarray(implement["axis"], float), parts)
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
