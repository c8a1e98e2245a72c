"""The clean-up's third fix (engine.cleanup): a synthesised take's bat meets the ball with the
source's face.

A take made in the shot's PC space (engine.synth) keeps about half its pose variance in two
PCs, and the bat's turn about its handle is not among what they keep: measured 2026-12-04 on
the bundled shots, the 2-PC takes met a ball bowled at their bat with the edge or the back in 5
of 36 (preset x shot), the face up to 106 deg from the source's, the square cut's ball going
to the leg side. So at the take's hit frame the face is turned back to the source's there,
by the adaptation's own face-keeping solve (engine.adapt: the left arm's free joints within
their limits, the importance blend carrying the turn to the neighbouring frames, the right
hand back on its grip), the bat joint staying where the take has it."""
from __future__ import annotations

import numpy as np

from . import quat
from .adapt import AdaptSettings, Adapter
from .library import Shot
from .rig import Rig
from .skeleton import Clip, Skeleton


def turn_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The shortest rotation vector ``(3,)`` rad taking direction ``a`` to ``b``
    (:func:`engine.quat.between` as the adapter's face turn wants it)."""
    return quat.log(quat.between(a, b))


def keep_source_face(rig: Rig, skeleton: Skeleton, clip: Clip, source_face: np.ndarray, hit_frame: int) -> float:
    """Turn the bat's face of ``clip`` at ``hit_frame`` to ``source_face`` (world, unit ``(3,)``),
    in place; the bat joint stays where the clip has it. Returns the angle (deg) left
    between the two faces."""
    take = Shot("take", "", int(hit_frame), "", skeleton, clip, rig.bat_joint)
    g_rot, g_pos = take.fk
    normal = np.asarray(rig.bat["face_normal"], float)
    face = quat.rotate(g_rot[hit_frame, rig.bat_joint], normal)
    a = Adapter(rig, take).adapt(g_pos[hit_frame, rig.bat_joint], AdaptSettings(), turn=turn_between(face, source_face))
    clip.local_rotations[:] = a.local_rotations
    kept = quat.rotate(a.global_rotations[hit_frame, rig.bat_joint], normal)
    return float(np.degrees(np.arccos(np.clip(np.dot(kept, source_face), -1.0, 1.0))))
