"""Linear-blend skinning on the CPU (numba), once per pose, for every pass that draws it.

On llvmpipe the vertex shader runs on the main thread for every pass; skinning
10k vertices there costs more than this loop (~0.2 ms) plus the upload, and the
lit pass and the shadow caster then share trivial vertex shaders.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, fastmath=True, nogil=True)
def _skin(positions, normals, joints, weights, matrices, out_positions, out_normals):
    for i in range(positions.shape[0]):
        px, py, pz = positions[i, 0], positions[i, 1], positions[i, 2]
        for a in range(3):
            sp = 0.0
            sn = 0.0
            for k in range(4):
                w = weights[i, k]
                if w == 0.0:
                    continue
                m = matrices[joints[i, k]]
                sp += w * (m[a, 0] * px + m[a, 1] * py + m[a, 2] * pz + m[a, 3])
                if normals.shape[0]:
                    sn += w * (m[a, 0] * normals[i, 0] + m[a, 1] * normals[i, 1] + m[a, 2] * normals[i, 2])
            out_positions[i, a] = sp
            if normals.shape[0]:
                out_normals[i, a] = sn


class SkinnedMesh:
    """Rest positions (and normals) of a skinned mesh with reusable output arrays.

    ``pose(skin_matrices)`` returns world positions ``(V,3)`` and normals ``(V,3)``
    (unnormalised; the shaders normalise) as float32 arrays owned by this object.
    """

    def __init__(self, mesh, with_normals: bool = True):
        self.positions = np.ascontiguousarray(mesh.positions, np.float32)
        self.normals = (np.ascontiguousarray(mesh.normals, np.float32) if with_normals
                        else np.zeros((0, 3), np.float32))
        self.joints = np.ascontiguousarray(mesh.joints, np.int32)
        self.weights = np.ascontiguousarray(mesh.weights, np.float32)
        self.out_positions = np.empty_like(self.positions)
        self.out_normals = np.empty_like(self.normals)

    def pose(self, skin_matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = np.ascontiguousarray(skin_matrices, np.float32)
        _skin(self.positions, self.normals, self.joints, self.weights, m, self.out_positions, self.out_normals)
        return self.out_positions, self.out_normals
