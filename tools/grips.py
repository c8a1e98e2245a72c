"""How the batsman's hands hold the bat, for the rig (tools/make_rig) and the shot authoring
(tools/shots_ik): a grip is data, named here, so a library can be built with either.

Hand frames are the rig's (the T-pose, palm down): X along the fingers (+X on the left hand,
-X on the right), Y out of the back of the hand, Z toward the thumb. The bat's frame is the
authoring's (tools/shots_ik.grip_frame): X across the blade, Y the face normal, Z from the toe
up the handle.

- ``library``: the grip the shots were first authored with. Both hands hold the bat upside
  down (an ice-pick grip: the top hand's toe beyond the little finger, the bottom hand's thumb
  up the handle), so the bat's hang asks the wrists for 55-75 deg of deviation (AAOS: radial
  20, ulnar 30); the rig's Hand y is widened for it.
- ``anatomical``: the toe beyond thumb and forefinger in both hands, 20 deg from the fingers
  (a diagonal grip would be 40-70: the library's bat keys hold the bat nearer the forearms'
  line than that lets the wrists follow); the face on the palms' side, as a bat picked up face
  down is held (the top hand's 165 deg round the handle from the back of the hand, the bottom
  hand's 90 from the palm: where tools/grip_feasibility found the keys held best). Hand y at
  AAOS. Its re-keys of the shared stance and rest and of some shots' bat keys are data here
  (``regrip``, ``reshape``); its build leans the bat frame by frame toward where the arms hold
  it (``lean_pass``: tools/shots_lean), charges the elbows' pops more (``elbow_weight``), and
  its top arm's pass leans the bat again with the elbow's place (``top_leans``:
  tools/shots_grips.TopHand), charges the shoulder's ranges at the hit too and a flipping face
  harder; and its bat keys away from the swing are re-fitted to where those passes held the bat
  (``bat_keys``: tools/refit_keys); a defence's or a glance's bat is held where it met the ball
  (``dead_bat_s``). The bundled rig and shots are its build.

A grip's optional keys: ``stance``, ``rest`` and ``shots`` (re-keys), ``lean_pass`` (bool),
``elbow_weight`` (tools/shots_arms.ArmSolver.ELBOW_WEIGHT), ``top_leans`` (degrees about the face
normal the top arm's pass may lean the bat: tools/shots_grips.TopHand),
``shoulder_contact_frames`` (ArmSolver.CONTACT_FRAMES), ``flip_weight`` (tools/shots_roll.FLIP_WEIGHT),
``bat_keys`` (a JSON file beside this module: the bat keys re-fitted for the grip, tools/refit_keys).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .shots_maths import rot_axis, turn, unit

GRIPS = {
    "library": {"top_toe_deg": -90.0, "top_face_deg": 0.0, "right": "library", "hand_y": [-75, 55]},
    "anatomical": {"top_toe_deg": 20.0, "top_face_deg": -165.0,
                   "right": {"toe_deg": 20.0, "face_deg": -90.0}, "hand_y": [-20, 30],
                   # the shared stance and rest re-keyed for it (tools/shots_defs), where the
                   # arms' comfort (tools/shots_arms.ArmSolver.cost, the shoulder's ranges
                   # included) is least at the keyed roll, so the authoring's roll pass leaves the
                   # bat still in them, and both wrists within make_shots.shared_reach: in the
                   # stance the bat is grounded 8 cm further back and 6 cm toward the off side,
                   # its face open 45 deg toward point; at rest it hangs 10 deg toward the
                   # batsman, its face open 30 deg. The top wrist prefers no deviation (the
                   # library's 50 and 30 deg radial, past AAOS's 20).
                   "stance": {"toe": [-9.0, 1.5, 98.0], "bat_d": [-0.0497, -0.9938, -0.0994],
                              "bat_n": [-0.882, -0.003, 0.4712], "wrist_pref": 0.0},
                   "rest": {"bat_d": [0.0255, -0.9948, -0.0984], "bat_n": [-0.7268, -0.0861, 0.6814],
                            "wrist_pref": 0.0},
                   # the shots' bat keys turned where no elbow held them (tools/grip_feasibility;
                   # a greedy search, 20 or 40 deg a step: reshape); -0.11..0.11 s is the swing
                   # through the ball, leant 20 deg about the face normal in five shots
                   # the bat leant toward where the arms hold it (tools/shots_lean), and the
                   # elbows' pops charged more (tools/shots_arms.ArmSolver.ELBOW_WEIGHT)
                   "lean_pass": True, "elbow_weight": 10.0,
                   # and the top arm's pass leans it again, with the elbow's place (tools/shots_grips.TopHand)
                   "top_leans": [-40.0, -30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0, 40.0],
                   # its arms charged for the shoulder's ranges at the hit too (the library's are not:
                   # the adaptation's face-keeping solve starts from those arms), and its roll pass
                   # for a face turned faster than FLIP_DEG ten times harder (tools/shots_roll)
                   "shoulder_contact_frames": 0, "flip_weight": 1e6,
                   # the bat keys away from the swing re-fitted to where these passes held the bat
                   # (tools/refit_keys)
                   "bat_keys": "anatomical_bat_keys.json",
                   # a defence's (or a glance's) grip not carried (make_shots.unfold) this long after the
                   # ball: the bat held where it met it (the top arm at full stretch, 48-54 cm) rather
                   # than drawn back at 1.5 m/s
                   "dead_bat_s": 0.14,
                   "shots": {
                       "back_foot_defence": [(-0.11, 0.13, "lean", 20)],
                       "cover_drive": [(0.579, 0.581, "lean", 20), (-0.361, -0.359, "face", 20)],
                       "square_cut": [(-0.11, 0.11, "lean", 20)],
                       "pull": [(-0.11, 0.11, "lean", 20)],
                       "sweep": [(-0.11, 0.11, "lean", 20)],
                   }},
}


def grip_of(rig) -> dict:
    """The grip ``rig`` holds its bat with (its ``bat.grip``; a rig that names none: ``library``)."""
    return GRIPS[rig.bat.get("grip", "library")]


def reshape(name: str, keys: list, grip: dict) -> list:
    """Shot ``name``'s keys with the grip's edits (its ``shots[name]``: ``(t_from, t_to, what,
    deg)`` each) made to the bat keys that hold both an axis and a face between ``t_from`` and
    ``t_to`` (s from the hit): ``"lean"`` turns the bat's axis about its face normal (the face,
    and so the ball's direction, kept), ``"face"`` turns the face about the axis."""
    edits = grip.get("shots", {}).get(name, [])
    out = []
    for t, k in keys:
        for t0, t1, what, deg in edits:
            if t0 <= t <= t1 and "bat_d" in k and "bat_n" in k:
                d, n = unit(np.asarray(k["bat_d"], float)), unit(np.asarray(k["bat_n"], float))
                n = unit(n - d * (n @ d))
                k = {**k, "bat_d": turn(n, deg, d)} if what == "lean" else {**k, "bat_n": turn(d, deg, n)}
        out.append((t, k))
    return out


def bat_keys(name: str, grip: dict) -> list:
    """Shot ``name``'s bat keys re-fitted for the grip (its ``bat_keys``: a JSON file beside this
    module, written by tools/refit_keys): ``[(t, bat_d, bat_n)]``, or none."""
    if "bat_keys" not in grip:
        return []
    entries = json.loads((Path(__file__).parent / grip["bat_keys"]).read_text()).get(name, [])
    return [(float(t), np.asarray(d, float), np.asarray(n, float)) for t, d, n in entries]


def refit(keys: list, fitted: list) -> list:
    """A shot's keys with the bat's axis and face at each of ``fitted``'s times ``[(t, bat_d,
    bat_n)]`` (tools/refit_keys) in place of the keyed ones (a face keyed by the forearm's way
    included); the grip point, or the hit, stays as keyed. Raises where a time holds no bat key."""
    out = list(keys)
    for t, d, n in fitted:
        i = [j for j, (tk, k) in enumerate(out) if abs(tk - t) < 1e-4 and "bat_d" in k]
        if len(i) != 1:
            raise ValueError(f"re-fitted bat key at t={t}: the shot has no bat key there")
        tk, k = out[i[0]]
        k = {c: v for c, v in k.items() if c not in ("bat_auto", "bat_x")}
        out[i[0]] = (tk, {**k, "bat_d": unit(d), "bat_n": unit(n)})
    return out


def regrip(keys: list, grip: dict, stance: dict, rest: dict) -> list:
    """A shot's keys ``[(t, {channel: value})]`` with the shared ``stance``'s and ``rest``'s
    keys given the grip's values (its ``stance`` and ``rest``). A key is the stance's (or the
    rest's) when every channel it holds has that pose's value: the holds at either end, and the
    bat's stance key before the backlift (the two poses share some values, the face's among them,
    so a channel alone does not tell them apart)."""
    same = lambda a, b: np.array_equal(np.asarray(a, float), np.asarray(b, float))

    def swap(k):
        for shared, new in ((stance, grip.get("stance", {})), (rest, grip.get("rest", {}))):
            if all(c in shared and same(v, shared[c]) for c, v in k.items()):
                return {**k, **{c: np.asarray(v, float) for c, v in new.items() if c in k}}
        return k
    return [(t, swap(k)) for t, k in keys]


def top_hand(grip: dict) -> tuple[list, list]:
    """The rig's ``bat.axis`` (handle -> toe) and ``bat.face_normal`` in LeftHand's frame:
    the toe turned ``top_toe_deg`` from the fingers (+X) toward the thumb (+Z; -90: toward the
    little finger), the face normal the back of the hand (+Y) turned ``top_face_deg`` about
    the handle."""
    t = np.radians(grip["top_toe_deg"])
    toe = np.array([np.cos(t), 0.0, np.sin(t)])
    face = turn(toe, grip["top_face_deg"], np.array([0.0, 1.0, 0.0]))
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
    face = turn(toe, right["face_deg"], np.array([0.0, -1.0, 0.0]))  # the palm behind the face
    z = -toe
    bat_in_hand = np.stack([np.cross(face, z), face, z], -1)
    return bat_in_hand.T
