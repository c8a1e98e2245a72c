"""tools/grips: a grip is data; the bundled rig is the anatomical grip's build: it
holds the bat the right way up with the wrists at AAOS. tools/grip_feasibility finds an
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


def test_the_bundled_rig_is_the_anatomical_grips_build():
    assert make_rig.rig("anatomical") == json.loads((assets_dir() / "rig.json").read_text())


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
    """Where the straight drive's top arm holds its bat inside the shoulder's ranges, an elbow on
    its circle does inside the rig's limits too, in all but a frame or two (the circle's
    sampling, and the clavicle PoseSolver.body_pose puts back: 1 of 62, 7 deg, in the anatomical
    grip's shot); with the wrist locked the same hands' poses are held nowhere near."""
    from tools.shots_check import axial_excess, horizontal_excess, humeral_rotations, humerus_angles
    rig = default_rig()
    shot = find_shot(load_library(rig=rig), "straight_drive")
    g_rot = shot.fk[0]
    _, elevation, axial = humeral_rotations(rig, g_rot, "Left")
    own = horizontal_excess(*humerus_angles(rig, g_rot, "Left")) + axial_excess(elevation, axial)
    held = own < 0.5
    assert held.sum() > len(held) // 2
    least = least_excess(*held_bat(rig, shot))["Left"]
    assert (least[held] > OVER_DEG).sum() <= 2, np.round(least[held], 1)
    narrow = default_rig()
    j = narrow.skeleton.index("LeftHand")
    narrow.limits[j] = (-1.0, 1.0)
    least = least_excess(*held_bat(narrow, shot))["Left"]
    assert (least > OVER_DEG).mean() > 0.9, np.round(least, 1)


def test_regrip_gives_the_grips_values_to_the_stance_and_rest_keys_alone():
    """The holds at either end and the bat's stance key before the backlift take the grip's
    values; every other key, and every channel the grip does not re-key, is left as it was
    (the stance and rest share their face, so a channel alone cannot tell them apart)."""
    from tools.grips import regrip
    from tools.shots_defs import REST, SHOTS, STANCE
    grip = GRIPS["anatomical"]
    same = lambda a, b: np.array_equal(np.asarray(a, float), np.asarray(b, float))
    for name in SHOTS:
        keys, _ = SHOTS[name]()
        found = []
        for (t, before), (t2, after) in zip(keys, regrip(keys, grip, STANCE, REST)):
            shared = next((p for p in (STANCE, REST) if all(c in p and same(v, p[c]) for c, v in before.items())), None)
            new = {} if shared is None else grip["stance" if shared is STANCE else "rest"]
            found.append("stance" if shared is STANCE else "rest" if shared is REST else "")
            assert t == t2 and before.keys() == after.keys()
            for c in before:
                assert same(after[c], new.get(c, before[c])), (name, t, c)
        # the two holds at either end, and the bat's stance key before the backlift (the feet's
        # keys that hold the stance's too have no channel the grip re-keys)
        assert found[:2] == ["stance"] * 2 and found[-2:] == ["rest"] * 2, (name, found)
        assert any(f == "stance" and "bat_d" in k for f, (t, k) in zip(found[2:], keys[2:])), name


def test_regrip_leaves_the_library_grips_keys_alone():
    from tools.grips import regrip, reshape
    from tools.shots_defs import REST, SHOTS, STANCE
    for name in SHOTS:
        keys, _ = SHOTS[name]()
        assert reshape(name, regrip(keys, GRIPS["library"], STANCE, REST), GRIPS["library"]) == keys


@pytest.mark.parametrize("what", ["lean", "face"])
def test_reshape_turns_the_bat_about_its_face_or_its_axis(what):
    """``lean`` turns the axis about the face normal (the face, so the ball's direction, kept);
    ``face`` turns the face about the axis (the axis kept); keys outside the window, and keys
    without both, are untouched."""
    from tools.grips import reshape
    d, n = np.array([0.0, -0.8, 0.6]), np.array([0.0, 0.6, 0.8])
    keys = [(-0.2, {"bat_d": d, "bat_n": n}), (0.0, {"bat_d": d, "bat_n": n, "hit": np.zeros(3)}),
            (0.05, {"bat_d": d}), (0.3, {"bat_d": d, "bat_n": n})]
    out = reshape("x", keys, {"shots": {"x": [(-0.1, 0.1, what, 30.0)]}})
    assert out[0] == keys[0] and out[2] == keys[2] and out[3] == keys[3]
    k = out[1][1]
    assert np.array_equal(k["hit"], keys[1][1]["hit"])
    if what == "lean":
        assert np.allclose(k["bat_n"], n) and np.isclose(np.degrees(np.arccos(k["bat_d"] @ d)), 30.0)
        assert abs(k["bat_d"] @ n) < 1e-12
    else:
        assert np.allclose(k["bat_d"], d) and np.isclose(np.degrees(np.arccos(k["bat_n"] @ n)), 30.0)
        assert abs(k["bat_n"] @ d) < 1e-12
