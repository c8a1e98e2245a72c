"""The hit frame's lean carried to the frames around it (a displacement map, Lee & Shin
1999): the adapter solves every frame alone, so where the hit frame needs the trunk to turn
(the right hand out of reach, the face kept) and its neighbours do not, the body turns at the
hit alone and pops back (over the +-30 cm grid 17 adaptations with the chest popping over
20 deg a frame, docs/history.md). Solving the hit frame first and starting every other frame
from its trunk, turned by that frame's importance blend, leans the body into the hit over the
frames the falloff adapts and keeps each frame's own solve (a frame still depends only on
itself and the hit frame). Those frames' trunks are then held within CARRY_REACH_DEG a joint
of the lean they start from (engine.adapt.trunk_reach's tiers), or each frame's own solve
turns the trunk again on top of the carried lean; a frame that hold does not serve (its bat
needing the wider tiers, its right hand kept off the grip: :func:`served`) is solved alone.
Before that rule: over the +-30 cm grid (126 adaptations,
wrist locked, measured 2026-12-07 against every frame alone) the chest's largest pop a frame
beyond the source's went over 20 deg in 15 -> 9, at most 36.5 -> 43.1 deg, better by over
5 deg in 15, worse in 6 (free after the carry: 9, 59.7, 15 and 10); elbow steps over 20 cm
12 -> 8; the chest's largest turn from the source's, median 12.9 -> 14.4, p90 32.7 -> 38.0 (the lean
spread over the frames, as meant), at most 101 -> 69. Where the hit itself turns the trunk
far (the leg glance 30 cm toward leg and 15 up: 64 deg), its neighbours carried are worse:
docs/history.md, "Pops in the adapted shot: three mends". With :func:`served` and the hold
narrowed from 10 to 5 deg the carry is the default (docs/history.md, "The lean carried by
default")."""
from __future__ import annotations

import numpy as np

from . import quat
from .carry_nb import carry_trunk
from .ccd import limit_euler
from .frames_nb import GRIP_CM, GRIP_RAD

CARRY_REACH_DEG = 5.0  # the carried frames' trunk joints within this of their start on each axis


def hit_run(blend: np.ndarray, frames: np.ndarray, hit: int) -> np.ndarray:
    """``(K,)`` bool: which of ``frames`` lie in the hit's own run of blended frames (``blend
    (F,)`` above 0 from the hit out to the first 0 either side). A frame the blend adapts
    again after a gap (the bat back near the hit point: the square cut's follow-through) is no
    part of the lean into the hit, and is solved alone."""
    zero = np.flatnonzero(np.asarray(blend) <= 0.0)
    lo = zero[zero < hit].max(initial=-1)
    hi = zero[zero > hit].min(initial=len(blend))
    return (frames > lo) & (frames < hi)


def carried_start(start_local: np.ndarray, start_euler: np.ndarray, hit_local: np.ndarray, trunk: np.ndarray,
                  blend: np.ndarray, frames: np.ndarray, hit: int, limits: np.ndarray):
    """The chains' start pose with the hit frame's trunk carried (None: the hit frame left its
    trunk alone, or no frame to carry it to): local rotations ``(F, J, 4)`` and their Euler
    angles ``(F, J, 3)`` rad, equal to ``start_local``/``start_euler`` except
    at ``frames`` in the hit's run (:func:`hit_run`), where the ``trunk`` joints (indices, root-most first) are
    turned by the hit frame's displacement (``hit_local (J, 4)``, the hit's solved local
    rotations, against ``start_local[hit]``) slerped by ``blend (F,)``. ``limits (J, 3, 2)``
    degrees pick the Euler branch (engine.ccd.limit_euler) and bound the free axes; a locked
    axis keeps the start's angle. Blend 0 leaves a frame as it was."""
    rows = frames[hit_run(blend, frames, hit) & (frames != hit)]
    if rows.size == 0 or trunk.size == 0 or np.array_equal(hit_local[trunk], start_local[hit, trunk]):
        return None
    disp = np.ascontiguousarray(quat.mul(hit_local[trunk], quat.conjugate(start_local[hit, trunk])))  # (T, 4)
    lim = np.radians(np.asarray(limits, float))
    local, euler = start_local.copy(), start_euler.copy()
    carry_trunk(start_local, start_euler, disp, np.ascontiguousarray(blend, float), rows.astype(np.int64),
                np.asarray(trunk, np.int64), np.ascontiguousarray(lim[..., 0]), np.ascontiguousarray(lim[..., 1]),
                local, euler)
    return local, euler




def served(solved_local: np.ndarray, start_euler: np.ndarray, grip_cm: np.ndarray, grip_deg: np.ndarray,
           trunk: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """``(K,)`` bool: which frames the carried lean served: solved (local rotations ``(K, J,
    4)`` from Euler angles ``(K, J, 3)`` rad) with every ``trunk`` joint within
    CARRY_REACH_DEG an axis of its start (further, the bat needed engine.adapt.trunk_reach's
    wider tiers) and the right hand on its grip (``grip_cm``, ``grip_deg`` ``(K,)``)."""
    lim = np.asarray(limits, float)[trunk]
    moved = limit_euler(solved_local[:, trunk], lim) - np.degrees(start_euler[:, trunk])
    moved = (moved + 180.0) % 360.0 - 180.0
    held = (np.abs(moved) <= CARRY_REACH_DEG + 1e-3).all(axis=(1, 2))
    # off its grip as the frame's own pipeline judges it (its two-arm solve's trigger): a
    # looser bound (0.5 cm) left the leg glance's hand 0.42 cm off where alone it is on
    return held & (grip_cm <= GRIP_CM) & (grip_deg <= np.degrees(GRIP_RAD))
