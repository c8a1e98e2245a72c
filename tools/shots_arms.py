"""The shot authoring's arms (tools/shots_ik.PoseSolver): a two-bone arm whose elbow may sit
anywhere on its circle of solutions, chosen by Viterbi over the whole shot for joint angles
comfortably inside the rig's limits, elbows clear of the trunk, shoulders within their
ranges, and an elbow that does not swing round its arm between two frames."""
from __future__ import annotations

import numpy as np

from .grips import grip_of
from .shots_check import (TRUNK_CM, TRUNK_JOINTS, distance_to_polyline, axial_excess, horizontal_excess,
                          humerothoracic, outside)
from .shots_maths import euler, perp, rel, rot_axis, unit
from .shots_viterbi import step_charge, viterbi


class ArmSolver:
    """Joint angles of the rig's arms from wrist positions and hand rotations (``solve``), and
    what the bat roll's planning (tools/shots_roll) asks of them: ``angles``, ``cost``,
    ``body``, ``fold_charge``, ``elbow_step``."""

    def __init__(self, rig):
        self.rig = rig
        # a grip may charge the elbow's pops more (tools/grips: ``elbow_weight``)
        self.elbow_weight = grip_of(rig).get("elbow_weight", self.ELBOW_WEIGHT)
        self.contact_frames = grip_of(rig).get("shoulder_contact_frames", self.CONTACT_FRAMES)
        self.ix = {n: i for i, n in enumerate(rig.skeleton.names)}
        self.off = rig.skeleton.offsets

    def bone(self, name: str) -> float:
        return float(np.linalg.norm(self.off[self.ix[name]]))

    def lengths(self, pre: str) -> tuple[float, float]:
        """The arm's two bones (cm): shoulder to elbow, elbow to wrist (the roll joints between)."""
        return (self.bone(pre + "ArmRoll") + self.bone(pre + "ForeArm"),
                self.bone(pre + "ForeArmRoll") + self.bone(pre + "Hand"))

    FOLD_CM = 27.0          # make_shots.unfold's d_min: an elbow past ~135 degrees
    FOLD_WEIGHT = 8.0       # per cm^2 nearer

    def fold_charge(self, wrist, shoulder):
        """``(F,)``: FOLD_WEIGHT per cm^2 a wrist ``(F, 3)`` lies nearer its shoulder than FOLD_CM."""
        return self.FOLD_WEIGHT * np.maximum(0.0, self.FOLD_CM - np.linalg.norm(wrist - shoulder, axis=-1)) ** 2

    def solve(self, L, g_rot, g_pos, pre, wrists, hand_rots, s, pref, body, turn_cost=None):
        """Two-bone arm: Arm(z,y)+ArmRoll(x) swing/twist, ForeArm pure y, ForeArmRoll x, Hand (z,y).

        The elbow may sit anywhere on its circle of solutions; a Viterbi pass
        over 72 elbow angles per frame, and over the hand's candidate poses (``wrists``,
        ``hand_rots``: G of ``(F, 3)`` and ``(F, 3, 3)``; ``turn_cost``: their costs ``(F, G)``
        and the charges ``(G, G)`` or per frame ``(F - 1, G, G)`` between them, for G > 1),
        picks the path whose joint angles stay comfortably inside the limits (wrist near its
        preferred deviation, small twists) and that moves smoothly from frame to frame. Returns
        (reach ``(F,)``: wrist distance over arm length, the hand pose chosen ``(F,)``).
        """
        ix = self.ix
        names = ("Arm", "ArmRoll", "ForeArm", "ForeArmRoll", "Hand")
        arm, roll, fore, froll, hand = (ix[pre + n] for n in names)
        S = g_pos[:, arm]
        l1, l2 = self.lengths(pre)
        parent = g_rot[:, ix[pre + "Shoulder"]]
        psi = np.radians(np.arange(0, 360, 5.0))
        K, G, F = len(psi), len(wrists), len(S)
        angs = [self.angles(S, w, r, parent, l1, l2, s, psi[None, :]) for w, r in zip(wrists, hand_rots)]
        # a hand pose that brings the wrist nearer its shoulder than FOLD_CM folds the arm shut
        cost = np.concatenate([self.cost(a, pre, s, pref[:, None], body) + self.fold_charge(w, S)[:, None]
                               for a, w in zip(angs, wrists)], 1)                         # (F, G*K)
        pose = np.repeat(np.arange(G), K)
        # the elbow may move as far as the first pose's wrist (the keyed one) moves
        elbows, allowed = np.concatenate([a["elbow"] for a in angs], 1), self.elbow_step(wrists[0], S)
        between = 0.0
        if turn_cost is not None:
            cost = cost + turn_cost[0][:, pose]
            between = turn_cost[1][pose][:, pose] if np.ndim(turn_cost[1]) == 2 else turn_cost[1]

        def extra(f):       # frame by frame: (F-1, G*K, G*K) at once is gigabytes for the bottom hand
            b = between[f][pose][:, pose] if np.ndim(between) == 3 else between
            return step_charge(elbows[f:f + 2], allowed[f:f + 1], self.elbow_weight)[0] + b
        choice = viterbi(cost, np.tile(psi, G), weight=15.0, extra=extra)
        chosen = pose[choice]
        wrist = np.stack(wrists)[chosen, np.arange(F)]
        best = self.angles(S, wrist, np.stack(hand_rots)[chosen, np.arange(F)], parent, l1, l2, s,
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

    def elbow_step(self, wrist, shoulder):
        """How far ``(F-1,)`` cm an elbow may move between two frames: as far as its wrist or
        its shoulder, plus ELBOW_SLACK_CM; further, it swings round the shoulder-wrist line,
        a pop through the body the viewer shows (up to 45 cm in one frame before it was charged)."""
        return np.maximum(np.linalg.norm(np.diff(wrist, axis=0), axis=-1),
                          np.linalg.norm(np.diff(shoulder, axis=0), axis=-1)) + self.ELBOW_SLACK_CM

    def arm_angles(self, pre, wrist, hand_rot, g_rot, g_pos, side, psi):
        """``angles`` of arm ``pre`` from the pose's global rotations and positions
        ``(F, J, 3, 3)``, ``(F, J, 3)``: its shoulder, its clavicle's rotation and its bones."""
        l1, l2 = self.lengths(pre)
        return self.angles(g_pos[:, self.ix[pre + "Arm"]], wrist, hand_rot, g_rot[:, self.ix[pre + "Shoulder"]],
                           l1, l2, side, psi)

    def angles(self, S, W, hand_rot, parent, l1, l2, s, psi):
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

    def body(self, g_rot, g_pos, T, trunk_weight) -> dict:
        """What the elbows keep clear of, per frame: the spine's polyline ``(F, 5, 3)``, hips to
        neck, and the chest's rotation ``(F, 3, 3)`` (the shoulder's horizontal range and the
        humerus's axial rotation), charged ``trunk_weight`` ((F, 1) or scalar). The shoulder's
        ranges are not charged round the hit:
        the face is keyed there, and the adaptation's face-keeping solve starts from those arms
        (moved, it loses the face at grid corners: tests/engine/test_face.py)."""
        F = g_pos.shape[0]
        hit = ~np.isfinite(T["roll_weight"]) if "roll_weight" in T else np.zeros(F, bool)
        k = self.contact_frames
        contact = np.convolve(hit.astype(float), np.ones(2 * k + 1), "same") > 0
        return {"spine": g_pos[:, [self.ix[n] for n in self.TRUNK]], "chest": g_rot[:, self.ix["Spine2"]],
                "trunk_weight": trunk_weight, "shoulder_weight": np.where(contact[:, None], 0.0, trunk_weight)}

    SHOULDER_DEG = 15.0     # past the horizontal range by this much costs as much as 1 deg past a joint limit
    # turned past AAOS's humeral rotation by this much, the same: at 20 (before the roll's pass
    # charged continuous elbows) 99 arm-frames lay 30 deg or more past; at 14, 77, and the elbow
    # pops fell too (93 -> 81); at 10, 55, but 44 pops over 20 cm and 29 folded arms
    AXIAL_DEG = 14.0

    def excess(self, ang, pre):
        """Degrees past the rig's limits, summed over the arm's joints, of ``angles``' answers
        ``(..., K)`` (the twist shared evenly by Arm and ArmRoll, as ``solve`` sets it)."""
        lim = self.rig.limits
        ix = self.ix
        e, h = ang["upper"], ang["hand"]
        over = lambda v, j, c: outside(v, lim[j, c, 0], lim[j, c, 1])
        return (over(e[..., 0], ix[pre + "Arm"], 0) + over(e[..., 1], ix[pre + "Arm"], 1)
                + over(e[..., 2] / 2, ix[pre + "Arm"], 2) + over(h[..., 0], ix[pre + "ForeArmRoll"], 2)
                + over(h[..., 1], ix[pre + "Hand"], 0) + over(h[..., 2], ix[pre + "Hand"], 1))

    def shoulder_excess(self, ang, pre, chest):
        """Degrees ``(..., K)`` past the shoulder's horizontal range and past the humerus's axial
        range (tools/shots_check) of ``angles``' answers, the chest's rotation ``chest (F, 3, 3)``."""
        plane, elevation, axial = humerothoracic(chest[:, None], ang["upper_rot"], pre)
        return horizontal_excess(elevation, plane), axial_excess(elevation, axial)

    def all_excess(self, ang, pre, chest):
        """``(..., K)`` degrees: ``excess`` plus both of ``shoulder_excess``'s, what
        tools/grip_feasibility and tools/shots_lean count."""
        across, turned = self.shoulder_excess(ang, pre, chest)
        return self.excess(ang, pre) + across + turned

    def cost(self, ang, pre, s, pref, body=None):
        e, h = ang["upper"], ang["hand"]
        viol = self.excess(ang, pre)
        comfort = 0.0
        if body is not None:
            # an elbow closer to the spine than TRUNK_CM touches the chest or belly; an upper
            # arm past the horizontal range at shoulder height lies through the neck or the back
            near = np.maximum(0.0, TRUNK_CM - distance_to_polyline(ang["elbow"], body["spine"][:, None]))
            viol = viol + body["trunk_weight"] * near
            across, turned = self.shoulder_excess(ang, pre, body["chest"])
            comfort = 50.0 * body["shoulder_weight"] * ((across / self.SHOULDER_DEG) ** 2 + (turned / self.AXIAL_DEG) ** 2)
        # elbows hang: prefer the elbow below the shoulder-wrist line
        return ((h[..., 1] / 35.0) ** 2 + ((s * h[..., 2] + pref) / 20.0) ** 2
                + (h[..., 0] / 60.0) ** 2 + (e[..., 2] / 80.0) ** 2 + 50.0 * viol ** 2 + comfort)
