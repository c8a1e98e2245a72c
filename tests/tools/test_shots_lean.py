"""tools/shots_lean: for a grip that asks for it, the keyed bat leans toward where both arms
hold it inside their limits and the shoulder's ranges, keeping the face at the hit, the shared
stance and rest, and the keyed shot's peak blade speed."""
import numpy as np
import pytest

from tools import make_rig
from tools.grip_feasibility import OVER_DEG, least_excess
from tools.grips import GRIPS
from tools.make_shots import planned
from tools.shots_lean import CONTACT_FRAMES, states
from tools.shots_maths import rot_axis
from tools.shots_roll import held_frames

SHOT = "forward_defence"


@pytest.fixture(scope="module")
def keyed_and_leant():
    """The anatomical grip's planned targets of SHOT without the lean and with it."""
    out = {}
    for lean in (False, True):
        GRIPS["_test"] = {**GRIPS["anatomical"], "lean_pass": lean}
        try:
            out[lean] = planned(SHOT, make_rig.grip_rig("_test"))
        finally:
            del GRIPS["_test"]
    assert GRIPS["anatomical"]["lean_pass"], "the anatomical grip leans its bat"
    return out


def test_the_states_are_rotations_and_the_middle_one_is_the_key():
    lean, tilt, turns = states()
    assert np.allclose(turns @ np.swapaxes(turns, -1, -2), np.eye(3), atol=1e-12)
    middle = len(turns) // 2
    assert lean[middle] == tilt[middle] == 0.0 and np.allclose(turns[middle], np.eye(3))
    assert np.allclose(turns[:, :, 1] @ np.array([0.0, 1.0, 0.0])[:, None], np.cos(np.radians(tilt))[:, None])


def test_the_face_is_kept_at_the_hit_and_the_shared_ends_are_as_keyed(keyed_and_leant):
    (_, keyed, hit, _, _), (_, leant, _, _, info) = keyed_and_leant[False], keyed_and_leant[True]
    face = lambda T: T["bat_rot"][..., 1]
    assert np.allclose(face(leant)[hit], face(keyed)[hit], atol=1e-12)
    assert info["lean"][hit, 1] == 0.0
    near = np.abs(np.arange(len(info["lean"])) - hit) <= CONTACT_FRAMES
    cos = np.einsum("fi,fi->f", face(leant)[near], face(keyed)[near])
    assert cos.min() > np.cos(np.radians(15.0)), "the face turns about the hit as keyed"
    for f in (0, -1):
        assert np.allclose(leant["bat_rot"][f], keyed["bat_rot"][f], atol=1e-12)


def test_the_lean_turns_the_bat_somewhere(keyed_and_leant):
    """Not a pass that does nothing: the anatomical grip's forward defence leans in its backlift."""
    info = keyed_and_leant[True][4]
    assert np.abs(info["lean"]).max() > 10.0
    R = rot_axis(1, info["lean"][:, 0]) @ rot_axis(0, info["lean"][:, 1])
    assert np.allclose(keyed_and_leant[True][1]["bat_rot"], keyed_and_leant[False][1]["bat_rot"] @ R, atol=1e-9)


def test_the_lean_brings_the_arms_within_their_limits_and_ranges(keyed_and_leant):
    excess = {lean: least_excess(solver, T) for lean, (solver, T, *_) in keyed_and_leant.items()}
    for arm in ("Left", "Right"):
        over = {lean: int((e[arm] > OVER_DEG).sum()) for lean, e in excess.items()}
        assert over[True] <= over[False], (arm, over)
    total = {lean: sum(float(e[a].sum()) for a in e) for lean, e in excess.items()}
    assert total[True] < 0.5 * total[False], total


def test_the_blade_is_never_much_faster_than_the_keyed_shots_peak(keyed_and_leant):
    """The pass charges steps beyond the keyed peak on its 15-degree grid; the smoothing of
    its path may add a little (5.8% on the forward defence)."""
    def steps(plan):
        solver, T = plan[0], plan[1]
        blade = T["grip"] + np.einsum("fij,j->fi", T["bat_rot"], solver.bat_from_grip)
        return np.linalg.norm(np.diff(blade, axis=0), axis=-1)
    assert steps(keyed_and_leant[True]).max() <= 1.1 * steps(keyed_and_leant[False]).max()


def test_a_defence_holds_its_bat_where_it_met_the_ball(keyed_and_leant):
    """After the ball (the grip's ``dead_bat_s``) the forward defence's lean is held and its
    tilt 0, and its grip is not carried: the planned blade moves under 1.5 cm a frame there
    (0.45 m/s; before the hold the grip was drawn back 5 cm a frame, 1.5 m/s)."""
    solver, T, hit, _, info = keyed_and_leant[True]
    held = hit + np.arange(int(round(GRIPS["anatomical"]["dead_bat_s"] * 30)) + 1)
    assert len(held) >= 4 and np.all(held_frames(T["roll_weight"])[held])
    assert np.all(info["lean"][held] == info["lean"][hit]) and np.all(info["lean"][held, 1] == 0.0)
    blade = T["grip"] + np.einsum("fij,j->fi", T["bat_rot"], solver.bat_from_grip)
    assert np.linalg.norm(np.diff(blade[held], axis=0), axis=-1).max() < 1.5
