"""Writing a take (a skeleton and a clip) to the formats users load elsewhere:
BVH, CSV and glTF (binary .glb or .gltf). One entry point, :func:`write_take`,
chosen by the file's extension; every writer is atomic."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import bvh
from .skeleton import Clip, Skeleton

EXTENSIONS = (".bvh", ".csv", ".glb", ".gltf")


def write_take(out: str | Path, skeleton: Skeleton, clip: Clip, *, name: str, limits: np.ndarray | None = None,
               blend: np.ndarray | None = None, reference: np.ndarray | None = None) -> None:
    """Write ``clip`` on ``skeleton`` to ``out`` (format by extension).

    ``name`` names the animation (glTF); BVH and CSV Euler angles are continuous
    over frames (:func:`engine.bvh.file_euler`), from the branch inside ``limits``
    (J, 3, 2) degrees (each joint's channel order) at frame 0, keeping
    ``reference`` (F, J, 3) -- the source file's numbers -- where the rotation is
    unchanged; ``blend`` (F,) is the importance blend written as the CSV's second
    column."""
    suffix = Path(out).suffix.lower()
    if suffix == ".bvh":
        bvh.write(out, skeleton, clip, limits=limits, reference=reference)
    elif suffix in (".glb", ".gltf"):
        from .gltf_export import write_gltf  # pygltflib: only when a glTF is written
        write_gltf(out, skeleton, clip, name=name)
    elif suffix == ".csv":
        write_csv(out, skeleton, clip, limits, blend, reference)
    else:
        raise ValueError(f"unknown extension {suffix or '(none)'!r} (use {', '.join(EXTENSIONS)})")


def write_csv(out, skeleton: Skeleton, clip: Clip, limits: np.ndarray | None, blend: np.ndarray | None,
              reference: np.ndarray | None = None) -> None:
    """One row a frame: frame, blend, root position, then Euler z, y, x per joint."""
    F = clip.num_frames
    e = bvh.file_euler(skeleton, clip, limits, reference)
    blend = np.zeros(F) if blend is None else blend
    head = ["frame", "blend", "root_x", "root_y", "root_z"] + [
        f"{n}_{ax}" for n in skeleton.names for ax in ("z", "y", "x")]
    rows = [",".join(head)]
    for f in range(F):
        vals = [str(f), f"{blend[f]:.6f}"] + [f"{v:.6f}" for v in clip.root_positions[f]] + [
            f"{v:.6f}" for v in e[f].reshape(-1)]
        rows.append(",".join(vals))
    bvh.atomic_write_text(out, "\n".join(rows) + "\n")
