"""The authoring tools take the top hand's grip from the rig (``rig.bat``: ``axis`` and
``face_normal`` in LeftHand's frame) and assume none of their own: turn the grip, and the
keyed bat stays where it is while the hands move round it."""
import numpy as np
import pytest

from engine.rig import default_rig
from tools.make_rig import bat_joint_offset
from tools.shots_grips import BottomHand
from tools.shots_ik import PoseSolver, bat_from_grip, grip_frame
from tools.shots_maths import perp, rot_axis, unit
from tools.shots_keys import bat_frame, face_for_forearm


def turned_rig(degrees: float):
    """The bundled rig with the bat turned in the top hand about the palm's normal (LeftHand
    Y): at 140 the toe leaves beyond the thumb, 50 deg from the fingers."""
    rig = default_rig()
    turn = rot_axis(1, degrees)
    rig.bat = dict(rig.bat, axis=(turn @ np.asarray(rig.bat["axis"])).tolist(),
                   face_normal=(turn @ np.asarray(rig.bat["face_normal"])).tolist())
    rig.skeleton.offsets[rig.bat_joint] = bat_joint_offset(rig.bat)
    return rig


def keyed_bats(n: int = 6):
    rng = np.random.default_rng(3)
    d = np.array([unit(v) for v in rng.normal(size=(n, 3))])
    face = np.array([perp(v, a) for v, a in zip(rng.normal(size=(n, 3)), d)])
    return rng.uniform(-50, 50, (n, 3)), d, bat_frame(d, face)


def test_the_rigs_bat_joint_is_where_the_grip_puts_the_ball():
    rig = default_rig()
    assert np.allclose(bat_joint_offset(rig.bat), rig.skeleton.offsets[rig.bat_joint])


@pytest.mark.parametrize("degrees", [0.0, 140.0, -35.0])
def test_a_turned_grip_moves_the_hands_not_the_bat(degrees):
    rig, bundled = turned_rig(degrees), default_rig()
    grip, d, B = keyed_bats()
    l_wrist, l_rot, r_wrist, r_rot = PoseSolver(rig).hand_targets(grip, B)
    # the top hand holds the bat as the rig says ...
    assert np.allclose(l_rot @ np.asarray(rig.bat["axis"]), d, atol=1e-9)
    assert np.allclose(l_rot @ np.asarray(rig.bat["face_normal"]), B[..., 1], atol=1e-9)
    # ... so the Bat joint (LeftHand's child) lands where the keys put it, whatever the grip
    bat_joint = l_wrist + l_rot @ rig.skeleton.offsets[rig.bat_joint]
    assert np.allclose(bat_joint, grip + B @ bat_from_grip(bundled), atol=1e-9)
    # and the bottom palm sits on the handle, its grip length further down
    palm = r_wrist + r_rot @ (np.asarray(rig.bat["left_grip"]) * [-1.0, 1.0, 1.0])
    assert np.allclose(palm, grip + d * rig.bat["right_grip_below_left"], atol=1e-9)
    if degrees:
        assert not np.allclose(l_rot, PoseSolver(bundled).hand_targets(grip, B)[1])


@pytest.mark.parametrize("degrees", [0.0, 140.0])
def test_the_face_for_a_forearm_points_the_top_forearm_that_way(degrees):
    rig = turned_rig(degrees)
    forearm_in_bat = grip_frame(rig)[0]
    _, d, _ = keyed_bats()
    for a, x in zip(d, np.random.default_rng(5).normal(size=(len(d), 3))):
        n = face_for_forearm(a, x, forearm_in_bat)
        hand_x = bat_frame(a, n) @ forearm_in_bat
        assert abs(n @ a) < 1e-9
        assert unit(perp(hand_x, a)) @ unit(perp(x, a)) > 1 - 1e-9


def test_a_grip_whose_face_is_not_across_the_axis_is_refused():
    rig = default_rig()
    rig.bat = dict(rig.bat, face_normal=[0.0, 0.6, -0.8])
    with pytest.raises(ValueError, match="perpendicular"):
        grip_frame(rig)


@pytest.mark.parametrize("turn", [-30.0, 15.0, 30.0])
def test_the_bottom_hand_turns_about_the_handle_with_its_palm_on_it(turn):
    """BottomHand.turned: the bottom hand's palm stays where it held the handle,
    and the hand's rotation differs from the keyed one by ``turn`` about the handle only."""
    rig = default_rig()
    solver = PoseSolver(rig)
    grip, d, B = keyed_bats()
    _, _, r_wrist, r_rot = solver.hand_targets(grip, B)
    wrist, rot = solver.bottom_hand.turned(r_wrist, r_rot, turn)
    palm = np.asarray(rig.bat["left_grip"]) * [-1.0, 1.0, 1.0]
    assert np.allclose(wrist + rot @ palm, r_wrist + r_rot @ palm, atol=1e-9)
    delta = rot @ np.swapaxes(r_rot, -1, -2)                  # the world turn from keyed to turned
    assert np.allclose(delta @ d[..., None], d[..., None], atol=1e-9)      # about the handle
    angle = np.degrees(np.arccos(np.clip((np.trace(delta, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)))
    assert np.allclose(angle, abs(turn), atol=1e-6)
    assert not np.allclose(wrist, r_wrist)                     # the wrist goes round with it


def test_the_bottom_hand_slides_down_the_handle_toward_the_blade():
    """BottomHand.grips: every candidate keeps the bottom palm on the handle's axis,
    a slide moves it that far toward the toe, the first and last frames (the shared stance
    and rest) allow no slide, and a slide faster than SLIDE_STEP_CM a frame is charged
    beyond anything a comfortable one costs."""
    rig = default_rig()
    solver = PoseSolver(rig)
    grip, d, B = keyed_bats(8)
    _, _, r_wrist, r_rot = solver.hand_targets(grip, B)
    wrists, rots, costs, charges, turns, slides = solver.bottom_hand.grips(r_wrist, r_rot)
    palm = np.asarray(rig.bat["left_grip"]) * [-1.0, 1.0, 1.0]
    keyed_palm = r_wrist + r_rot @ palm
    assert turns[0] == slides[0] == 0.0 and sorted(set(slides)) == sorted(BottomHand.SLIDES)
    for w, r, s in zip(wrists, rots, slides):
        assert np.allclose(w + r @ palm, keyed_palm + s * d, atol=1e-9)
    held, moved = BottomHand.HELD_FRAMES, slides > 0.0
    assert np.isinf(costs[:held][:, moved]).all() and np.isinf(costs[-held:][:, moved]).all()
    assert np.isfinite(costs[held:-held]).all() and (costs[:, 0] == 0.0).all()
    same_turn = turns[:, None] == turns[None, :]
    fast = np.abs(slides[:, None] - slides[None, :]) > BottomHand.SLIDE_STEP_CM
    assert charges[fast & same_turn].min() > 100.0 * charges[~fast & same_turn].max()
