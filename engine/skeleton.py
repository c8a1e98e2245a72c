"""Skeletons and clips as plain arrays, and forward kinematics over all frames.

A skeleton is ``names``, ``parents`` (``parents[i] < i``, root has -1) and
``offsets (J, 3)`` in the parent's frame (world-aligned in the rest pose, as in
BVH). A clip is ``root_positions (F, 3)`` and ``local_rotations (F, J, 4)``;
files with translation channels on non-root joints keep them in
``local_positions (F, J, 3)``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import quat


@dataclass
class Skeleton:
    names: list[str]
    parents: np.ndarray                 # (J,) int, parents[i] < i
    offsets: np.ndarray                 # (J, 3) cm, in the parent's frame
    channel_orders: list[str] = field(default_factory=list)   # per joint, e.g. "ZYX"
    position_channels: list[bool] = field(default_factory=list)  # per joint
    end_sites: dict[int, np.ndarray] = field(default_factory=dict)  # joint -> offset

    def __post_init__(self):
        self.parents = np.asarray(self.parents, dtype=np.int64)
        self.offsets = np.asarray(self.offsets, dtype=float)
        J = len(self.names)
        if not self.channel_orders:
            self.channel_orders = ["ZYX"] * J
        if not self.position_channels:
            self.position_channels = [i == 0 for i in range(J)]
        if self.parents.shape != (J,) or self.offsets.shape != (J, 3):
            raise ValueError("skeleton arrays do not match the number of names")
        for i, p in enumerate(self.parents):
            if not (p < i) or (i > 0 and p < 0):
                raise ValueError(f"joint {self.names[i]!r}: parent index {p} must be in [0, {i})")

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of a joint by name; a clear error for unknown names."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"unknown joint {name!r}") from None

    def children(self, i: int) -> list[int]:
        return [int(c) for c in np.nonzero(self.parents == i)[0]]

    def chain(self, start: str, end: str) -> list[int]:
        """Joint indices from ``start`` down to ``end`` (inclusive), root-most first."""
        s, e = self.index(start), self.index(end)
        path = [e]
        while path[-1] != s:
            p = int(self.parents[path[-1]])
            if p < 0:
                raise ValueError(f"{end!r} is not below {start!r}")
            path.append(p)
        return path[::-1]


@dataclass
class Clip:
    root_positions: np.ndarray          # (F, 3)
    local_rotations: np.ndarray         # (F, J, 4) (w, x, y, z)
    fps: float = 30.0
    local_positions: np.ndarray | None = None  # (F, J, 3) when the file animates them

    @property
    def num_frames(self) -> int:
        return self.local_rotations.shape[0]

    def copy(self) -> "Clip":
        return Clip(self.root_positions.copy(), self.local_rotations.copy(), self.fps,
                    None if self.local_positions is None else self.local_positions.copy())


def local_translations(skeleton: Skeleton, clip: Clip) -> np.ndarray:
    """Per-frame local translations ``(F, J, 3)``: offsets, root and animated channels."""
    F = clip.num_frames
    if clip.local_positions is not None:
        t = clip.local_positions.copy()
    else:
        t = np.broadcast_to(skeleton.offsets, (F,) + skeleton.offsets.shape).copy()
    t[:, 0] = clip.root_positions
    return t


def forward_kinematics(parents: np.ndarray, local_translations: np.ndarray,
                       local_rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations ``(..., J, 4)`` and positions ``(..., J, 3)``.

    Loops over joints and broadcasts over any leading (frame) axes.
    """
    J = len(parents)
    g_rot = np.empty(local_rotations.shape[:-2] + (J, 4))
    g_pos = np.empty(np.broadcast_shapes(local_translations.shape[:-2],
                                         local_rotations.shape[:-2]) + (J, 3))
    for j in range(J):
        p = parents[j]
        if p < 0:
            g_rot[..., j, :] = local_rotations[..., j, :]
            g_pos[..., j, :] = local_translations[..., j, :]
        else:
            g_rot[..., j, :] = quat.mul(g_rot[..., p, :], local_rotations[..., j, :])
            g_pos[..., j, :] = g_pos[..., p, :] + quat.rotate(g_rot[..., p, :], local_translations[..., j, :])
    return g_rot, g_pos


def pose_fk(skeleton: Skeleton, root_positions: np.ndarray, local_rotations: np.ndarray,
            one_pose: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """FK of poses ``root_positions (..., 3)``, ``local_rotations (..., J, 4)`` on the
    skeleton's offsets. ``one_pose``: a single pose ``(3,)``, ``(J, 4)`` by 3x3
    matrices, far cheaper than quaternion ops on tiny arrays (the PC pad's marker
    moves every frame)."""
    root = np.asarray(root_positions, float)
    if not one_pose:
        t = np.broadcast_to(skeleton.offsets, root.shape[:-1] + skeleton.offsets.shape).copy()
        t[..., 0, :] = root
        return forward_kinematics(skeleton.parents, t, local_rotations)
    R = quat.to_matrix(local_rotations)
    G = np.empty_like(R)
    P = np.empty((skeleton.num_joints, 3))
    for j, p in enumerate(skeleton.parents):
        if p < 0:
            G[j], P[j] = R[j], root
        else:
            G[j] = G[p] @ R[j]
            P[j] = P[p] + G[p] @ skeleton.offsets[j]
    return quat.from_matrix(G), P


def clip_fk(skeleton: Skeleton, clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """FK of a whole clip: ``(F, J, 4)`` global rotations, ``(F, J, 3)`` positions."""
    return forward_kinematics(skeleton.parents, local_translations(skeleton, clip), clip.local_rotations)


def relative_pose(frame_rot: np.ndarray, frame_pos: np.ndarray, rot: np.ndarray, pos: np.ndarray):
    """A global pose (``rot (..., 4)``, ``pos (..., 3)``) in the frame of another (``frame_rot``,
    ``frame_pos``): ``(position, rotation)`` relative to it (the trail hand's grip in the lead hand's)."""
    inv = quat.conjugate(frame_rot)
    return quat.rotate(inv, pos - frame_pos), quat.mul(inv, rot)


def carried_pose(frame_rot: np.ndarray, frame_pos: np.ndarray, rel_pos: np.ndarray, rel_rot: np.ndarray):
    """The global ``(position, rotation)`` of a pose held at ``rel_pos``, ``rel_rot`` in a frame
    now at ``frame_rot``, ``frame_pos`` (the inverse of :func:`relative_pose`)."""
    return frame_pos + quat.rotate(frame_rot, rel_pos), quat.mul(frame_rot, rel_rot)


def bind_positions(skeleton: Skeleton) -> np.ndarray:
    """Rest-pose global joint positions ``(J, 3)`` (root at its offset)."""
    J = skeleton.num_joints
    _, pos = forward_kinematics(skeleton.parents, skeleton.offsets, quat.identity((J,)))
    return pos


def skinning_matrices(global_rotations: np.ndarray, global_positions: np.ndarray,
                      bind_positions: np.ndarray) -> np.ndarray:
    """Flat bone-matrix buffer ``(..., J, 4, 4)`` float32 for GPU skinning.

    With world-aligned rest frames the inverse bind matrix is a translation by
    ``-bind_positions``, so ``M = [R | p - R b]``.
    """
    R = quat.to_matrix(global_rotations)
    t = global_positions - np.einsum("...ij,...j->...i", R, bind_positions)
    M = np.zeros(global_rotations.shape[:-1] + (4, 4), dtype=np.float32)
    M[..., :3, :3] = R
    M[..., :3, 3] = t
    M[..., 3, 3] = 1.0
    return M


def reorder_joints(skeleton: Skeleton, clip: Clip, names: list[str]) -> tuple[Skeleton, Clip]:
    """The same skeleton and clip with joints permuted into the order of ``names``.

    BVH files list joints depth first; a rig may list them in another order
    (e.g. helper joints last). Parents must still precede children.
    """
    if sorted(names) != sorted(skeleton.names):
        raise ValueError("reorder_joints: joint names differ")
    perm = [skeleton.names.index(n) for n in names]
    inv = {old: new for new, old in enumerate(perm)}
    parents = np.array([-1 if skeleton.parents[o] < 0 else inv[int(skeleton.parents[o])] for o in perm])
    skel = Skeleton(list(names), parents, skeleton.offsets[perm],
                    [skeleton.channel_orders[o] for o in perm],
                    [skeleton.position_channels[o] for o in perm],
                    {inv[j]: v for j, v in skeleton.end_sites.items()})
    out = Clip(clip.root_positions.copy(), clip.local_rotations[:, perm].copy(), clip.fps,
               None if clip.local_positions is None else clip.local_positions[:, perm].copy())
    return skel, out
