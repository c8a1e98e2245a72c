"""The shot library: a manifest of BVH source shots with their hit frames."""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from . import bvh
from .rig import Rig, assets_dir, default_rig
from .skeleton import Clip, Skeleton, clip_fk, reorder_joints


@dataclass
class Shot:
    name: str
    file: str
    hit_frame: int
    description: str
    skeleton: Skeleton
    clip: Clip
    bat_joint: int

    @cached_property
    def fk(self) -> tuple[np.ndarray, np.ndarray]:
        """Global rotations ``(F, J, 4)`` and positions ``(F, J, 3)`` of the source."""
        return clip_fk(self.skeleton, self.clip)

    @property
    def hit_point(self) -> np.ndarray:
        """FK position of the bat joint at the hit frame ``(3,)``."""
        return self.fk[1][self.hit_frame, self.bat_joint]

    @property
    def num_frames(self) -> int:
        return self.clip.num_frames


def conform_to_rig(rig: Rig, skeleton: Skeleton, clip: Clip, where: str) -> tuple[Skeleton, Clip]:
    """The clip with its joints in the rig's order; a clear error if they differ."""
    if sorted(skeleton.names) != sorted(rig.skeleton.names):
        missing = sorted(set(rig.skeleton.names) - set(skeleton.names))
        extra = sorted(set(skeleton.names) - set(rig.skeleton.names))
        detail = (f"missing {', '.join(missing[:3])}" if missing else f"unknown {', '.join(extra[:3])}")
        raise ValueError(f"{where}: joints do not match the rig ({detail})")
    if skeleton.names != rig.skeleton.names:
        skeleton, clip = reorder_joints(skeleton, clip, rig.skeleton.names)
    return skeleton, clip


def load_library(manifest: str | Path | None = None, rig: Rig | None = None) -> list[Shot]:
    """Load every shot of a manifest (default: the bundled library)."""
    rig = rig or default_rig()
    manifest = Path(manifest) if manifest else assets_dir() / "shots" / "library.json"
    entries = json.loads(manifest.read_text())
    shots = []
    for e in entries:
        path = manifest.parent / e["file"]
        skel, clip = bvh.read(path)
        skel, clip = conform_to_rig(rig, skel, clip, str(path))
        h = int(e["hit_frame"])
        if not 0 <= h < clip.num_frames:
            raise ValueError(f"{path}: hit frame {h} outside 0..{clip.num_frames - 1}")
        shots.append(Shot(e["name"], e["file"], h, e.get("description", ""), skel, clip, rig.bat_joint))
    return shots


def find_shot(shots: list[Shot], name: str) -> Shot:
    for s in shots:
        if s.name == name:
            return s
    raise KeyError(f"unknown shot {name!r} (known: {', '.join(s.name for s in shots)})")
