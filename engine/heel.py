"""A planted foot the hips leave behind: the heel lifts, the ball of the foot stays.

Where a synthesised take carries the hip further from a planted ankle than the leg
reaches (an exaggerated drive's lunge, a golfer's lead leg straightening through the
ball), the foot pivots about the ball of the foot (the first toe joint), heel up, by the
least angle that brings the ankle back within reach; the toes turn back so they stay flat.
Before, the foot was let go there and slid (the CMU golf swing's lead foot, 7.3 cm along
the ground at the default exaggeration). Past ``HEEL_MAX`` the plant keeps the largest
lift and the clean-up's hips follow the foot (:func:`engine.cleanup.feet_on_plants`).
"""
from __future__ import annotations

import numpy as np

from . import quat
from .ccd import limit_euler

HEEL_MAX = 60.0     # deg: a batsman's back foot up on its toes; further, the hips follow
HEEL_STEP = 0.25    # deg: the lift is searched on this grid

UP = np.array([0.0, 1.0, 0.0])


def ball_joint(rig, skeleton, side: str) -> int | None:
    """The joint at the ball of ``side``'s foot: the first of ``rig.feet[side]`` whose parent
    is the ankle (the leg chain's effector); None if the rig has no toe joint."""
    ankle = rig.chains[f"{side}_leg"].effector
    return next((int(j) for j in rig.feet.get(side, []) if skeleton.parents[j] == ankle), None)


def lift_heels(t_pos: np.ndarray, t_rot: np.ndarray, ball_offset: np.ndarray, hip_pos: np.ndarray,
               reach_cm: float, lift_to_cm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ankle targets ``t_pos (F,3)`` cm and foot rotations ``t_rot (F,4)``, with the ball of the
    foot at ``t_pos + ball_offset (F,3)``: where the hip ``hip_pos (F,3)`` is further than
    ``reach_cm`` from the ankle's target, the foot turned heel up about the ball (about the
    horizontal axis across the foot) by the least angle, at most HEEL_MAX, that brings the
    ankle within ``lift_to_cm`` (<= ``reach_cm``; the closest the lift gets, if none does).
    Returns ``(t_pos, t_rot, heel_deg (F,), reached (F,) bool)``, new arrays; the lift is 0
    within reach; ``reached`` is False where no lift up to HEEL_MAX brings the ankle within
    ``reach_cm``."""
    t_pos, t_rot = np.array(t_pos, float), np.array(t_rot, float)
    heel = np.zeros(len(t_pos))
    reached = np.ones(len(t_pos), bool)
    far = np.flatnonzero(np.linalg.norm(t_pos - hip_pos, axis=-1) > reach_cm)
    if far.size == 0:
        return t_pos, t_rot, heel, reached
    to_ankle = -ball_offset[far]                                   # (n, 3) ball -> ankle
    across = np.cross(UP, ball_offset[far] * [1.0, 0.0, 1.0])      # turning +about it raises the heel
    ok_axis = np.linalg.norm(across, axis=-1) > 1e-6               # a foot pointing straight down: left
    angles = np.radians(np.arange(0.0, HEEL_MAX + HEEL_STEP / 2, HEEL_STEP))        # (K,)
    turns = quat.from_axis_angle(across[:, None, :], np.broadcast_to(angles, (len(far), len(angles))))
    ball = t_pos[far] + ball_offset[far]
    ankles = ball[:, None] + quat.rotate(turns, np.broadcast_to(to_ankle[:, None], turns.shape[:-1] + (3,)))
    dist = np.linalg.norm(ankles - hip_pos[far, None], axis=-1)                   # (n, K)
    within = dist <= lift_to_cm
    k = np.where(within.any(1), within.argmax(1), dist.argmin(1))
    k = np.where(ok_axis, k, 0)
    rows = np.arange(len(far))
    t_pos[far] = ankles[rows, k]
    t_rot[far] = quat.normalize(quat.mul(turns[rows, k], t_rot[far]))
    heel[far] = np.degrees(angles[k])
    reached[far] = dist[rows, k] <= reach_cm
    return t_pos, t_rot, heel, reached


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
