"""tools.make_shots: the shared stance and rest keys are within the arms' reach."""
import numpy as np
import pytest

from engine.rig import default_rig
from tools import make_shots, shots_defs
from tools.shots_ik import PoseSolver


def test_shared_keys_within_reach():
    make_shots.shared_reach(PoseSolver(default_rig()))


def test_a_stance_with_a_locked_arm_is_refused(monkeypatch):
    """The stance before the fix (the library grip's left wrist 53.5 cm from its shoulder, of
    54; the anatomical grip's 49.8) popped the bat 26 cm in the first frames of every shot: it
    must be refused."""
    locked = dict(shots_defs.STANCE, hips_pos=np.array([27.0, 83, 117]), chest_ypr=np.array([-88.0, 16, 18]),
                  toe=np.array([-7.0, 1.5, 102]))
    monkeypatch.setattr(make_shots, "STANCE", locked)
    with pytest.raises(ValueError, match="STANCE: left wrist 49.8 cm"):
        make_shots.shared_reach(PoseSolver(default_rig()))


def test_into_limits_clamps_and_puts_the_right_hand_back():
    """A right wrist pushed 10 deg past its limit comes back to the limit; the right hand,
    moved off the handle by that clamp, is put back on it; the other frames stay."""
    from engine import quat
    from engine.library import find_shot, load_library
    from engine.skeleton import clip_fk
    from tools import shots_check as chk
    rig = default_rig()
    shot = find_shot(load_library(rig=rig), "cover_drive")
    clip = shot.clip.copy()
    j, f = rig.skeleton.index("RightHand"), 40
    e = chk.dof_euler(rig, clip.local_rotations)[f, j]
    e[1] = rig.limits[j, 1, 1] + 10.0                       # y past its upper limit
    clip.local_rotations[f, j] = quat.from_euler(e, "ZYX")
    fixed, largest = make_shots.into_limits(rig, clip)
    assert 9.5 < largest < 10.5
    assert chk.limit_violations(rig, fixed.local_rotations) == []
    have, want = chk.right_in_left(rig, *clip_fk(rig.skeleton, fixed)), chk.right_in_left(rig, *shot.fk)
    assert np.linalg.norm(have[0] - want[0], axis=-1).max() < 0.3
    others = np.arange(clip.num_frames) != f
    assert np.array_equal(fixed.local_rotations[others], clip.local_rotations[others])


def test_the_face_turns_about_the_axis_the_short_way_between_keys():
    """Keys 160 degrees apart about a still axis: the keyed normals exactly at the keys,
    and between them the face turns evenly the shorter way (the normals interpolated
    apart passed through the axis and flipped over in one frame)."""
    from tools.shots_keys import sample_face
    d = np.array([0.0, -1.0, 0.0])
    a = np.radians(160.0)
    n1 = np.array([np.cos(a), 0.0, np.sin(a)])
    keys = [(0.0, {"bat_d": d, "bat_n": np.array([1.0, 0.0, 0.0])}), (0.3, {"bat_d": d, "bat_n": n1})]
    times = np.arange(10) / 30.0
    face = sample_face(keys, times)
    assert np.allclose(face[0], [1, 0, 0]) and np.allclose(face[-1], n1)
    assert np.allclose(face @ d, 0.0) and np.allclose(np.linalg.norm(face, axis=-1), 1.0)
    turn = np.degrees(np.arccos(np.clip((face[1:] * face[:-1]).sum(-1), -1, 1)))
    assert turn.sum() == pytest.approx(160.0, abs=0.01) and turn.max() < 160.0 / 9 * 1.6


def test_the_face_follows_a_turning_axis_without_spinning_about_it():
    """The axis swings 90 degrees with both keys' normals square to the swing plane:
    the face is carried along and never turns about the axis."""
    from tools.shots_keys import sample_face
    n = np.array([0.0, 0.0, 1.0])
    keys = [(0.0, {"bat_d": np.array([0.0, -1.0, 0.0]), "bat_n": n}),
            (0.3, {"bat_d": np.array([1.0, 0.0, 0.0]), "bat_n": n})]
    face = sample_face(keys, np.arange(10) / 30.0)
    assert np.allclose(face, n, atol=1e-9)
