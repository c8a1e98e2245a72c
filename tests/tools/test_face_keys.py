"""tools/face_keys: the faces it tries and the keys it may change (no shot is built here;
the search itself runs in minutes and is an authoring step)."""
import numpy as np
import pytest

from tools import face_keys
from tools.shots_defs import SHOTS


@pytest.mark.parametrize("d", [(0, -1, 0), (-0.35, -0.44, -0.83), (0.9, 0.1, 0.2), (0, 1, 0.01)])
def test_candidate_faces_are_square_to_the_axis_and_evenly_round_it(d):
    d = np.asarray(d, float) / np.linalg.norm(d)
    faces = face_keys.candidate_faces(d)
    assert faces.shape == (8, 3)
    assert np.allclose(np.linalg.norm(faces, axis=-1), 1.0)
    assert np.allclose(faces @ d, 0.0, atol=1e-12)
    turns = np.degrees(np.arccos(np.clip(np.sum(faces * np.roll(faces, -1, 0), -1), -1, 1)))
    assert np.allclose(turns, 45.0)


@pytest.mark.parametrize("name", sorted(SHOTS))
def test_only_faces_left_to_the_forearms_away_from_the_swing_and_stance_are_free(name):
    keys, _ = SHOTS[name]()
    free = face_keys.free_keys(keys)
    for i in free:
        t, k = keys[i]
        assert k.get("bat_auto") and abs(t) >= face_keys.SWING_S and t > face_keys.STANCE_S
    # the hit, the stance and the rest keep the faces they are keyed with
    assert all(abs(keys[i][0]) > 0.2 for i in free)
    assert not {0, 1, len(keys) - 2, len(keys) - 1} & set(free)


def test_with_faces_keys_only_the_faces_asked_for():
    name = "straight_drive"
    keys, _ = SHOTS[name]()
    i = face_keys.free_keys(keys)[0]
    n = face_keys.candidate_faces(keys[i][1]["bat_d"])[3]
    changed, _ = face_keys.with_faces(name, {i: n})
    assert np.array_equal(changed[i][1]["bat_n"], n) and "bat_auto" not in changed[i][1]
    for j in range(len(keys)):
        if j != i:
            assert changed[j][0] == keys[j][0] and changed[j][1].keys() == keys[j][1].keys()


def test_a_trial_that_breaks_what_the_tests_hold_is_refused():
    base = dict(hit_problems=0, face_turn=40.0, jerk=-3.0, clamp=4.0, unfold=30.0)
    assert face_keys.acceptable(dict(base), base)
    for key, bad in (("hit_problems", 1), ("face_turn", 46.0), ("jerk", 0.5), ("clamp", 12.0), ("unfold", 40.0)):
        assert not face_keys.acceptable(dict(base, **{key: bad}), base), key
