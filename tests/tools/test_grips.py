"""tools/grips: a grip is data; the bundled rig is the library grip's build, and the anatomical
grip holds the bat the right way up with the wrists at AAOS. tools/grip_feasibility finds an
elbow that holds a bat wherever the arm really can, and none where the wrist cannot."""
import json

import numpy as np
import pytest

from engine import quat
from engine.library import find_shot, load_library
from engine.rig import assets_dir, default_rig
from engine.skeleton import clip_fk
from tools import make_rig
from tools.grip_feasibility import OVER_DEG, least_excess
from tools.grips import GRIPS, right_in_bat, top_hand
from tools.make_rig import grip_rig
from tools.shots_ik import PoseSolver, grip_frame

THUMB, FINGERS = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])     # in LeftHand's frame


def test_the_bundled_rig_is_the_library_grips_build():
    assert make_rig.rig("library") == json.loads((assets_dir() / "rig.json").read_text())


def test_the_library_grip_holds_the_toe_beyond_the_little_finger():
    axis, _ = top_hand(GRIPS["library"])
    assert np.asarray(axis) @ THUMB == -1.0


@pytest.mark.parametrize("name", sorted(GRIPS))
def test_a_grips_hands_hold_the_handle_as_rotations(name):
    axis, normal = np.asarray(top_hand(GRIPS[name])[0]), np.asarray(top_hand(GRIPS[name])[1])
    assert abs(np.linalg.norm(axis) - 1) < 1e-9 and abs(np.linalg.norm(normal) - 1) < 1e-9 and abs(axis @ normal) < 1e-9
    r = right_in_bat(GRIPS[name])
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(r), 1.0)


def test_the_anatomical_grip_holds_the_toe_beyond_thumb_and_forefinger():
    """Both hands: the toe leaves the fist on the thumb's side, toward the fingers' ends (the
    right hand's fingers point along -X, its thumb +Z, as the left's mirror)."""
    g = GRIPS["anatomical"]
    axis = np.asarray(top_hand(g)[0])
    assert axis @ THUMB > 0.3 and axis @ FINGERS > 0.3
    toe_in_right = right_in_bat(g).T @ np.array([0.0, 0.0, -1.0])     # the bat's -Z, in RightHand's frame
    assert toe_in_right @ THUMB > 0.3 and toe_in_right @ -FINGERS > 0.3


def test_a_grip_rig_holds_the_bat_where_its_grip_says():
    rig = grip_rig("anatomical")
    assert rig.bat["grip"] == "anatomical"
    assert np.allclose(rig.skeleton.offsets[rig.bat_joint], make_rig.bat_joint_offset(rig.bat))
    assert np.allclose(grip_frame(rig)[:, 2], -np.asarray(rig.bat["axis"]))
    for side, s in (("Left", 1), ("Right", -1)):
        lo, hi = rig.limits[rig.skeleton.index(side + "Hand"), 1]
        assert (lo, hi) == ((-20, 30) if s > 0 else (-30, 20))


def held_bat(rig, shot):
    """The targets of a bundled shot's solved pose as ``PoseSolver.body_pose`` and
    ``least_excess`` read them: the bat where the top hand really holds it."""
    sk = rig.skeleton
    g_rot, g_pos = clip_fk(sk, shot.clip)
    m = quat.to_matrix(g_rot)
    hand = m[:, sk.index("LeftHand")]
    solver = PoseSolver(rig)
    T = {"hips_pos": g_pos[:, 0], "hips_rot": m[:, 0], "chest_rot": m[:, sk.index("Spine2")],
         "head_rot": m[:, sk.index("Head")],
         "grip": g_pos[:, sk.index("LeftHand")] + hand @ solver.left_grip, "bat_rot": hand @ grip_frame(rig),
         "roll_weight": np.full(len(m), np.inf)}
    for side, pre in (("l", "Left"), ("r", "Right")):
        T[side + "_ankle"] = g_pos[:, sk.index(pre + "Foot")]
        T[side + "_foot_rot"] = m[:, sk.index(pre + "Foot")]
        T[side + "_toe_bend"] = np.zeros(len(m))
        T[side + "_knee_dir"] = m[:, sk.index(pre + "UpLeg")] @ np.array([0.0, 0.0, 1.0])
    return solver, T


def test_feasibility_finds_the_elbow_of_an_arm_that_holds_the_bat():
    """The straight drive's top arm holds its bat inside the library rig's limits on every frame,
    so an elbow on its circle does (within the circle's sampling); under the anatomical
    grip's wrist range the same hands' poses (75 deg of radial deviation) are held nowhere near."""
    rig = default_rig()
    shot = find_shot(load_library(rig=rig), "straight_drive")
    least = least_excess(*held_bat(rig, shot))["Left"]
    assert least.max() <= OVER_DEG, np.round(least, 1)
    narrow = default_rig()
    j = narrow.skeleton.index("LeftHand")
    narrow.limits[j, 1] = (-20.0, 30.0)
    least = least_excess(*held_bat(narrow, shot))["Left"]
    assert (least > OVER_DEG).sum() > len(least) // 2, np.round(least, 1)
