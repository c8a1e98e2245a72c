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

from .shots_check import (TRUNK_CM, TRUNK_JOINTS, axial_excess, clamp_into_limits, distance_to_polyline,
                          horizontal_excess, humerothoracic, outside)


# ----------------------------------------------------------------- small maths
def unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors ``(..., 3)``."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def perp(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Component of ``v`` perpendicular to the unit ``axis`` (both ``(..., 3)``)."""
    return v - np.sum(v * axis, axis=-1, keepdims=True) * axis


def rot_axis(axis: int, deg: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` about a principal axis (0 x, 1 y, 2 z)."""
    return quat.to_matrix(quat._axis_quat(axis, np.asarray(deg, float)))


def frame_from_yz(y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Orthonormal frame with Y exactly along ``y`` and Z as close to ``z`` as possible."""
    Y = unit(y)
    Z = unit(perp(z, Y))
    X = np.cross(Y, Z)
    return np.stack([X, Y, Z], axis=-1)


def ypr(yaw, pitch, roll) -> np.ndarray:
    """World orientation of a body part from yaw (about world Y; 0 faces +Z),
    pitch (forward bend about the part's own X) and roll (about its own Z):
    R = Ry(yaw) Rx(pitch) Rz(roll), ``(F, 3, 3)``."""
    return rot_axis(1, yaw) @ rot_axis(0, pitch) @ rot_axis(2, roll)


def to_q(m: np.ndarray) -> np.ndarray:
    return quat.normalize(quat.from_matrix(m))


def euler(m: np.ndarray, order: str) -> np.ndarray:
    """Euler degrees of rotation matrices in ``order`` (R = R_o0 R_o1 R_o2)."""
    return quat.to_euler(to_q(m), order)


def rel(parent: np.ndarray, child: np.ndarray) -> np.ndarray:
    """Local rotation of ``child`` under ``parent`` (both global, ``(F, 3, 3)``)."""
    return np.swapaxes(parent, -1, -2) @ child


def split_rotation(m: np.ndarray, parts: int) -> np.ndarray:
    """The rotation whose ``parts``-th power is ``m`` (same axis, angle / parts)."""
    return quat.to_matrix(quat.exp(quat.log(to_q(m)) / parts))


# ----------------------------------------------------------------- two-bone IK
def two_bone(root: np.ndarray, target: np.ndarray, l1: float, l2: float,
             hint: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Middle-joint position for a two-bone chain ``(F, 3)``.

    The middle joint lies on the circle of solutions on the side of ``hint``.
    Returns (middle, reached_target, bend_dir) where ``bend_dir`` is the unit
    direction from the root-target line toward the middle joint.
    Out-of-reach targets are pulled in to 99.9 % of full extension.
    """
    d = target - root
    D = np.linalg.norm(d, axis=-1, keepdims=True)
    u = d / np.maximum(D, 1e-9)
    Dc = np.clip(D, abs(l1 - l2) + 1e-3, (l1 + l2) * 0.999)
    reached = root + u * Dc
    k = unit(perp(hint - root, u))
    a = (l1 * l1 - l2 * l2 + Dc * Dc) / (2 * Dc)
    h = np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))
    return root + a * u + h * k, reached, k


# ----------------------------------------------------------------- the grip
# The bat's frame: X across the blade, Y the face normal, Z from the toe up the handle. The
# keys give the bat's pose in the world (shots_keys.bat_frame); the rig's ``bat`` says how the
# top hand holds it (``axis``, ``face_normal`` in LeftHand's frame), and nothing else here
# assumes a grip.
RIGHT_GRIP_EXT = -40.0     # deg, see PoseSolver.__init__
RIGHT_GRIP_DEV = 60.0


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
    """Turns world-space targets into local rotations for ``rig.skeleton``."""

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
        # the right hand holds the handle palm-forward: its frame is the bat's
        # turned 180 degrees about the handle, then tilted so that the handle
        # lies diagonally across the palm and fingers as in a real grip (wrist
        # extended ~40, deviated ~60 toward the toe from square): the bottom
        # forearm points more along the face normal than the top one
        self.right_in_bat = rot_axis(2, 180.0) @ rot_axis(1, -RIGHT_GRIP_DEV) @ rot_axis(2, -RIGHT_GRIP_EXT)

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
        info = {}
        # legs
        for side, pre in (("l", "Left"), ("r", "Right")):
            self._leg(L, g_rot, g_pos, T, side, pre)
        # clavicles lean a little toward their hand, then the arms
        l_wrist, l_rot, r_wrist, r_rot = self.hand_targets(T["grip"], T["bat_rot"])
        gain = T.get("clavicle_gain", np.full(F, 0.5))
        for pre, wrist, s in (("Left", l_wrist, 1.0), ("Right", r_wrist, -1.0)):
            self._clavicle(L, g_rot, g_pos, pre, wrist, s, gain)
        g_rot, g_pos = self.fk(T["hips_pos"], L)
        pref = T["wrist_pref"]
        if "roll_weight" in T:
            # turn the bat about its own axis where the stroke leaves the face
            # free, so both arms find comfortable joint angles
            roll = self._choose_roll(g_rot, g_pos, T, pref)
            info["roll"] = roll
            T = dict(T, bat_rot=T["bat_rot"] @ rot_axis(2, roll))
            l_wrist, l_rot, r_wrist, r_rot = self.hand_targets(T["grip"], T["bat_rot"])
        info["bat_rot"] = T["bat_rot"]
        body = self._body(g_rot, g_pos, T, trunk_weight=4.0)
        info["Left_reach"] = self._arm(L, g_rot, g_pos, "Left", [l_wrist], [l_rot], 1.0, pref, body)[0]
        # the bat is the top hand's: where its arm is clamped into the limits the bat moves with
        # it, and the bottom hand holds the handle there (not where the keys had it)
        grip, bat_rot, info["top_arm_clamped_deg"] = self._clamped_top_arm(L, T["hips_pos"])
        _, _, r_wrist, r_rot = self.hand_targets(grip, bat_rot)
        wrists, rots, costs, charges, turns, slides = self._right_grips(r_wrist, r_rot)
        info["Right_reach"], grip = self._arm(L, g_rot, g_pos, "Right", wrists, rots, -1.0, 0 * pref, body,
                                              (costs, charges))
        info["right_grip_turn"], info["right_grip_slide"] = turns[grip], slides[grip]
        return T["hips_pos"], quat.make_continuous(to_q(L)), info

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

    # The bottom hand holds the handle loosely (the coaches' thumb-and-forefinger bottom hand):
    # it may turn about the handle, and slide down it, which the top hand may not (the bat is
    # the top hand's). Where the keyed bat turns the hands faster than the bottom arm's limits
    # follow, the turn lets its elbow stay on its side instead of swinging round the arm; where
    # the hands' keyed spacing would fold the bottom arm or swing its elbow round, the slide
    # gives it room (library: elbow pops over 20 cm 15 -> 10, arms folded 14 -> 7).
    GRIP_TURNS = np.array([0.0, -15.0, 15.0, -30.0, 30.0])   # deg about the handle; the keyed grip first
    GRIP_TURN_DEG = 15.0    # a turn this far costs as much as the wrist 20 deg off its preference
    GRIP_STEP_WEIGHT = 5.0  # per (7.5 deg or GRIP_SLIDE_STEP_CM)^2 the grip changes between frames
    GRIP_STEP_DEG = 30.0    # and no faster than this a frame (900 deg/s): faster, the glove spins
    # cm down the handle from the keyed grip (11 cm below the top hand's): at 7.5 the glove's
    # edge is still 2 cm short of the blade (the handle is 30 cm)
    GRIP_SLIDES = np.array([0.0, 2.5, 5.0, 7.5])
    GRIP_SLIDE_CM = 1.0     # a slide of s cm costs (s / GRIP_SLIDE_CM)^2 a frame: only where it buys that
    GRIP_SLIDE_STEP_CM = 2.5    # and no faster than this a frame (75 cm/s)
    GRIP_HELD_FRAMES = 3    # the first and last frames hold the shared stance's and rest's grip

    def _turned_right_hand(self, wrist, hand_rot, turn: float):
        """The right wrist ``(F, 3)`` and hand rotation ``(F, 3, 3)`` turned ``turn`` degrees
        about the handle (the bat's Z) from ``wrist``, ``hand_rot``: the palm stays on it."""
        bat_rot = hand_rot @ self.right_in_bat.T
        turned = bat_rot @ rot_axis(2, turn) @ self.right_in_bat
        return wrist + (hand_rot - turned) @ self.right_grip, turned

    def _right_grips(self, wrist, hand_rot):
        """The bottom hand's candidate grips on the handle for ``_arm``, from its keyed ``wrist``
        ``(F, 3)`` and ``hand_rot`` ``(F, 3, 3)``: every GRIP_TURNS x GRIP_SLIDES. Returns (G
        wrists ``(F, 3)``, G hand rotations ``(F, 3, 3)``, costs ``(F, G)``, charges between
        them ``(G, G)``, turns ``(G,)`` deg, slides ``(G,)`` cm); the keyed grip first."""
        F = len(wrist)
        turns = np.tile(self.GRIP_TURNS, len(self.GRIP_SLIDES))
        slides = np.repeat(self.GRIP_SLIDES, len(self.GRIP_TURNS))
        down = -(hand_rot @ self.right_in_bat.T)[..., 2]          # the bat's Z points up the handle
        grips = [self._turned_right_hand(wrist, hand_rot, t) for t in self.GRIP_TURNS]
        wrists = [grips[g % len(grips)][0] + s * down for g, s in enumerate(slides)]
        rots = [grips[g % len(grips)][1] for g in range(len(slides))]
        costs = np.tile((turns / self.GRIP_TURN_DEG) ** 2 + (slides / self.GRIP_SLIDE_CM) ** 2, (F, 1))
        held = np.zeros(F, bool)
        held[:self.GRIP_HELD_FRAMES] = held[-self.GRIP_HELD_FRAMES:] = True
        costs[np.ix_(held, slides != 0.0)] = np.inf
        turn_step = np.abs(turns[:, None] - turns[None, :])
        slide_step = np.abs(slides[:, None] - slides[None, :])
        charges = (self.GRIP_STEP_WEIGHT * ((turn_step / 7.5) ** 2 + (slide_step / self.GRIP_SLIDE_STEP_CM) ** 2)
                   + 1e4 * (np.maximum(0.0, turn_step - self.GRIP_STEP_DEG) ** 2
                            + np.maximum(0.0, slide_step - self.GRIP_SLIDE_STEP_CM) ** 2))
        return wrists, rots, costs, charges, turns, slides

    ROLLS = np.arange(-180.0, 180.0, 7.5)     # the full circle: a follow-through may turn the face over

    def _choose_roll(self, g_rot, g_pos, T, pref):
        """Bat roll about its axis per frame ``(F,)`` degrees: Viterbi over the
        arms' best comfort cost, charged ``roll_weight * (roll / 20)^2``, 25 per rad^2
        of roll from frame to frame, a face turning over (``_flip_charge``), and what keeping
        each arm's elbow from popping between two rolls costs it (``continuity_charge``: the
        arms' own pass cannot mend a pop whose other side is 50-85 deg past a wrist limit).
        It plans with the keyed grip; the arms' pass may then turn the bottom hand (GRIP_TURNS)."""
        psi = np.radians(np.arange(0, 360, 10.0))
        F = g_pos.shape[0]
        K = len(self.ROLLS)
        costs = np.zeros((F, K))
        arm_costs = {pre: np.zeros((F, K, len(psi))) for pre in ("Left", "Right")}
        elbows = {pre: np.zeros((F, K, len(psi), 3)) for pre in ("Left", "Right")}
        keyed = self.hand_targets(T["grip"], T["bat_rot"])
        wrists = {"Left": keyed[0], "Right": keyed[2]}      # at the keyed roll: how fast the hands go
        # the elbows keep out of the trunk, but not at the hit, where the face is keyed
        body = self._body(g_rot, g_pos, T, trunk_weight=np.isfinite(T["roll_weight"])[:, None])
        for k, r in enumerate(self.ROLLS):
            lw, lr, rw, rr = self.hand_targets(T["grip"], T["bat_rot"] @ rot_axis(2, np.full(F, r)))
            for pre, w, hr, s, pr in (("Left", lw, lr, 1.0, pref), ("Right", rw, rr, -1.0, 0 * pref)):
                l1 = self.bone(pre + "ArmRoll") + self.bone(pre + "ForeArm")
                l2 = self.bone(pre + "ForeArmRoll") + self.bone(pre + "Hand")
                ang = self._arm_angles(g_pos[:, self.ix[pre + "Arm"]], w, hr,
                                       g_rot[:, self.ix[pre + "Shoulder"]], l1, l2, s, psi[None, :])
                arm_costs[pre][:, k] = self._arm_cost(ang, pre, s, pr[:, None], body)
                costs[:, k] += arm_costs[pre][:, k].min(1)
                elbows[pre][:, k] = ang["elbow"]
                # an arm folded shut: the roll carried the hand round the handle to its shoulder
                costs[:, k] += self._fold_charge(w, g_pos[:, self.ix[pre + "Arm"]])
        w = T["roll_weight"]
        near = ~np.isfinite(w)
        costs += np.where(near, 200.0, w)[:, None] * (self.ROLLS / 20.0) ** 2
        # a frame of infinite weight (the hit: the face is keyed there) and the shared end
        # frames keep the keyed face exactly
        costs[near] = np.where(self.ROLLS == 0.0, costs[near], np.inf)
        costs[[0, -1]] = np.where(self.ROLLS == 0.0, 0.0, np.inf)
        extra = self._flip_charge(T["bat_rot"]) + self._speed_charge(T["grip"], T["bat_rot"])
        for pre in ("Left", "Right"):
            allowed = self._elbow_step(wrists[pre], g_pos[:, self.ix[pre + "Arm"]])
            extra = extra + continuity_charge(arm_costs[pre], elbows[pre], allowed, self.ELBOW_WEIGHT)
        return self.ROLLS[viterbi(costs, np.radians(self.ROLLS), weight=25.0, extra=extra)]

    FOLD_CM = 27.0          # make_shots.unfold's d_min: an elbow past ~135 degrees
    FOLD_WEIGHT = 8.0       # per cm^2 nearer

    def _fold_charge(self, wrist, shoulder):
        """``(F,)``: FOLD_WEIGHT per cm^2 a wrist ``(F, 3)`` lies nearer its shoulder than FOLD_CM."""
        return self.FOLD_WEIGHT * np.maximum(0.0, self.FOLD_CM - np.linalg.norm(wrist - shoulder, axis=-1)) ** 2
    SPEED_WEIGHT = 300.0    # per cm^2 the roll adds to the Bat joint's keyed step

    def _speed_charge(self, grip, bat_rot):
        """Transition charges ``(F-1, K, K)``: the Bat joint lies off the bat's axis, so a roll
        moves the blade; each cm it moves beyond its keyed step between two frames is charged
        (the defences stay slow, the stance still)."""
        turns = rot_axis(2, self.ROLLS)                                                   # (K, 3, 3)
        bat = grip[:, None] + np.einsum("fij,kjl,l->fki", bat_rot, turns, self.bat_from_grip)  # (F, K, 3)
        keyed = np.linalg.norm(np.diff(bat[:, np.argmin(np.abs(self.ROLLS))], axis=0), axis=-1)
        return step_charge(bat, keyed, self.SPEED_WEIGHT)

    FLIP_DEG, FLIP_WEIGHT = 40.0, 1e5

    def _flip_charge(self, bat_rot):
        """Transition charges ``(F-1, K, K)`` from roll i at frame f to roll j at f+1: the face
        turning faster than FLIP_DEG a frame (1200 deg/s), keyed turn and roll together,
        is a flip the viewer shows; charged FLIP_WEIGHT per radian^2 beyond it."""
        r = np.radians(self.ROLLS)
        face = np.einsum("fij,kj->fki", bat_rot, np.stack([-np.sin(r), np.cos(r), 0.0 * r], -1))  # bat Y turned
        turn = np.arccos(np.clip(np.einsum("fid,fjd->fij", face[:-1], face[1:]), -1.0, 1.0))
        return self.FLIP_WEIGHT * np.maximum(0.0, turn - np.radians(self.FLIP_DEG)) ** 2

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

    def _arm(self, L, g_rot, g_pos, pre, wrists, hand_rots, s, pref, body, turn_cost=None):
        """Two-bone arm: Arm(z,y)+ArmRoll(x) swing/twist, ForeArm pure y, ForeArmRoll x, Hand (z,y).

        The elbow may sit anywhere on its circle of solutions; a Viterbi pass
        over 72 elbow angles per frame, and over the hand's candidate poses (``wrists``,
        ``hand_rots``: G of ``(F, 3)`` and ``(F, 3, 3)``; ``turn_cost``: their costs ``(F, G)``
        and the charges ``(G, G)`` between them, for G > 1), picks the path whose joint angles
        stay comfortably inside the limits (wrist near its preferred deviation, small twists)
        and that moves smoothly from frame to frame. Returns (reach ``(F,)``: wrist distance
        over arm length, the hand pose chosen ``(F,)``).
        """
        ix = self.ix
        names = ("Arm", "ArmRoll", "ForeArm", "ForeArmRoll", "Hand")
        arm, roll, fore, froll, hand = (ix[pre + n] for n in names)
        S = g_pos[:, arm]
        l1 = self.bone(pre + "ArmRoll") + self.bone(pre + "ForeArm")
        l2 = self.bone(pre + "ForeArmRoll") + self.bone(pre + "Hand")
        parent = g_rot[:, ix[pre + "Shoulder"]]
        psi = np.radians(np.arange(0, 360, 5.0))
        K, G, F = len(psi), len(wrists), len(S)
        angs = [self._arm_angles(S, w, r, parent, l1, l2, s, psi[None, :]) for w, r in zip(wrists, hand_rots)]
        # a hand pose that brings the wrist nearer its shoulder than FOLD_CM folds the arm shut
        cost = np.concatenate([self._arm_cost(a, pre, s, pref[:, None], body) + self._fold_charge(w, S)[:, None]
                               for a, w in zip(angs, wrists)], 1)                         # (F, G*K)
        pose = np.repeat(np.arange(G), K)
        # the elbow may move as far as the first pose's wrist (the keyed one) moves
        elbows, allowed = np.concatenate([a["elbow"] for a in angs], 1), self._elbow_step(wrists[0], S)
        between = 0.0
        if turn_cost is not None:
            cost = cost + turn_cost[0][:, pose]
            between = turn_cost[1][pose][:, pose]

        def extra(f):       # frame by frame: (F-1, G*K, G*K) at once is gigabytes for the bottom hand
            return step_charge(elbows[f:f + 2], allowed[f:f + 1], self.ELBOW_WEIGHT)[0] + between
        choice = viterbi(cost, np.tile(psi, G), weight=15.0, extra=extra)
        chosen = pose[choice]
        wrist = np.stack(wrists)[chosen, np.arange(F)]
        best = self._arm_angles(S, wrist, np.stack(hand_rots)[chosen, np.arange(F)], parent, l1, l2, s,
                                psi[choice % K][:, None])
        e, flex, h = (best[k][:, 0] for k in ("upper", "flex", "hand"))
        L[:, arm] = rot_axis(2, e[:, 0]) @ rot_axis(1, e[:, 1]) @ rot_axis(0, e[:, 2] / 2)
        L[:, roll] = rot_axis(0, e[:, 2] / 2)
        L[:, fore] = rot_axis(1, -s * flex)
        L[:, froll] = rot_axis(0, h[:, 0])
        L[:, hand] = rot_axis(2, h[:, 1]) @ rot_axis(1, h[:, 2])
        return np.linalg.norm(wrist - S, axis=-1) / (l1 + l2), chosen

    ELBOW_SLACK_CM = 3.0    # an elbow may outpace its wrist and shoulder by this much a frame
    ELBOW_WEIGHT = 3.0      # per cm^2 beyond: at 10 the drives clamp 7-10 deg into the limits instead

    def _elbow_step(self, wrist, shoulder):
        """How far ``(F-1,)`` cm an elbow may move between two frames: as far as its wrist or
        its shoulder, plus ELBOW_SLACK_CM; further, it swings round the shoulder-wrist line,
        a pop through the body the viewer shows (up to 45 cm in one frame before it was charged)."""
        return np.maximum(np.linalg.norm(np.diff(wrist, axis=0), axis=-1),
                          np.linalg.norm(np.diff(shoulder, axis=0), axis=-1)) + self.ELBOW_SLACK_CM

    def _arm_angles(self, S, W, hand_rot, parent, l1, l2, s, psi):
        """Joint angles for elbow circle angles ``psi (F or 1, K)``: dict of (F, K, ...) arrays."""
        d = W - S
        D = np.linalg.norm(d, axis=-1, keepdims=True)
        u = d / np.maximum(D, 1e-9)
        D = np.clip(D, abs(l1 - l2) + 1e-3, (l1 + l2) * 0.999)
        Wr = S + u * D
        a = (l1 * l1 - l2 * l2 + D * D) / (2 * D)
        h = np.sqrt(np.maximum(l1 * l1 - a * a, 1e-6))
        ref = np.where(np.abs(u[:, 1:2]) < 0.9, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
        e1 = unit(perp(ref, u))
        e2 = np.cross(u, e1)
        c, sn = np.cos(psi)[..., None], np.sin(psi)[..., None]
        k = c * e1[:, None] + sn * e2[:, None]                     # (F, K, 3)
        E = (S + a * u)[:, None] + h[:, None] * k
        up_dir = unit(E - S[:, None])
        fdir = unit(Wr[:, None] - E)
        Z = unit(perp(fdir, up_dir))
        X = s * up_dir
        Y = np.cross(Z, X)
        upper = np.stack([X, Y, np.cross(X, Y)], -1)                # (F, K, 3, 3)
        e = euler(rel(parent[:, None], upper), "ZYX")
        flex = np.degrees(np.arccos(np.clip(np.sum(up_dir * fdir, -1), -1, 1)))
        forearm = upper @ rot_axis(1, -s * flex)
        hh = euler(rel(forearm, hand_rot[:, None]), "XZY")          # Rx(twist) Rz(a) Ry(b)
        return {"upper": e, "flex": flex, "hand": hh, "elbow": E, "upper_rot": upper}

    TRUNK = TRUNK_JOINTS

    CONTACT_FRAMES = 4      # frames either side of the hit where the upper arms are not moved for the shoulder

    def _body(self, g_rot, g_pos, T, trunk_weight) -> dict:
        """What the elbows keep clear of, per frame: the spine's polyline ``(F, 5, 3)``, hips to
        neck, and the chest's rotation ``(F, 3, 3)`` (the shoulder's horizontal range and the
        humerus's axial rotation), charged ``trunk_weight`` ((F, 1) or scalar). The shoulder's
        ranges are not charged round the hit:
        the face is keyed there, and the adaptation's face-keeping solve starts from those arms
        (moved, it loses the face at grid corners: tests/engine/test_face.py)."""
        F = g_pos.shape[0]
        hit = ~np.isfinite(T["roll_weight"]) if "roll_weight" in T else np.zeros(F, bool)
        k = self.CONTACT_FRAMES
        contact = np.convolve(hit.astype(float), np.ones(2 * k + 1), "same") > 0
        return {"spine": g_pos[:, [self.ix[n] for n in self.TRUNK]], "chest": g_rot[:, self.ix["Spine2"]],
                "trunk_weight": trunk_weight, "shoulder_weight": np.where(contact[:, None], 0.0, trunk_weight)}

    SHOULDER_DEG = 15.0     # past the horizontal range by this much costs as much as 1 deg past a joint limit
    # turned past AAOS's humeral rotation by this much, the same: at 20 (before the roll's pass
    # charged continuous elbows) 99 arm-frames lay 30 deg or more past; at 14, 77, and the elbow
    # pops fell too (93 -> 81); at 10, 55, but 44 pops over 20 cm and 29 folded arms
    AXIAL_DEG = 14.0

    def _arm_cost(self, ang, pre, s, pref, body=None):
        lim = self.rig.limits
        ix = self.ix
        e, h = ang["upper"], ang["hand"]
        over = lambda v, j, c: outside(v, lim[j, c, 0], lim[j, c, 1])
        viol = (over(e[..., 0], ix[pre + "Arm"], 0) + over(e[..., 1], ix[pre + "Arm"], 1)
                + over(e[..., 2] / 2, ix[pre + "Arm"], 2) + over(h[..., 0], ix[pre + "ForeArmRoll"], 2)
                + over(h[..., 1], ix[pre + "Hand"], 0) + over(h[..., 2], ix[pre + "Hand"], 1))
        comfort = 0.0
        if body is not None:
            # an elbow closer to the spine than TRUNK_CM touches the chest or belly; an upper
            # arm past the horizontal range at shoulder height lies through the neck or the back
            near = np.maximum(0.0, TRUNK_CM - distance_to_polyline(ang["elbow"], body["spine"][:, None]))
            viol = viol + body["trunk_weight"] * near
            plane, elevation, axial = humerothoracic(body["chest"][:, None], ang["upper_rot"], pre)
            across, turned = horizontal_excess(elevation, plane), axial_excess(elevation, axial)
            comfort = 50.0 * body["shoulder_weight"] * ((across / self.SHOULDER_DEG) ** 2 + (turned / self.AXIAL_DEG) ** 2)
        # elbows hang: prefer the elbow below the shoulder-wrist line
        return ((h[..., 1] / 35.0) ** 2 + ((s * h[..., 2] + pref) / 20.0) ** 2
                + (h[..., 0] / 60.0) ** 2 + (e[..., 2] / 80.0) ** 2 + 50.0 * viol ** 2 + comfort)


def step_charge(points: np.ndarray, allowed: np.ndarray, weight: float) -> np.ndarray:
    """Viterbi transition charges ``(F-1, K, K)`` for candidate points ``(F, K, 3)``: ``weight``
    per cm^2 that going from candidate i at frame f to j at f + 1 moves further than
    ``allowed (F-1,)`` cm."""
    moved = np.linalg.norm(points[1:, None, :] - points[:-1, :, None], axis=-1)          # (F-1, from, to)
    return weight * np.maximum(0.0, moved - allowed[:, None, None]) ** 2


def continuity_charge(cost: np.ndarray, points: np.ndarray, allowed: np.ndarray, weight: float) -> np.ndarray:
    """Transition charges ``(F-1, K, K)`` between states whose sub-choices (``cost (F, K, P)``,
    candidate points ``(F, K, P, 3)``) are made per frame: what moving from state i at frame f
    to j at f + 1 with its sub-choices continuous (``weight`` per cm^2 a point moves further
    than ``allowed (F-1,)``) costs beyond taking each frame's best sub-choice."""
    F, K, P = cost.shape
    out = np.zeros((F - 1, K, K))
    best = cost.min(2)
    flat, pts = cost.reshape(F, K * P), points.reshape(F, K * P, 3)
    sq = np.einsum("fnd,fnd->fn", pts, pts)
    for f in range(F - 1):
        # |a - b|^2 by one matrix product: (K*P)^2 pairs a frame
        d2 = sq[f][:, None] + sq[f + 1][None, :] - 2.0 * pts[f] @ pts[f + 1].T
        tot = 0.5 * flat[f][:, None] + 0.5 * flat[f + 1][None, :] \
            + weight * np.maximum(0.0, np.sqrt(np.maximum(d2, 0.0)) - allowed[f]) ** 2
        out[f] = tot.reshape(K, P, K, P).min(axis=(1, 3)) - 0.5 * best[f][:, None] - 0.5 * best[f + 1][None, :]
    return out


def viterbi(cost: np.ndarray, psi: np.ndarray, weight: float, extra=None) -> np.ndarray:
    """Cheapest path of indices ``(F,)`` through ``cost (F, K)`` with a
    ``weight * (circular angle step in radians)^2`` charge between frames, plus
    ``extra[f, i, j]`` ``(F-1, K, K)`` (or ``extra(f)``, ``(K, K)``) from index i at
    frame f to j at f + 1."""
    F, K = cost.shape
    # the first and last frames are shared by every shot: pin them to their
    # own best choice so the path cannot make them differ between shots
    cost = cost.copy()
    for f in (0, F - 1):
        keep = np.argmin(cost[f])
        cost[f] = np.inf
        cost[f, keep] = 0.0
    step = np.abs(np.angle(np.exp(1j * (psi[:, None] - psi[None, :]))))
    trans = weight * step ** 2
    acc = cost[0].copy()
    back = np.zeros((F, K), int)
    for f in range(1, F):
        step_extra = 0.0 if extra is None else extra(f - 1) if callable(extra) else extra[f - 1]
        tot = acc[:, None] + trans + step_extra                                  # from i to j
        back[f] = np.argmin(tot, axis=0)
        acc = tot[back[f], np.arange(K)] + cost[f]
    path = np.zeros(F, int)
    path[-1] = int(np.argmin(acc))
    for f in range(F - 1, 0, -1):
        path[f - 1] = back[f, path[f]]
    return path


def look_rotation(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """A level head (no roll) whose +Z looks from ``eye`` at ``target``, ``(F, 3, 3)``."""
    z = unit(target - eye)
    x = unit(np.cross(np.array([0.0, 1.0, 0.0]), z))
    return np.stack([x, np.cross(z, x), z], -1)


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
    k = np.exp(-0.5 * (np.arange(-6, 7) / 2.0) ** 2)
    k /= k.sum()
    pad = np.pad(best, ((6, 6), (0, 0)), mode="edge")
    smooth = np.stack([np.convolve(pad[:, i], k, "valid") for i in range(3)], -1)
    return smooth * env[:, None]
