"""Load the batsman glTF binary (pygltflib) into flat arrays for the renderer.

``load_glb(path, rig)`` returns every mesh of the file by name as a ``Mesh``:
positions, normals, sRGB colours, gloss, triangle indices and, for skinned
meshes, JOINTS_0/WEIGHTS_0 with the joint indices mapped to the rig's joint
order by joint name (so a file whose skin lists joints in another order still
binds correctly).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pygltflib

from engine.rig import assets_dir, default_rig

_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


@dataclass
class Mesh:
    positions: np.ndarray            # (V, 3) float32, cm, rest pose
    normals: np.ndarray              # (V, 3) float32
    colors: np.ndarray               # (V, 4) float32 sRGB in [0, 1]
    gloss: np.ndarray                # (V,) float32 in [0, 1]
    indices: np.ndarray              # (T, 3) uint32
    joints: np.ndarray | None = None   # (V, 4) int32 rig joint indices
    weights: np.ndarray | None = None  # (V, 4) float32, rows sum to 1
    skin_joint_names: list[str] | None = None
    inverse_bind: np.ndarray | None = None  # (J_skin, 4, 4) float32, row-major

    @property
    def num_triangles(self) -> int:
        return len(self.indices)


def default_glb_path() -> Path:
    return assets_dir() / "batsman.glb"


def _accessor(gltf, blob: bytes, index: int) -> np.ndarray:
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    dtype = np.dtype(_DTYPES[acc.componentType])
    width = _WIDTH[acc.type]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    stride = view.byteStride or dtype.itemsize * width
    if stride == dtype.itemsize * width:
        a = np.frombuffer(blob, dtype, acc.count * width, start).reshape(acc.count, width)
    else:  # interleaved
        raw = np.frombuffer(blob, np.uint8, stride * (acc.count - 1) + dtype.itemsize * width, start)
        a = np.lib.stride_tricks.as_strided(raw, (acc.count, dtype.itemsize * width), (stride, 1))
        a = a.copy().view(dtype).reshape(acc.count, width)
    if acc.normalized and dtype.kind in "ui":
        a = a.astype(np.float32) / np.iinfo(dtype).max
    return a.copy()


def load_glb(path: str | Path | None = None, rig=None) -> dict[str, Mesh]:
    """Meshes of a .glb by mesh name; primitives of one mesh are merged.

    Skinned meshes need ``rig`` (default: the bundled rig); a skin joint that the
    rig lacks raises ``ValueError`` naming it.
    """
    path = Path(path) if path else default_glb_path()
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    if blob is None:
        raise ValueError(f"{path}: no binary buffer (expected a .glb)")
    skin_of_mesh = {n.mesh: n.skin for n in gltf.nodes if n.mesh is not None}
    out = {}
    for mi, m in enumerate(gltf.meshes):
        chunks = []
        for prim in m.primitives:
            a = prim.attributes
            pos = _accessor(gltf, blob, a.POSITION).astype(np.float32)
            V = len(pos)
            nrm = _accessor(gltf, blob, a.NORMAL).astype(np.float32) if a.NORMAL is not None else np.zeros((V, 3), np.float32)
            if a.COLOR_0 is not None:
                col = _accessor(gltf, blob, a.COLOR_0).astype(np.float32)
                if col.shape[1] == 3:
                    col = np.concatenate([col, np.ones((V, 1), np.float32)], 1)
            else:
                col = np.ones((V, 4), np.float32)
            gl = getattr(a, "_GLOSS", None)
            gloss = _accessor(gltf, blob, gl)[:, 0].astype(np.float32) if gl is not None else np.full(V, 0.3, np.float32)
            idx = _accessor(gltf, blob, prim.indices).reshape(-1, 3).astype(np.uint32) if prim.indices is not None \
                else np.arange(V, dtype=np.uint32).reshape(-1, 3)
            jo = _accessor(gltf, blob, a.JOINTS_0).astype(np.int32) if a.JOINTS_0 is not None else None
            we = _accessor(gltf, blob, a.WEIGHTS_0).astype(np.float32) if a.WEIGHTS_0 is not None else None
            chunks.append((pos, nrm, col, gloss, idx, jo, we))
        offs = np.cumsum([0] + [len(c[0]) for c in chunks])[:-1]
        mesh = Mesh(np.concatenate([c[0] for c in chunks]), np.concatenate([c[1] for c in chunks]),
                    np.concatenate([c[2] for c in chunks]), np.concatenate([c[3] for c in chunks]),
                    np.concatenate([c[4] + o for c, o in zip(chunks, offs)]).astype(np.uint32))
        skin_index = skin_of_mesh.get(mi)
        if skin_index is not None and all(c[5] is not None for c in chunks):
            skin = gltf.skins[skin_index]
            names = [gltf.nodes[j].name for j in skin.joints]
            if rig is None:
                rig = default_rig()
            missing = [n for n in names if n not in rig.skeleton.names]
            if missing:
                raise ValueError(f"{path}: skin joint {missing[0]!r} is not in the rig")
            to_rig = np.array([rig.skeleton.names.index(n) for n in names], np.int32)
            mesh.joints = to_rig[np.concatenate([c[5] for c in chunks])]
            mesh.weights = np.concatenate([c[6] for c in chunks])
            mesh.skin_joint_names = names
            if skin.inverseBindMatrices is not None:
                ibm = _accessor(gltf, blob, skin.inverseBindMatrices).reshape(-1, 4, 4)
                mesh.inverse_bind = np.ascontiguousarray(ibm.transpose(0, 2, 1)).astype(np.float32)
        out[m.name or f"mesh{mi}"] = mesh
    return out
