"""The body drawn for a skeleton without a mesh of its own: capsules, a head, and the
implement its profile names held in the lead hand."""

import numpy as np

from app.render.bonebody import BAT_BLADE_CM, BAT_HANDLE_CM, BAT_TOP_CM, CLUB_SHAFT_CM, bone_body
from engine.capture import load_capture
from engine.skeleton import bind_positions
from tests import capture_kit as kit


def _reach_along_axis(rig, implement):
    """How far the lead hand's vertices reach along the implement's axis, from the hand (cm)."""
    mesh = bone_body(rig, rig.roles.get("head"), implement)
    hand = int(rig.skeleton.parents[rig.bat_joint])
    held = mesh.joints[:, 0] == hand
    axis = np.asarray(rig.bat["axis"], float)
    axis /= np.linalg.norm(axis)
    return float(((mesh.positions[held] - bind_positions(rig.skeleton)[hand]) @ axis).max(initial=0.0))


def test_the_implement_drawn_is_the_one_the_profile_names(tmp_path):
    rig = load_capture(kit.write_family(tmp_path / "n.bvh", "neuron")).rig
    bat = _reach_along_axis(rig, dict(rig.bat, kind="bat", held=True))
    club = _reach_along_axis(rig, dict(rig.bat, kind="club", held=True))
    none = _reach_along_axis(rig, dict(rig.bat, kind="none", held=True))
    assert abs(bat - (BAT_HANDLE_CM + BAT_BLADE_CM[0] - BAT_TOP_CM)) < 1.0
    assert abs(club - (CLUB_SHAFT_CM - BAT_TOP_CM)) < 1.0
    assert none < 0.5 * bat                  # the hand's own capsule only
    no_axis = {k: v for k, v in rig.bat.items() if k != "axis"}
    assert _reach_along_axis(rig, dict(no_axis, held=True)) == none
    assert _reach_along_axis(rig, dict(rig.bat, kind="bat", held=False)) == none


def test_hands_that_hold_nothing_get_no_implement(tmp_path):
    """A walk's hands are half a metre apart at its 'hit': the capture says nothing is held
    and the body has no implement; a golf swing's hands (16.5 cm) hold the club its profile
    (CMU's) names."""
    from tests.conftest import MOCAP
    walk = load_capture(MOCAP / "cmu_02_01_walk.bvh").rig
    golf = load_capture(MOCAP / "cmu_63_02_golf_swing.bvh").rig
    assert not walk.bat["held"] and golf.bat["held"] and golf.bat["kind"] == "club"
    assert _reach_along_axis(walk, walk.bat) == _reach_along_axis(walk, dict(walk.bat, kind="none"))
    assert _reach_along_axis(golf, golf.bat) > CLUB_SHAFT_CM - BAT_TOP_CM - 1.0
