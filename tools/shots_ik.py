"""Pose solving for the shot authoring script: world targets -> rig local rotations.

All functions work on whole clips at once (leading frame axis F); rotations are
3x3 matrices ``(F, 3, 3)`` (columns = the joint's local axes in world) until the
end, where they become (w, x, y, z) quaternions. Every joint's local rotation
is *built from its allowed Euler DOFs* (e.g. the elbow is a pure Ry, the hand a
pure Rz Ry), so the stored BVH holds exactly the pose that FK reproduces.
"""
from __future__ import annotations

import numpy as np

from engine import quat
from engine.skeleton import forward_kinematics

from .grips import grip_of, right_in_bat
from .shots_arms import ArmSolver
from .shots_check import clamp_into_limits
from .shots_grips import BottomHand, TopHand
from .shots_maths import (frame_from_yz, gaussian_smooth, look_rotation, perp, rel, rot_axis, split_rotation, to_q,
                          two_bone, unit, ypr)
from .shots_lean import EXCESS_DEG, bottom_excess
from .shots_roll import FLIP_WEIGHT, choose_roll


# ----------------------------------------------------------------- the grip
# The bat's frame: X across the blade, Y the face normal, Z from the toe up the handle. The
# keys give the bat's pose in the world (shots_keys.bat_frame); the rig's ``bat`` says how the
# top hand holds it (``axis``, ``face_normal`` in LeftHand's frame), and nothing else here
# assumes a grip.


def grip_frame(rig) -> np.ndarray:
    """The bat's frame in LeftHand's ``(3, 3)``: columns X = Y x Z, Y = ``face_normal``,
    Z = -``axis`` (the rig's ``bat``; the two must be perpendicular unit vectors)."""
    n = np.asarray(rig.bat["face_normal"], float)
    z = -np.asarray(rig.bat["axis"], float)
    if abs(np.linalg.norm(n) - 1.0) > 1e-6 or abs(np.linalg.norm(z) - 1.0) > 1e-6 or abs(n @ z) > 1e-6:
        raise ValueError("rig bat: axis and face_normal must be perpendicular unit vectors")
    return np.stack([np.cross(n, z), n, z], -1)


def bat_from_grip(rig) -> np.ndarray:
    """The Bat joint from the left grip ``(3,)`` cm, in the bat's frame."""
    return grip_frame(rig).T @ (rig.skeleton.offsets[rig.bat_joint] - np.asarray(rig.bat["left_grip"], float))


# ----------------------------------------------------------------- the solver
class PoseSolver:
    """Turns world-space targets into local rotations for ``rig.skeleton``: the trunk, head and
    legs here; the bat's roll (tools/shots_roll), the arms (tools/shots_arms.ArmSolver) and the
    bottom hand's grip (tools/shots_grips.BottomHand) in their own modules."""

    def __init__(self, rig):
        self.rig = rig
        sk = rig.skeleton
        self.sk = sk
        self.ix = {n: i for i, n in enumerate(sk.names)}
        self.off = sk.offsets
        bat = rig.bat
        self.left_grip = np.array(bat["left_grip"], float)
        self.left_in_bat = grip_frame(rig).T             # LeftHand's rotation in the bat's frame
        self.bat_from_grip = bat_from_grip(rig)
        self.right_below = float(bat["right_grip_below_left"])
        # right palm centre in RightHand's frame: the mirror of the left grip
        self.right_grip = self.left_grip * np.array([-1.0, 1.0, 1.0])
        # how the bottom hand holds the handle: the rig's grip (tools/grips)
        self.right_in_bat = right_in_bat(grip_of(rig))
        self.arms = ArmSolver(rig)
        self.bottom_hand = BottomHand(self.right_in_bat, self.right_grip)
        leans = grip_of(rig).get("top_leans")
        self.top_hand = TopHand(leans, self.hand_targets, self.bat_from_grip) if leans else None
        # how hard the roll pass charges a face turned faster than wrists turn a bat (shots_roll)
        self.flip_weight = grip_of(rig).get("flip_weight", FLIP_WEIGHT)

    # ---- helpers
    def bone(self, name: str) -> float:
        return float(np.linalg.norm(self.off[self.ix[name]]))

    def fk(self, root_pos: np.ndarray, local_m: np.ndarray):
        """Global rotation matrices and positions from local matrices ``(F, J, 3, 3)``."""
        F = root_pos.shape[0]
        t = np.broadcast_to(self.off, (F,) + self.off.shape).copy()
        t[:, 0] = root_pos
        g_rot, g_pos = forward_kinematics(self.sk.parents, t, to_q(local_m))
        return quat.to_matrix(g_rot), g_pos

    def hand_targets(self, grip: np.ndarray, bat_rot: np.ndarray):
        """Wrist positions and hand rotations of both hands from the bat pose.

        ``grip``: left grip point (F,3); ``bat_rot``: the bat's world frame (F,3,3).
        """
        l_rot = bat_rot @ self.left_in_bat
        l_wrist = grip - l_rot @ self.left_grip
        r_rot = bat_rot @ self.right_in_bat
        r_grip = grip - bat_rot[..., 2] * self.right_below        # down the handle
        r_wrist = r_grip - r_rot @ self.right_grip
        return l_wrist, l_rot, r_wrist, r_rot

    # ---- solve
    def solve(self, T: dict) -> tuple[np.ndarray, np.ndarray, dict]:
        """World targets ``T`` -> (root_positions (F,3), local_rotations (F,J,4), info).

        Keys of ``T`` (all per frame): hips_pos, hips_rot, chest_rot, head_rot,
        {l,r}_ankle, {l,r}_foot_rot, {l,r}_toe_bend (deg), {l,r}_knee_dir,
        grip, bat_rot (the bat's frame), wrist_pref (deg, radial deviation preferred), clavicle_gain.
        """
        L, g_rot, g_pos = self.body_pose(T)
        l_wrist, l_rot, r_wrist, r_rot = self.hand_targets(T["grip"], T["bat_rot"])
        info = {}
        pref = T["wrist_pref"]
        if "roll_weight" in T:
            # turn the bat about its own axis where the stroke leaves the face
            # free, so both arms find comfortable joint angles
            roll = choose_roll(self, self.arms, g_rot, g_pos, T, pref)
            info["roll"] = roll
            T = dict(T, bat_rot=T["bat_rot"] @ rot_axis(2, roll))
            l_wrist, l_rot, r_wrist, r_rot = self.hand_targets(T["grip"], T["bat_rot"])
        body = self.arms.body(g_rot, g_pos, T, trunk_weight=4.0)
        if self.top_hand is None:
            info["Left_reach"] = self.arms.solve(L, g_rot, g_pos, "Left", [l_wrist], [l_rot], 1.0, pref, body)[0]
        else:
            wrists, rots, costs, charges, leans = self._top_hand_candidates(T, g_rot, g_pos)
            info["Left_reach"], chosen = self.arms.solve(L, g_rot, g_pos, "Left", wrists, rots, 1.0, pref,
                                                         body, (costs, charges))
            info["top_lean"] = leans[chosen]
        # the bat is the top hand's: where its arm is clamped into the limits the bat moves with
        # it, and the bottom hand holds the handle there (not where the keys had it)
        grip, bat_rot, info["top_arm_clamped_deg"] = self._clamped_top_arm(L, T["hips_pos"])
        info["bat_rot"] = bat_rot       # as the top hand holds it: rolled, leant, clamped
        _, _, r_wrist, r_rot = self.hand_targets(grip, bat_rot)
        wrists, rots, costs, charges, turns, slides = self.bottom_hand.grips(r_wrist, r_rot)
        info["Right_reach"], grip = self.arms.solve(L, g_rot, g_pos, "Right", wrists, rots, -1.0, 0 * pref,
                                                    body, (costs, charges))
        info["right_grip_turn"], info["right_grip_slide"] = turns[grip], slides[grip]
        return T["hips_pos"], quat.make_continuous(to_q(L)), info

    def _top_hand_candidates(self, T, g_rot, g_pos):
        """TopHand.grips for the keyed bat, each lean also charged for what it asks of the bottom
        arm: its least excess (tools/shots_lean.bottom_excess, its turns on the handle allowed)
        past TopHand.BOTTOM_DEG, per (5 deg)^2 (without it the cover drive's follow-through
        leant -30 deg where the bottom wrist then clamped 73 deg)."""
        top = self.top_hand
        wrists, rots, costs, charges, leans = top.grips(T["grip"], T["bat_rot"], top.held(T["roll_weight"]))
        psi = np.radians(np.arange(0.0, 360.0, 15.0))[None]
        F = len(costs)
        for g, a in enumerate(leans):
            _, _, rw, rr = self.hand_targets(T["grip"], T["bat_rot"] @ rot_axis(1, np.full(F, a)))
            deg = EXCESS_DEG * np.sqrt(bottom_excess(self, rw, rr, g_rot, g_pos, psi))
            costs[:, g] += (np.maximum(0.0, deg - top.BOTTOM_DEG) / EXCESS_DEG) ** 2
        return wrists, rots, costs, charges, leans

    def body_pose(self, T: dict):
        """Everything but the arms, from the targets ``T`` (``solve``'s): local rotations
        ``(F, J, 3, 3)`` of the trunk, head, legs and clavicles (the arms at rest), and their
        global rotations and positions."""
        ix = self.ix
        F = T["hips_pos"].shape[0]
        J = self.sk.num_joints
        L = np.broadcast_to(np.eye(3), (F, J, 3, 3)).copy()
        L[:, 0] = T["hips_rot"]
        spine = split_rotation(rel(T["hips_rot"], T["chest_rot"]), 3)
        for n in ("Spine", "Spine1", "Spine2"):
            L[:, ix[n]] = spine
        head_rot = T.get("head_rot")
        if head_rot is None:
            # eyes level and on the ball: look from roughly the eyes at T["look"]
            _, g0 = self.fk(T["hips_pos"], L)
            eye = g0[:, ix["Neck"]] + T["chest_rot"] @ np.array([0.0, 18.0, 9.0])
            head_rot = look_rotation(eye, T["look"])
            if "head_tilt" in T:
                head_rot = head_rot @ rot_axis(2, T["head_tilt"])
        neck = split_rotation(rel(T["chest_rot"], head_rot), 2)
        L[:, ix["Neck"]] = neck
        L[:, ix["Head"]] = neck
        g_rot, g_pos = self.fk(T["hips_pos"], L)
        # legs
        for side, pre in (("l", "Left"), ("r", "Right")):
            self._leg(L, g_rot, g_pos, T, side, pre)
        # clavicles lean a little toward their hand, then the arms
        l_wrist, l_rot, r_wrist, r_rot = self.hand_targets(T["grip"], T["bat_rot"])
        gain = T.get("clavicle_gain", np.full(F, 0.5))
        for pre, wrist, s in (("Left", l_wrist, 1.0), ("Right", r_wrist, -1.0)):
            self._clavicle(L, g_rot, g_pos, pre, wrist, s, gain)
        g_rot, g_pos = self.fk(T["hips_pos"], L)
        return L, g_rot, g_pos

    def _clamped_top_arm(self, L, root_pos):
        """Clamp the top (left) arm's joints in ``L`` into the rig's limits, in place, and return
        where it then holds the bat: (left grip point ``(F, 3)``, the bat's frame ``(F, 3, 3)``,
        the largest clamp in degrees)."""
        arm = [self.ix["Left" + n] for n in ("Arm", "ArmRoll", "ForeArm", "ForeArmRoll", "Hand")]
        q, largest = clamp_into_limits(self.rig, to_q(L), arm)
        L[:, arm] = quat.to_matrix(q[:, arm])
        g_rot, g_pos = self.fk(root_pos, L)
        hand = g_rot[:, self.ix["LeftHand"]]
        return g_pos[:, self.ix["LeftHand"]] + hand @ self.left_grip, hand @ self.left_in_bat.T, largest

    def _leg(self, L, g_rot, g_pos, T, side, pre):
        ix = self.ix
        up, leg, foot, toe = (ix[pre + n] for n in ("UpLeg", "Leg", "Foot", "ToeBase"))
        hip = g_pos[:, up]
        ankle = T[side + "_ankle"]
        l1, l2 = self.bone(pre + "Leg"), self.bone(pre + "Foot")
        knee, ankle_r, _ = two_bone(hip, ankle, l1, l2, hip + T[side + "_knee_dir"] * 100.0)
        down = unit(knee - hip)                    # thigh direction = -Y of UpLeg
        fwd = perp(unit(T[side + "_knee_dir"]), down)
        shin = unit(ankle_r - knee)
        fwd = np.where(np.linalg.norm(perp(shin, down), axis=-1, keepdims=True) > 1e-6,
                       -perp(shin, down), fwd)     # knee points away from the shin's bend
        thigh = frame_from_yz(-down, fwd)
        L[:, up] = rel(g_rot[:, 0], thigh)
        flex = np.degrees(np.arccos(np.clip(np.sum(down * shin, -1), -1, 1)))
        L[:, leg] = rot_axis(0, flex)
        shin_rot = thigh @ L[:, leg]
        L[:, foot] = rel(shin_rot, T[side + "_foot_rot"])
        L[:, toe] = rot_axis(0, T[side + "_toe_bend"])

    def _clavicle(self, L, g_rot, g_pos, pre, wrist, s, gain):
        ix = self.ix
        c = ix[pre + "Shoulder"]
        chest = g_rot[:, ix["Spine2"]]
        v = np.einsum("fji,fj->fi", chest, wrist - g_pos[:, c])   # in the chest frame
        elev = np.degrees(np.arctan2(v[:, 1], np.hypot(v[:, 0], v[:, 2])))
        prot = np.degrees(np.arctan2(v[:, 2], s * v[:, 0]))
        lim = self.rig.limits[c]
        z = np.clip(s * gain * (elev + 20.0), *lim[0])      # arms hang ~20 deg below level
        y = np.clip(-s * gain * 0.5 * prot, *lim[1])
        L[:, c] = rot_axis(2, z) @ rot_axis(1, y)


def shoulder_positions(solver: PoseSolver, hips_pos, hips_rot, chest_rot) -> np.ndarray:
    """Left and right Arm joint positions ``(..., 2, 3)`` for a torso pose
    (clavicles at rest), with the spine bent evenly as ``solve`` does it."""
    off = solver.off
    ix = solver.ix
    step = split_rotation(rel(hips_rot, chest_rot), 3)
    p = hips_pos + hips_rot @ off[ix["Spine"]]
    r = hips_rot
    for n in ("Spine1", "Spine2"):
        r = r @ step
        p = p + r @ off[ix[n]]
    out = []
    for pre in ("Left", "Right"):
        base = p + chest_rot @ off[ix[pre + "Shoulder"]]
        out.append(base + chest_rot @ off[ix[pre + "Arm"]])
    return np.stack(out, -2)


def fit_torso(solver: PoseSolver, T: dict, chest_ypr: np.ndarray, env: np.ndarray,
              lo: float = 0.52, hi: float = 0.9) -> np.ndarray:
    """Small per-frame chest yaw/pitch/roll offsets ``(F, 3)`` that keep both
    arms' shoulder-to-wrist distance inside [lo, hi] of full reach (elbows
    neither locked straight nor folded tight), found by grid search,
    then smoothed over time and faded out by ``env`` (F,)."""
    l_wrist, _, r_wrist, _ = solver.hand_targets(T["grip"], T["bat_rot"])
    full = (solver.bone("LeftArmRoll") + solver.bone("LeftForeArm")
            + solver.bone("LeftForeArmRoll") + solver.bone("LeftHand"))
    g = np.arange(-30.0, 30.1, 5.0)
    dy, dp, dr = (a.ravel() for a in np.meshgrid(g, g, g, indexing="ij"))
    F = chest_ypr.shape[0]
    best = np.zeros((F, 3))
    for f in range(F):
        c = ypr(chest_ypr[f, 0] + dy, chest_ypr[f, 1] + dp, chest_ypr[f, 2] + dr)
        sh = shoulder_positions(solver, T["hips_pos"][f], T["hips_rot"][f], c)
        cost = (dy / 15.0) ** 2 + (dp / 15.0) ** 2 + (dr / 15.0) ** 2
        for k, w in ((0, l_wrist[f]), (1, r_wrist[f])):
            r = np.linalg.norm(w - sh[:, k], axis=-1) / full
            cost = cost + (np.maximum(0, r - hi) / 0.02) ** 2 + (np.maximum(0, lo - r) / 0.02) ** 2
        best[f] = (dy[np.argmin(cost)], dp[np.argmin(cost)], dr[np.argmin(cost)])
    smooth = gaussian_smooth(best, 2.0, 6)
    return smooth * env[:, None]
