"""Which way a capture faces on the pitch (engine.capture).

A capture's world axes are its studio's: a batsman recorded facing the studio's -Z, or a
golfer whose target lies behind our bowler, swings away from the ball the viewer bowls, and
the implement's face meets it with its back (the CMU golf swing: face . toward-ball -0.49).
Studio conventions differ by multiples of 90 deg about the vertical, so a capture whose face
at its hit does not meet the ball is turned by the multiple of 90 deg that best makes it
meet it, about the vertical through its hips at the hit; a capture already facing the ball,
or holding nothing, is left as recorded. Files go back out in the capture's own frame
(engine.capture.Capture.to_file)."""
from __future__ import annotations

import numpy as np

from . import face, quat
from .choice import BALL_START
from .skeleton import Clip

FACINGS_DEG = (0, 90, 180, 270)


def check_facing(value) -> int | str:
    """``value`` as a facing: "auto" or one of FACINGS_DEG (an int, or text of one); else ValueError."""
    if value == "auto":
        return "auto"
    try:
        deg = int(value) if not isinstance(value, (bool, float)) else None
    except (TypeError, ValueError):
        deg = None
    if deg not in FACINGS_DEG:
        raise ValueError(f"facing must be auto or one of {', '.join(map(str, FACINGS_DEG))} (degrees), "
                         f"got {str(value)[:40]!r}")
    return deg


UP = np.array([0.0, 1.0, 0.0])


def yaw(degrees: float) -> np.ndarray:
    """The turn ``(4,)`` (w, x, y, z) of ``degrees`` about the vertical."""
    return quat.from_axis_angle(UP, np.radians(float(degrees)))


def turned_point(point: np.ndarray, degrees: float, pivot: np.ndarray) -> np.ndarray:
    """``point (..., 3)`` cm turned ``degrees`` about the vertical through ``pivot (3,)``."""
    q = yaw(degrees)
    return pivot + quat.rotate(q, np.asarray(point, float) - pivot)


def choose_facing(face_normal: np.ndarray, hit_point: np.ndarray, pivot: np.ndarray,
                  ball_start: np.ndarray = BALL_START) -> int:
    """The turn (deg, one of FACINGS_DEG) that makes the world ``face_normal (3,)`` at ``hit_point``
    meet a ball from ``ball_start``: 0 when it already does (face.EDGE_COS), else the best."""
    def cos(deg: float) -> float:
        return float(face.face_to_ball(quat.rotate(yaw(deg), face_normal), ball_start,
                                       turned_point(hit_point, deg, pivot)))
    if cos(0) >= face.EDGE_COS:
        return 0
    return int(max(FACINGS_DEG, key=cos))


def turn_clip(clip: Clip, degrees: float, pivot: np.ndarray) -> None:
    """Turn ``clip``'s root (joint 0) ``degrees`` about the vertical through ``pivot (3,)`` cm, in
    place: its rotation and position, and its local position where the clip has them."""
    if degrees % 360 == 0:
        return
    q = yaw(degrees)
    clip.local_rotations[:, 0] = quat.mul(q, clip.local_rotations[:, 0])
    clip.root_positions = turned_point(clip.root_positions, degrees, pivot)
    if clip.local_positions is not None:
        clip.local_positions[:, 0] = clip.root_positions
