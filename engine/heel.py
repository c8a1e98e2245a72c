"""A planted foot the hips leave behind: the heel lifts, the ball of the foot stays.

Where a synthesised take carries the hip further from a planted ankle than the leg
reaches (an exaggerated drive's lunge, a golfer's lead leg straightening through the
ball), the foot pivots about the ball of the foot (the first toe joint), heel up, by the
least angle that brings the ankle back within reach; the toes turn back so they stay flat.
Before, the foot was let go there and slid (the CMU golf swing's lead foot, 7.3 cm along
the ground at the default exaggeration). Where no lift up to ``HEEL_MAX`` brings the
ankle back within reach, the foot leaves the plant (:func:`engine.cleanup.foot_plant`).
"""
from __future__ import annotations

import numpy as np

from . import quat
from .ccd import limit_euler

HEEL_MAX = 60.0     # deg: a batsman's back foot up on its toes; further, the foot lets go

UP = np.array([0.0, 1.0, 0.0])


def ball_joint(rig, skeleton, side: str) -> int | None:
    """The joint at the ball of ``side``'s foot: the first of ``rig.feet[side]`` whose parent
    is the ankle (the leg chain's effector); None if the rig has no toe joint."""
    ankle = rig.chains[f"{side}_leg"].effector
    return next((int(j) for j in rig.feet.get(side, []) if skeleton.parents[j] == ankle), None)


def lift_heels(t_pos: np.ndarray, t_rot: np.ndarray, ball_offset: np.ndarray, hip_pos: np.ndarray,
               reach_cm: float, frames: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ankle targets ``t_pos (F,3)`` cm and foot rotations ``t_rot (F,4)``, with the ball of the
    foot at ``t_pos + ball_offset (F,3)``: where the hip ``hip_pos (F,3)`` is further than
    ``reach_cm`` from the ankle's target, the foot turned heel up about the ball (about the
    horizontal axis across the foot) by the least angle, at most HEEL_MAX, that brings the
    ankle within ``reach_cm`` (the closest the lift gets, if none does).
    Returns ``(t_pos, t_rot, heel_deg (F,), reached (F,) bool)``, new arrays; the lift is 0
    within reach; ``reached`` is False where no lift up to HEEL_MAX brings the ankle within
    ``reach_cm``. ``frames (F,)`` bool: the frames to lift (all by default)."""
    t_pos, t_rot = np.array(t_pos, float), np.array(t_rot, float)
    heel = np.zeros(len(t_pos))
    reached = np.ones(len(t_pos), bool)
    far = np.linalg.norm(t_pos - hip_pos, axis=-1) > reach_cm
    far = np.flatnonzero(far if frames is None else far & frames)
    if far.size == 0:
        return t_pos, t_rot, heel, reached
    ball = t_pos[far] + ball_offset[far]
    across = np.cross(UP, ball_offset[far] * [1.0, 0.0, 1.0])      # turning +about it raises the heel
    norm = np.linalg.norm(across, axis=-1, keepdims=True)
    axis = across / np.maximum(norm, 1e-9)
    theta = least_lift(axis, -ball_offset[far], ball - hip_pos[far], reach_cm, np.radians(HEEL_MAX))
    theta = np.where(norm[:, 0] > 1e-6, theta, 0.0)                # a foot pointing straight down: left
    turns = quat.from_axis_angle(axis, theta)
    t_pos[far] = ball + quat.rotate(turns, -ball_offset[far])
    t_rot[far] = quat.normalize(quat.mul(turns, t_rot[far]))
    heel[far] = np.degrees(theta)
    reached[far] = np.linalg.norm(t_pos[far] - hip_pos[far], axis=-1) <= reach_cm + 1e-9
    return t_pos, t_rot, heel, reached


def least_lift(axis: np.ndarray, to_ankle: np.ndarray, from_hip: np.ndarray, reach_cm: float,
               most: float) -> np.ndarray:
    """(n,) the least turn (radians, in [0, ``most``]) about the unit ``axis (n,3)`` through the
    ball of the foot that brings the ankle (``to_ankle (n,3)`` from the ball) within
    ``reach_cm`` of the hip (``from_hip (n,3)``: hip -> ball); where none does, the turn in
    [0, ``most``] that brings it closest. Closed form: turned by t the squared distance is
    ``e + b cos t + c sin t`` (Rodrigues)."""
    along = np.sum(axis * to_ankle, -1)
    b = 2.0 * (np.sum(from_hip * to_ankle, -1) - along * np.sum(axis * from_hip, -1))
    c = 2.0 * np.sum(from_hip * np.cross(axis, to_ankle), -1)
    e = np.sum(from_hip ** 2, -1) + np.sum(to_ankle ** 2, -1) + 2.0 * along * np.sum(axis * from_hip, -1)
    m, phase = np.hypot(b, c), np.arctan2(c, b)         # b cos t + c sin t = m cos(t - phase)
    ratio = (reach_cm ** 2 - e) / np.maximum(m, 1e-12)
    # the first t >= 0 where m cos(t - phase) comes down to reach^2 - e
    first = np.mod(phase + np.arccos(np.clip(ratio, -1.0, 1.0)), 2 * np.pi)
    closest = np.mod(phase + np.pi, 2 * np.pi)         # where m cos(t - phase) is least
    # not within [0, most]: whichever end is closer (the distance has one minimum a turn)
    at_most = m * np.cos(most - phase) < b
    fallback = np.where(closest <= most, closest, np.where(at_most, most, 0.0))
    return np.where((np.abs(ratio) <= 1.0) & (first <= most), first, fallback)


def flatten_toes(rig, skeleton, local_rotations: np.ndarray, g_rot: np.ndarray, ball: int,
                 flat_rot: np.ndarray, weight: np.ndarray) -> None:
    """The toes of a lifted heel turned back flat, in place: the ``ball`` joint's local
    rotations in ``local_rotations (F,J,4)`` made to give, with the foot as solved (``g_rot
    (F,J,4)``), the toes' global rotation they had with the foot at ``flat_rot (F,4)`` (its
    rotation before the lift), by ``weight (F,)`` (0 leaves a frame alone), within the
    joint's DOFs and limits."""
    sel = np.flatnonzero(weight > 0)
    if sel.size == 0:
        return
    current = local_rotations[sel, ball]
    flat_toes = quat.mul(flat_rot[sel], current)                  # the toes' rotation, foot unlifted
    wanted = quat.mul(quat.inverse(g_rot[sel, skeleton.parents[ball]]), flat_toes)
    turned = quat.slerp(current, wanted, weight[sel])
    lim = rig.limits[ball]
    euler = limit_euler(turned[:, None], lim[None])[:, 0]          # (n, 3) z, y, x degrees
    had = limit_euler(current[:, None], lim[None])[:, 0]
    # locked axes have limits [0, 0]; a toe the take already put outside its limits may stay there
    euler = np.clip(euler, np.minimum(lim[:, 0], had), np.maximum(lim[:, 1], had))
    local_rotations[sel, ball] = quat.from_euler(euler, "ZYX")
