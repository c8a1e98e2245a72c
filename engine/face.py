"""The bat face and where the ball goes (DESIGN.md, "Where the ball goes").

Vectorised over any leading shape; quaternions (w, x, y, z).

- the face normal is the rig's ``face_normal`` in the Bat joint's frame;
- ``face_to_ball`` is the cosine between that normal and the direction from
  the hit point toward the incoming ball (1: the face looks straight at it);
- the ball's azimuth is measured in the ground plane from straight back past
  the bowler (0 deg, +Z), positive toward the off side (-X for the right-hander:
  cover ~+60, point +90, mid-wicket ~-70, fine leg ~-140); elevation above the
  ground plane.
"""
from __future__ import annotations

import numpy as np

from . import quat

# Below this |face_to_ball| the ball meets the edge. The ball's path then lies
# within asin(0.2) = 11.5 deg of the face plane: a depth error of d moves the
# contact along the face by d * tan(78.5 deg) = 4.9 d, so 1.1 cm (a third of the
# ball's radius) already carries it from the middle of the 10.8 cm blade to its
# edge, and the face turns the ball by under ~20 deg - a cricket "edge".
EDGE_COS = 0.2
CONTACTS = ("face", "edge", "back")


def face_normal(global_rotations, bat_joint: int, face_normal_local) -> np.ndarray:
    """World face normal ``(..., 3)`` from global rotations ``(..., J, 4)``."""
    n = np.asarray(face_normal_local, float)
    n = n / np.linalg.norm(n)
    return quat.rotate(np.asarray(global_rotations, float)[..., bat_joint, :], n)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def toward_ball(ball_start, hit_point) -> np.ndarray:
    """Unit direction from the hit point back toward where the ball comes from."""
    return _unit(np.asarray(ball_start, float) - np.asarray(hit_point, float))


def face_to_ball(normal, ball_start, hit_point) -> np.ndarray:
    """Cosine between the face normal ``(..., 3)`` and the direction toward the ball."""
    return np.sum(_unit(normal) * toward_ball(ball_start, hit_point), axis=-1)


def contact(cosine, edge_cos: float = EDGE_COS):
    """``"face"``, ``"edge"`` or ``"back"`` for a face-to-ball cosine (a str for a
    scalar, an array of str otherwise)."""
    c = np.asarray(cosine, float)
    out = np.where(c >= edge_cos, "face", np.where(c <= -edge_cos, "back", "edge"))
    return str(out) if out.ndim == 0 else out


def face_angle_deg(rotations_a, rotations_b, bat_joint: int, face_normal_local) -> np.ndarray:
    """Angle (deg) between the face normals of two sets of global rotations ``(..., J, 4)``."""
    na = face_normal(rotations_a, bat_joint, face_normal_local)
    nb = face_normal(rotations_b, bat_joint, face_normal_local)
    c = np.clip(np.sum(na * nb, axis=-1), -1.0, 1.0)
    return np.degrees(np.arccos(c))


def azimuth_deg(velocity) -> np.ndarray:
    """Ground-plane direction (deg) of ``(..., 3)``: 0 toward +Z, +90 toward -X (off side)."""
    v = np.asarray(velocity, float)
    return np.degrees(np.arctan2(-v[..., 0], v[..., 2]))


def elevation_deg(velocity) -> np.ndarray:
    """Angle (deg) of ``(..., 3)`` above the ground plane."""
    v = np.asarray(velocity, float)
    return np.degrees(np.arctan2(v[..., 1], np.hypot(v[..., 0], v[..., 2])))


def wrap_deg(a) -> np.ndarray:
    """Angles to (-180, 180]."""
    return 180.0 - np.mod(180.0 - np.asarray(a, float), 360.0)
