"""The clean-up's third fix (engine.cleanup): a synthesised take meets the ball where the source
shot does, with the source's face.

A take made in the shot's PC space (engine.synth) keeps about half its pose variance in two
PCs. Neither the bat's turn about its handle nor where the bat is at the hit are among what
they keep. Measured 2026-12-04 on the bundled shots:

* the face: the 2-PC takes met a ball bowled at their bat with the edge or the back in 5 of
  36 (preset x shot), the face up to 106 deg from the source's, the square cut's ball going
  to the leg side;
* the place: at the hit frame the 2-PC cover drive's bat was 94 cm from the shot's hit point
  (86 cm higher: the ball met over the batsman's head), the on drive's 76, the square cut's
  53, the pull's 51; the frame nearest the hit point was still 13-65 cm off.

So at the take's hit frame the bat is brought to the shot's hit point and its face turned to
the source's there, by the adaptation itself (engine.adapt: the left arm's free joints within
their limits, the importance blend carrying the move and the turn to the neighbouring frames,
the right hand back on its grip) run on the take as its source."""
from __future__ import annotations

import numpy as np

from . import quat
from .adapt import END_GUARD_FRAMES, AdaptSettings, Adapter
from .library import Shot
from .rig import Rig
from .skeleton import Clip, Skeleton


def turn_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The shortest rotation vector ``(3,)`` rad taking direction ``a`` to ``b``
    (:func:`engine.quat.between` as the adapter's face turn wants it)."""
    return quat.log(quat.between(a, b))


def meet_ball(rig: Rig, skeleton: Skeleton, clip: Clip, source_face: np.ndarray, hit_frame: int,
              hit_point: np.ndarray | None = None) -> tuple[float, float, float]:
    """Bring the bat joint of ``clip`` at ``hit_frame`` to ``hit_point`` (world ``(3,)`` cm;
    None: where the clip has it) with its face turned to ``source_face`` (world, unit
    ``(3,)``), in place. Returns ``(face angle left (deg), bat error (cm), bat moved (cm))``."""
    take = Shot("take", "", int(hit_frame), "", skeleton, clip, rig.bat_joint)
    g_rot, g_pos = take.fk
    normal = np.asarray(rig.bat["face_normal"], float)
    face = quat.rotate(g_rot[hit_frame, rig.bat_joint], normal)
    bat = g_pos[hit_frame, rig.bat_joint]
    target = bat if hit_point is None else np.asarray(hit_point, float)
    # a take whose hit lies at one of its ends (a drawn path that stops at the hit pose) meets
    # the ball there: the shots' rule that the ends stay FK would keep the bat from it
    inside = END_GUARD_FRAMES <= hit_frame < clip.num_frames - END_GUARD_FRAMES
    a = Adapter(rig, take, end_guard=inside).adapt(target, AdaptSettings(), turn=turn_between(face, source_face))
    clip.local_rotations[:] = a.local_rotations
    kept = quat.rotate(a.global_rotations[hit_frame, rig.bat_joint], normal)
    angle = float(np.degrees(np.arccos(np.clip(np.dot(kept, source_face), -1.0, 1.0))))
    return angle, a.bat_error_cm, float(np.linalg.norm(target - bat))
