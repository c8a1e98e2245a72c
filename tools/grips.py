"""How the batsman's hands hold the bat, for the rig (tools/make_rig) and the shot authoring
(tools/shots_ik): a grip is data, named here, so a library can be built with either.

Hand frames are the rig's (the T-pose, palm down): X along the fingers (+X on the left hand,
-X on the right), Y out of the back of the hand, Z toward the thumb. The bat's frame is the
authoring's (tools/shots_ik.grip_frame): X across the blade, Y the face normal, Z from the toe
up the handle.

- ``library``: the grip the bundled shots were authored with. Both hands hold the bat upside
  down (an ice-pick grip: the top hand's toe beyond the little finger, the bottom hand's thumb
  up the handle), so the bat's hang asks the wrists for 55-75 deg of deviation (AAOS: radial
  20, ulnar 30); the rig's Hand y is widened for it.
- ``anatomical``: a real grip. The top hand's toe beyond the thumb and forefinger, the handle
  diagonal across the fingers; the bottom hand's palm behind the face. Hand y at AAOS.
"""
from __future__ import annotations

import numpy as np

from .shots_maths import rot_axis, unit

GRIPS = {
    "library": {"top_toe_deg": -90.0, "top_face_deg": 0.0, "right": "library", "hand_y": [-75, 55]},
    "anatomical": {"top_toe_deg": 20.0, "top_face_deg": -60.0,
                   "right": {"toe_deg": 20.0, "face_deg": -90.0}, "hand_y": [-20, 30]},
}


def _about(axis: np.ndarray, v: np.ndarray, deg: float) -> np.ndarray:
    """``v`` turned ``deg`` about the unit ``axis`` (Rodrigues)."""
    a, c, s = unit(axis), np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return v * c + np.cross(a, v) * s + a * (a @ v) * (1.0 - c)


def top_hand(grip: dict) -> tuple[list, list]:
    """The rig's ``bat.axis`` (handle -> toe) and ``bat.face_normal`` in LeftHand's frame:
    the toe turned ``top_toe_deg`` from the fingers (+X) toward the thumb (+Z; -90: toward the
    little finger), the face normal the back of the hand (+Y) turned ``top_face_deg`` about
    the handle."""
    t = np.radians(grip["top_toe_deg"])
    toe = np.array([np.cos(t), 0.0, np.sin(t)])
    face = _about(toe, np.array([0.0, 1.0, 0.0]), grip["top_face_deg"])
    clean = lambda v: [round(float(x), 12) + 0.0 for x in v]
    return clean(toe), clean(face)


def right_in_bat(grip: dict) -> np.ndarray:
    """The bottom (right) hand's rotation in the bat's frame ``(3, 3)``: columns are RightHand's
    axes in bat coordinates (the hand's world rotation is the bat's times this)."""
    right = grip["right"]
    if right == "library":
        # the handle square across the palm, thumb up the handle, tilted so it lies
        # diagonally across palm and fingers (wrist extended ~40, deviated ~60 toward the toe)
        return rot_axis(2, 180.0) @ rot_axis(1, -60.0) @ rot_axis(2, 40.0)
    t = np.radians(right["toe_deg"])
    toe = np.array([-np.cos(t), 0.0, np.sin(t)])                 # from the fingers (-X) toward the thumb
    face = _about(toe, np.array([0.0, -1.0, 0.0]), right["face_deg"])  # the palm behind the face
    z = -toe
    bat_in_hand = np.stack([np.cross(face, z), face, z], -1)
    return bat_in_hand.T
