"""The bat's roll about its own axis for the shot authoring (tools/shots_ik.PoseSolver): where a
stroke leaves the face free, the roll that lets both arms find comfortable joint angles,
chosen by Viterbi over the whole shot."""
from __future__ import annotations

import numpy as np

from .shots_maths import rot_axis
from .shots_viterbi import continuity_charge, step_charge, viterbi

ROLLS = np.arange(-180.0, 180.0, 7.5)     # the full circle: a follow-through may turn the face over
SPEED_WEIGHT = 300.0    # per cm^2 the roll adds to the Bat joint's keyed step
FLIP_DEG, FLIP_WEIGHT = 40.0, 1e5
# what the planning passes (tools/grip_feasibility, tools/shots_lean) let this one do: where the
# roll weight is below FREE_WEIGHT it turns the bat freely, by about FREE_ROLLS
FREE_ROLLS = np.arange(-60.0, 60.1, 15.0)
FREE_WEIGHT = 1.0
# a roll weight this high (or infinite, the hit) holds the face as keyed: a defence's bat after
# the ball (tools/make_shots), where the planning lean and the top hand's lean hold too
HELD_WEIGHT = 1e6


def held_frames(roll_weight: np.ndarray) -> np.ndarray:
    """``(F,)`` bool: the frames whose face is held as keyed (``roll_weight`` >= HELD_WEIGHT)."""
    return np.asarray(roll_weight) >= HELD_WEIGHT


def frames_from(held: np.ndarray) -> np.ndarray:
    """``(F,)`` int: each frame's distance in frames to the nearest ``held`` one (F where none)."""
    F = len(held)
    return np.abs(np.arange(F)[:, None] - np.flatnonzero(held)[None, :]).min(1, initial=F)


def choose_roll(poses, arms, g_rot, g_pos, T, pref):
    """Bat roll about its axis per frame ``(F,)`` degrees: Viterbi over the arms' best comfort
    cost, charged ``roll_weight * (roll / 20)^2``, 25 per rad^2 of roll from frame to frame, a
    face turning over (``flip_charge``), the blade sped up (``speed_charge``), and what keeping
    each arm's elbow from popping between two rolls costs it (``continuity_charge``: the
    arms' own pass cannot mend a pop whose other side is 50-85 deg past a wrist limit).
    It plans with the keyed grip; the arms' pass may then move the bottom hand
    (shots_grips.BottomHand). ``poses``: the PoseSolver (hand targets, the bat's geometry);
    ``arms``: its ArmSolver."""
    psi = np.radians(np.arange(0, 360, 10.0))
    F = g_pos.shape[0]
    K = len(ROLLS)
    costs = np.zeros((F, K))
    arm_costs = {pre: np.zeros((F, K, len(psi))) for pre in ("Left", "Right")}
    elbows = {pre: np.zeros((F, K, len(psi), 3)) for pre in ("Left", "Right")}
    keyed = poses.hand_targets(T["grip"], T["bat_rot"])
    wrists = {"Left": keyed[0], "Right": keyed[2]}      # at the keyed roll: how fast the hands go
    # the elbows keep out of the trunk, but not at the hit, where the face is keyed
    body = arms.body(g_rot, g_pos, T, trunk_weight=np.isfinite(T["roll_weight"])[:, None])
    for k, r in enumerate(ROLLS):
        lw, lr, rw, rr = poses.hand_targets(T["grip"], T["bat_rot"] @ rot_axis(2, np.full(F, r)))
        for pre, w, hr, s, pr in (("Left", lw, lr, 1.0, pref), ("Right", rw, rr, -1.0, 0 * pref)):
            ang = arms.arm_angles(pre, w, hr, g_rot, g_pos, s, psi[None, :])
            arm_costs[pre][:, k] = arms.cost(ang, pre, s, pr[:, None], body)
            costs[:, k] += arm_costs[pre][:, k].min(1)
            elbows[pre][:, k] = ang["elbow"]
            # an arm folded shut: the roll carried the hand round the handle to its shoulder
            costs[:, k] += arms.fold_charge(w, g_pos[:, arms.ix[pre + "Arm"]])
    w = T["roll_weight"]
    near = ~np.isfinite(w)
    costs += np.where(near, 200.0, w)[:, None] * (ROLLS / 20.0) ** 2
    # a frame of infinite weight (the hit: the face is keyed there) and the shared end
    # frames keep the keyed face exactly
    costs[near] = np.where(ROLLS == 0.0, costs[near], np.inf)
    costs[[0, -1]] = np.where(ROLLS == 0.0, 0.0, np.inf)
    extra = flip_charge(T["bat_rot"], poses.flip_weight) + speed_charge(T["grip"], T["bat_rot"], poses.bat_from_grip)
    for pre in ("Left", "Right"):
        allowed = arms.elbow_step(wrists[pre], g_pos[:, arms.ix[pre + "Arm"]])
        extra = extra + continuity_charge(arm_costs[pre], elbows[pre], allowed, arms.elbow_weight)
    return ROLLS[viterbi(costs, np.radians(ROLLS), weight=25.0, extra=extra)]


def speed_charge(grip, bat_rot, bat_from_grip, turns=None, keyed=None, at_peak=False):
    """Transition charges ``(F-1, K, K)`` for the bat turned by each of ``turns`` ``(K, 3, 3)``
    (in the bat's frame, about its grip; default the rolls, ROLLS): the Bat joint lies off the
    turn's axis, so a turn moves the blade; each cm it moves between two frames beyond the keyed
    turn's (index ``keyed``) step there, or with ``at_peak`` beyond that turn's fastest step in
    the shot, is charged SPEED_WEIGHT per cm^2 (the defences stay slow, the stance still). The
    roll pass, the planning lean (tools/shots_lean) and the top hand's leans (tools/shots_grips)
    all charge the blade so."""
    if turns is None:
        turns, keyed = rot_axis(2, ROLLS), int(np.argmin(np.abs(ROLLS)))
    bat = grip[:, None] + np.einsum("fij,kjl,l->fki", bat_rot, turns, bat_from_grip)  # (F, K, 3)
    steps = np.linalg.norm(np.diff(bat[:, keyed], axis=0), axis=-1)
    return step_charge(bat, np.full_like(steps, steps.max()) if at_peak else steps, SPEED_WEIGHT)


def flip_charge(bat_rot, weight: float = FLIP_WEIGHT):
    """Transition charges ``(F-1, K, K)`` from roll i at frame f to roll j at f+1: the face
    turning faster than FLIP_DEG a frame (1200 deg/s), keyed turn and roll together,
    is a flip the viewer shows; charged ``weight`` per radian^2 beyond it."""
    r = np.radians(ROLLS)
    face = np.einsum("fij,kj->fki", bat_rot, np.stack([-np.sin(r), np.cos(r), 0.0 * r], -1))  # bat Y turned
    turn = np.arccos(np.clip(np.einsum("fid,fjd->fij", face[:-1], face[1:]), -1.0, 1.0))
    return weight * np.maximum(0.0, turn - np.radians(FLIP_DEG)) ** 2
