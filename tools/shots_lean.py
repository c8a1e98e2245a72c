"""The bat's lean for the shot authoring (tools/make_shots.planned), for a grip that asks for it
(tools/grips: ``lean_pass``): the keyed bat turned, per frame, toward a pose both arms can hold
with that grip, chosen by Viterbi over the whole shot.

The bundled shots' bat keys were authored with an upside-down grip; held with the anatomical
grip, no elbow holds a fifth of their frames inside the limits and the shoulder's ranges
(tools/grip_feasibility). Each frame may turn the keyed bat up to MAX_DEG about its face normal
(``lean``: the face, so the ball's direction, kept) and across the blade (``tilt``: the face
turns): a frame's cost is what the turn moves the bat from its key plus both arms' least excess
(as grip_feasibility counts it), the path's what it turns between frames and any blade step
faster than the keyed shot's fastest. At the hit only the lean is free: the face meets the ball
as keyed. The first and last frames are pinned (tools/shots_viterbi), so the shared stance and
rest stay shared.
"""
from __future__ import annotations

import numpy as np

from .shots_maths import gaussian_smooth, rot_axis
from .shots_roll import FREE_ROLLS, FREE_WEIGHT, frames_from, held_frames, speed_charge
from .shots_viterbi import viterbi

STEP_DEG = 15.0         # the states' grid: lean and tilt each -MAX_DEG..MAX_DEG
MAX_DEG = 60.0
KEY_DEG = 20.0          # turned this far from its key costs as much as EXCESS_DEG past a limit
EXCESS_DEG = 5.0        # (grip_feasibility's OVER_DEG: a frame over it needs the bat moved)
TURN_WEIGHT = 50.0      # per rad^2 the bat's turn changes between two frames
CONTACT_FRAMES = 2      # frames either side of the hit where the face is kept (tilt 0)
SMOOTH_FRAMES = 1.5     # the chosen path's 15-degree steps smoothed (Gaussian sigma, frames)
ELBOW_STEP_DEG = 15.0   # the elbow circle's sampling
FOLD_UNIT_CM = 2.0      # a wrist this much nearer its shoulder than ArmSolver.FOLD_CM costs as much
                        # as EXCESS_DEG (without it the lean folded arms 14 -> 25 times)


def states() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lean ``(S,)``, tilt ``(S,)`` degrees, turns ``(S, 3, 3)``: Ry(lean) Rx(tilt) in the bat's frame)."""
    g = np.arange(-MAX_DEG, MAX_DEG + 0.1, STEP_DEG)
    lean, tilt = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    return lean, tilt, rot_axis(1, lean) @ rot_axis(0, tilt)


def arm_costs(solver, T, turns, g_rot, g_pos) -> np.ndarray:
    """``(F, S)``: for the keyed bat turned by each of ``turns``, both arms' least excess
    (``excess``) over their elbow circles, plus their wrists' fold, over the bat's free rolls
    (where ``T["roll_weight"]`` < FREE_WEIGHT; one roll for both arms) and, for the bottom
    hand, its turns on the handle."""
    arms = solver.arms
    F = len(T["grip"])
    psi = np.radians(np.arange(0.0, 360.0, ELBOW_STEP_DEG))[None]
    free = T["roll_weight"] < FREE_WEIGHT
    out = np.full((F, len(turns)), np.inf)
    for s, turn in enumerate(turns):
        for roll in FREE_ROLLS:
            lw, lr, rw, rr = solver.hand_targets(T["grip"], T["bat_rot"] @ turn @ rot_axis(2, np.full(F, roll)))
            total = excess(arms, arms.arm_angles("Left", lw, lr, g_rot, g_pos, 1.0, psi), "Left", g_rot)
            right = bottom_excess(solver, rw, rr, g_rot, g_pos, psi)
            # a lean that brings a wrist nearer its shoulder than FOLD_CM folds the arm shut
            for w, pre in ((lw, "Left"), (rw, "Right")):
                near = arms.FOLD_CM - np.linalg.norm(w - g_pos[:, arms.ix[pre + "Arm"]], axis=-1)
                total = total + (np.maximum(0.0, near) / FOLD_UNIT_CM) ** 2
            out[:, s] = np.minimum(out[:, s], np.where(free | (roll == 0.0), total + right, np.inf))
    return out


def bottom_excess(solver, wrist, hand_rot, g_rot, g_pos, psi) -> np.ndarray:
    """``(F,)``: the bottom arm's least ``excess`` holding the handle with its keyed ``wrist``
    ``(F, 3)`` and ``hand_rot`` ``(F, 3, 3)`` over its elbow places ``psi`` ``(1, K)`` rad and its
    hand's turns on the handle (each charged as tools/shots_grips.BottomHand charges it)."""
    arms, bottom = solver.arms, solver.bottom_hand
    out = np.full(len(wrist), np.inf)
    for t in bottom.TURNS:
        w, r = bottom.turned(wrist, hand_rot, t)
        c = excess(arms, arms.arm_angles("Right", w, r, g_rot, g_pos, -1.0, psi), "Right", g_rot)
        out = np.minimum(out, c + (t / bottom.TURN_DEG) ** 2)
    return out


def excess(arms, ang, pre, g_rot):
    """``(F,)``: the least of ``ArmSolver.all_excess`` over ``angles``' elbow places, squared
    in units of EXCESS_DEG."""
    return (arms.all_excess(ang, pre, g_rot[:, arms.ix["Spine2"]]).min(1) / EXCESS_DEG) ** 2


def choose_lean(solver, T, hit: int) -> tuple[np.ndarray, np.ndarray]:
    """The bat's turn per frame: (``(F, 3, 3)`` to right-multiply ``T["bat_rot"]`` by,
    ``(F, 2)`` its lean and tilt in degrees). Where the face is held as keyed (``T["roll_weight"]``
    past shots_roll.HELD_WEIGHT: the hit, and a defence's bat after it) the tilt is 0, and a run
    of such frames holds one lean: the bat stays where it met the ball."""
    lean, tilt, turns = states()
    _, g_rot, g_pos = solver.body_pose(T)
    F = len(T["grip"])
    held = held_frames(T["roll_weight"])
    held[hit] = True
    cost = (np.hypot(lean, tilt) / KEY_DEG)[None] ** 2
    extra = TURN_WEIGHT * np.arccos(np.clip((np.einsum("aij,bij->ab", turns, turns) - 1.0) / 2.0, -1.0, 1.0)) ** 2
    # the blade never faster than the keyed shot's own peak: the defences stay slow
    extra = extra + speed_charge(T["grip"], T["bat_rot"], solver.bat_from_grip, turns, len(turns) // 2, at_peak=True)
    run = held[:-1] & held[1:]
    extra[run] = np.where(np.eye(len(turns), dtype=bool), extra[run], np.inf)
    cost = cost + arm_costs(solver, T, turns, g_rot, g_pos)
    off = frames_from(held)
    cost[np.ix_(off <= CONTACT_FRAMES, tilt != 0.0)] = np.inf
    path = viterbi(cost, np.zeros(len(turns)), weight=0.0, extra=extra)
    chosen = np.stack([lean[path], tilt[path]], -1)
    smooth = gaussian_smooth(chosen, SMOOTH_FRAMES, 5)
    # the face is kept at the contact: the tilt fades out smoothly about the hit
    smooth[:, 1] *= 1.0 - np.exp(-0.5 * (off / SMOOTH_FRAMES) ** 2)
    inside = np.zeros(F, bool)
    inside[1:] |= run
    inside[:-1] |= run
    smooth[inside] = chosen[inside]
    smooth[[0, -1]] = chosen[[0, -1]]
    return rot_axis(1, smooth[:, 0]) @ rot_axis(0, smooth[:, 1]), smooth
