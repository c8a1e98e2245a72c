"""Write assets/rig.json: the bundled batsman's skeleton, DOFs, limits, IK chains
and bat/ball dimensions. Deterministic; run `python -m tools.make_rig`.

Offsets are in cm, in a T-pose facing +Z with the left side toward +X (joint
frames world-aligned, as in BVH). Limits are Euler degrees for
R = Rz(z) Ry(y) Rx(x); in the arms x is the twist about the bone.

Anatomical ranges (DESIGN.md: a shot that needs more is re-keyed, the limit is not widened):
- ForeArmRoll x, forearm pronation/supination from the mid-position (the T-pose's
  palm-down, thumb-forward hand is the mid-position: the arm hanging with the palm
  to the thigh, abducted 90 deg): pronation 85, supination 90 (Kapandji, The
  Physiology of the Joints vol. 1; AAOS, Joint Motion: Method of Measuring and
  Recording, 1965, gives 80 / 80). For the left arm +x turns the palm backward and
  the thumb down: pronation; so [-90, 85]. The same on the right: the frames are
  world-aligned, and a mirror across the midplane keeps a rotation about X (+x turns
  either thumb down).
- Hand z, wrist flexion/extension: flexion 80, extension 70 (AAOS 1965). For the
  left hand +z lifts the fingers (extension): [-80, 70], mirrored on the right.
- Arm (the humerus under the clavicle), R = Rz(z) Ry(y) Rx(x) with x along the bone
  (left arm: +X out to the side, +Y up, +Z forward): the bone points along
  (cos y cos z, cos y sin z, -sin y), so z is its angle in the frontal plane (-90
  hanging, 0 out to the side, +90 overhead) and y its angle out of that plane (-
  forward, + backward). Abduction 180 (AAOS 1965): z up to +90. Extension 60 (AAOS):
  y up to +60 (the hanging arm swung back). Flexion 180 (AAOS) goes forward through
  y = -90 and on up to z = +90, y = 0, so y stays within [-90, 60]: the second ZYX
  branch (y past -90, with the twist turned by 180) never fits the box, and the box
  means one rotation only. Across the front the frontal-plane angle wraps at +-180
  where the crossed arm passes shoulder height (horizontal flexion 135, AAOS, is
  z = +-180, y = -45), and the bottom arm at the hit sits there (z 150-180 on the
  right): a bound at the wrap walls the solvers in. So z runs past it, down to -225
  (the limits' ranges may pass +-180: engine.quat_nb.into_range), the crossed arm up
  to 45 deg above shoulder height, as in front of the face with the arm forward. The
  box cannot tell that from an arm crossing behind the head, nor bound horizontal
  flexion by 135 on its own; the authoring checks measure those on the bone's
  direction and the trunk (tools/shots_check.shoulder_problems, trunk_problems).
- UpLeg, the hip (the leg hanging along -y): +z swings the left foot out to the side
  (abduction 45, adduction 30, AAOS 1965: [-30, 45]), +x swings it back (flexion 120,
  extension 30: [-120, 30]); mirrored on the right. The shots use abduction up to 40,
  adduction 20, flexion 107 and no extension. Adduction was 20, tighter than anatomy: it
  held the CMU golfer's trail foot 5.6 cm off its plant in an exaggerated take. The y column,
  a turn about the vertical, is the femur's axial rotation only with the hip straight (with
  it flexed, as in every front leg, it swings the thigh across), so it keeps [-70, 70]; the
  shots use up to 68.
- Hand y, the wrist's radial/ulnar deviation: AAOS's 20 / 30 (the bundled rig's grip is
  tools/grips' ``anatomical``). -y turns the left hand toward +Z, the thumb (the T-pose's
  palm-down hand, and the batsman mesh's thumb), so -y is radial deviation on the left and +y
  on the right. The ``library`` grip, which the shots were first authored with, held the bat
  upside down and needed [-75, 55] (docs/history.md).
Wider than anatomy, and held by the solvers instead:
- Arm x + ArmRoll x, the humeral rotation (AAOS internal 70 / external 90), hold +-90
  each: the bat's poses in the backlifts and follow-throughs ask for up to 150-180. No box on
  the ZYX twist can be AAOS's: an arm across the chest with no axial rotation reads x = 180
  (z = 180, y = -45; tests/assets/test_rig_anatomy.test_the_euler_twist_is_not_the_axial_rotation).
  So the rig gives the axial range itself (``humerus``: AAOS internal 70 / external 90, read
  as ISB does), and every solver holds it after each step (engine/humerus_nb.py); the Euler
  box stays the joints' own reach.
The grips are data in tools/grips: ``anatomical`` (the bundled rig: the toe beyond thumb and
forefinger, Hand y at AAOS) and ``library`` (both hands holding the bat upside down, the top
hand's toe beyond the little finger, Hand y widened to [-75, 55]; ``grip_rig``). The shots were
authored with the library grip; docs/history.md has the anatomical grip's re-keys and builds.
"""
import json
from functools import partial
from pathlib import Path

import numpy as np

from engine.rig import Rig, rig_from_dict

from .grips import GRIPS, top_hand

BALL_DIAMETER = 7.2
BAT = {
    "length": 86.0, "handle_length": 30.0, "blade_width": 10.8,
    "blade_thickness": 6.0, "edge_thickness": 3.8,
    # grip point of the left (top) hand, in LeftHand's frame: the palm centre
    "left_grip": [8.0, -2.0, 0.0],
    "grip_to_top": 5.0,               # handle top lies 5 cm beyond the left grip
    # the grip (tools/grips) adds "axis" (handle -> toe) and "face_normal", in LeftHand's
    # frame: the Bat joint (bat_joint_offset) and the authoring (tools/shots_ik) follow them
    "right_grip_below_left": 11.0,    # cm further down the handle
}


def joint(name, parent, offset, dof="", limits=None, end=None):
    j = {"name": name, "parent": parent, "offset": offset, "dof": dof,
         "limits": limits or {}}
    if end is not None:
        j["end_site"] = end
    return j


def mirrored(s, z=None, y=None, x=None) -> dict:
    """A joint's limits on side ``s`` (+1 left, -1 right) from the left side's ranges. The
    mirror across the midplane (x -> -x) flips rotations about world Z and Y; a rotation
    about X keeps its sign, as the frames are world-aligned (+x turns either thumb down from
    the T-pose, and bends either hip or knee the same way)."""
    f = (lambda r: r) if s > 0 else (lambda r: [-r[1], -r[0]])
    out = {k: f(v) for k, v in (("z", z), ("y", y)) if v is not None}
    if x is not None:
        out["x"] = x
    return out


def side(prefix, s, hand_y=(-75, 55)):
    """Arm joints; s = +1 for left (+X), -1 for right; ``hand_y``: the left wrist's deviation
    range (the grip's, tools/grips)."""
    lim = partial(mirrored, s)
    L = prefix
    return [
        joint(f"{L}Shoulder", "Spine2", [3.0 * s, 12.0, 0.0], "zy", lim([-25, 35], [-30, 30], None)),
        joint(f"{L}Arm", f"{L}Shoulder", [15.0 * s, 0.0, 0.0], "zyx", lim([-225, 90], [-90, 60], [-90, 90])),
        joint(f"{L}ArmRoll", f"{L}Arm", [14.0 * s, 0.0, 0.0], "x", lim(None, None, [-90, 90])),
        joint(f"{L}ForeArm", f"{L}ArmRoll", [14.0 * s, 0.0, 0.0], "y", lim(None, [-150, 0], None)),
        joint(f"{L}ForeArmRoll", f"{L}ForeArm", [13.0 * s, 0.0, 0.0], "x", lim(None, None, [-90, 85])),
        joint(f"{L}Hand", f"{L}ForeArmRoll", [13.0 * s, 0.0, 0.0], "zy", lim([-80, 70], list(hand_y), None),
              end=[9.0 * s, 0.0, 0.0]),
    ]


def leg(prefix, s):
    lim = partial(mirrored, s)
    L = prefix
    return [
        joint(f"{L}UpLeg", "Hips", [9.0 * s, -6.0, 0.0], "zyx", lim([-30, 45], [-70, 70], [-120, 30])),
        joint(f"{L}Leg", f"{L}UpLeg", [0.0, -44.0, 0.0], "x", lim(None, None, [0, 150])),
        joint(f"{L}Foot", f"{L}Leg", [0.0, -41.0, 0.0], "zyx", lim([-40, 40], [-35, 35], [-55, 55])),
        joint(f"{L}ToeBase", f"{L}Foot", [0.0, -6.0, 13.0], "x", lim(None, None, [-60, 30]),
              end=[0.0, 0.0, 7.0]),
    ]


def bat_joint_offset(b: dict) -> list:
    """Where the ball meets the face, in LeftHand's frame (cm): the middle of the blade, a
    ball's radius out from the face, wherever the grip (``axis``, ``face_normal``) holds it."""
    axis, normal = np.asarray(b["axis"], float), np.asarray(b["face_normal"], float)
    along = b["length"] - b["grip_to_top"] - (b["length"] - b["handle_length"]) / 2
    out = b["blade_thickness"] / 2 + BALL_DIAMETER / 2
    return (np.asarray(b["left_grip"], float) + along * axis + out * normal).tolist()


def rig(grip: str = "anatomical"):
    """The rig as a dict (``assets/rig.json``), its bat held with ``grip`` (tools/grips.GRIPS)."""
    g = GRIPS[grip]
    axis, normal = top_hand(g)
    bat = dict(BAT, axis=axis, face_normal=normal, grip=grip)
    spine = {"z": [-45, 45], "y": [-50, 50], "x": [-40, 60]}
    joints = [
        joint("Hips", None, [0.0, 97.0, 0.0], "zyx", {"z": [-180, 180], "y": [-180, 180], "x": [-180, 180]}),
        joint("Spine", "Hips", [0.0, 10.0, 0.0], "zyx", spine),
        joint("Spine1", "Spine", [0.0, 12.0, 0.0], "zyx", spine),
        joint("Spine2", "Spine1", [0.0, 12.0, 0.0], "zyx", spine),
        joint("Neck", "Spine2", [0.0, 17.0, 0.0], "zyx", {"z": [-40, 40], "y": [-70, 70], "x": [-40, 50]}),
        joint("Head", "Neck", [0.0, 10.0, 2.0], "zyx", {"z": [-40, 40], "y": [-70, 70], "x": [-40, 50]},
              end=[0.0, 19.0, 0.0]),
    ]
    joints += side("Left", 1, g["hand_y"]) + side("Right", -1, g["hand_y"]) + leg("Left", 1) + leg("Right", -1)
    joints.append(joint("Bat", "LeftHand", bat_joint_offset(bat), ""))
    return {
        "units": "cm",
        "euler_order": "ZYX",
        "joints": joints,
        "animated_joints": 26,
        "chains": {
            "left_arm": {"start": "Spine", "end": "LeftHand", "effector": "Bat"},
            "right_arm": {"start": "RightShoulder", "end": "RightHand", "effector": "RightHand"},
            "left_leg": {"start": "LeftUpLeg", "end": "LeftFoot", "effector": "LeftFoot"},
            "right_leg": {"start": "RightUpLeg", "end": "RightFoot", "effector": "RightFoot"},
        },
        "wrist": {"joint": "LeftHand", "default_dof": 0},
        "feet": {"left": ["LeftFoot", "LeftToeBase"], "right": ["RightFoot", "RightToeBase"]},
        # the humerus's axial rotation as ISB reads it (engine.humerus_nb), AAOS's range
        "humerus": {"chest": "Spine2", "left": "LeftArmRoll", "right": "RightArmRoll",
                    "internal": 70, "external": 90},
        "bat": bat,
        "ball": {"diameter": BALL_DIAMETER},
    }


def grip_rig(grip: str) -> Rig:
    """The bundled rig with its bat held with ``grip`` (tools/grips.GRIPS)."""
    return rig_from_dict(json.loads(json.dumps(rig(grip))))


if __name__ == "__main__":
    out = Path(__file__).resolve().parent.parent / "assets" / "rig.json"
    out.write_text(json.dumps(rig(), indent=1) + "\n")
    print(f"wrote {out}")
