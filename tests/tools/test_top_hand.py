"""tools/shots_grips.TopHand: for a grip that asks (``top_leans``), the top arm's pass may lean the
bat about its face normal; the face is kept, the keyed bat comes first and costs nothing, the
lean is held at the hit and the shared ends, and a lean that speeds the blade up is charged."""
import numpy as np
import pytest

from tools import make_rig
from tools.grips import GRIPS
from tools.make_shots import planned

SHOT = "forward_defence"


@pytest.fixture(scope="module")
def candidates():
    assert GRIPS["anatomical"].get("top_leans"), "the anatomical grip leans its bat in the top arm's pass"
    solver, T, hit, _, _ = planned(SHOT, make_rig.grip_rig("anatomical"))
    held = solver.top_hand.held(T["roll_weight"])
    return solver, T, hit, held, solver.top_hand.grips(T["grip"], T["bat_rot"], held)


def test_every_candidate_holds_the_keyed_face_at_the_keyed_grip(candidates):
    solver, T, _, _, (wrists, rots, _, _, leans) = candidates
    assert leans[0] == 0.0 and len(leans) == len(set(leans.tolist())) > 1
    keyed_wrist, keyed_rot = solver.hand_targets(T["grip"], T["bat_rot"])[:2]
    assert np.allclose(wrists[0], keyed_wrist) and np.allclose(rots[0], keyed_rot)
    for w, r, a in zip(wrists, rots, leans):
        bat = r @ solver.left_in_bat.T
        assert np.allclose(bat[..., 1], T["bat_rot"][..., 1], atol=1e-9), "the face normal is kept"
        cos = np.einsum("fi,fi->f", bat[..., 2], T["bat_rot"][..., 2])
        assert np.allclose(cos, np.cos(np.radians(a)), atol=1e-9), "the handle leans by the lean"
        # the palm's grip point stays on the keyed grip point
        assert np.allclose(w + r @ solver.left_grip, T["grip"], atol=1e-9)


def test_the_keyed_bat_is_free_and_the_lean_is_held_at_the_hit_and_the_shared_ends(candidates):
    solver, _, hit, held, (_, _, costs, _, leans) = candidates
    top = solver.top_hand
    assert held[hit - top.CONTACT_FRAMES:hit + top.CONTACT_FRAMES + 1].all()
    assert held[:top.END_FRAMES].all() and held[-top.END_FRAMES:].all() and not held.all()
    assert np.all(costs[:, 0] == 0.0)
    assert np.all(np.isinf(costs[held][:, 1:])) and np.all(np.isfinite(costs[~held]))
    free = costs[~held][0]
    assert np.all(np.diff(free[np.argsort(np.abs(leans))]) >= 0.0), "a bigger lean costs more"


def test_a_lean_that_speeds_the_blade_up_is_charged(candidates):
    solver, T, _, _, (_, _, _, charges, leans) = candidates
    F, G = len(T["grip"]), len(leans)
    assert charges.shape == (F - 1, G, G) and np.all(charges >= 0.0)
    assert np.allclose(charges[:, 0, 0], 0.0), "the keyed bat moves no faster than its own peak"
    # from the keyed bat to the widest lean in one frame swings the blade tens of cm
    blade = np.linalg.norm(solver.bat_from_grip) * 2 * np.sin(np.radians(np.abs(leans).max()) / 2)
    assert blade > 20.0 and charges[:, 0, np.argmax(np.abs(leans))].min() > 1e4


def test_the_built_shot_leans_but_not_at_the_hit_nor_the_shared_ends(candidates):
    from tools.make_shots import build
    _, _, hit, held, _ = candidates
    info = build(SHOT, make_rig.grip_rig("anatomical"))[4]
    lean = info["top_lean"]
    assert np.all(lean[held] == 0.0) and lean[hit] == 0.0 and lean[0] == lean[-1] == 0.0
    assert np.abs(lean).max() >= 10.0, "a pass that never leans does nothing"


def test_a_lean_the_bottom_arm_cannot_follow_is_charged(candidates):
    """The pose solver adds to each lean what it asks of the bottom arm past TopHand.BOTTOM_DEG:
    never less than the lean's own cost, more somewhere (the anatomical forward defence's bottom
    arm cannot hold every lean), and nothing for the keyed bat where the keys hold it."""
    solver, T, _, held, (_, _, costs, _, leans) = candidates
    _, g_rot, g_pos = solver.body_pose(T)
    charged = solver._top_hand_candidates(T, g_rot, g_pos)[2]
    assert charged.shape == costs.shape and np.all(charged >= costs)
    assert np.any(charged[~held] > costs[~held] + 1.0)
    assert np.median(charged[:, 0] - costs[:, 0]) == 0.0


def test_leans_without_the_keyed_bat_are_refused():
    from tools.shots_grips import TopHand
    with pytest.raises(ValueError, match="must hold 0"):
        TopHand([-10.0, 10.0], None, None)
