"""tools/refit_keys and tools/grips.refit: a grip's re-fitted bat keys turn the bat at the keys'
own times, away from the swing and the shared stance and rest, and nowhere else; the grip point
stays as keyed; the written data names only bat keys each shot has."""
import numpy as np
import pytest

from tools.grips import GRIPS, bat_keys, refit
from tools.refit_keys import REST_S, STANCE_S, SWING_S, fitted_keys, rank
from tools.shots_defs import SHOTS
from tools.shots_keys import bat_frame
from tools.shots_maths import rot_axis


def bat_times(keys):
    return [t for t, k in keys if "bat_d" in k]


def test_refit_turns_the_bat_at_its_times_alone_and_keeps_the_grip():
    keys, _ = SHOTS["forward_defence"]()
    free = [t for t in bat_times(keys) if abs(t) >= SWING_S and STANCE_S < t < keys[-1][0] - REST_S]
    d, n = np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    out = refit(keys, [(free[0], d, n)])
    changed = [i for i, ((_, a), (_, b)) in enumerate(zip(keys, out)) if a is not b]
    assert len(changed) == 1
    t, k = out[changed[0]]
    assert t == free[0] and np.allclose(k["bat_d"], d) and np.allclose(k["bat_n"], n)
    assert "bat_auto" not in k and "bat_x" not in k
    old = keys[changed[0]][1]
    assert all(np.array_equal(k[c], old[c]) for c in ("grip", "hit", "toe") if c in old)
    assert refit(keys, []) == keys


def test_refit_refuses_a_time_without_a_bat_key():
    keys, _ = SHOTS["square_cut"]()
    with pytest.raises(ValueError, match="no bat key"):
        refit(keys, [(0.123, np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0]))])


def test_fitted_keys_key_the_solved_bat_away_from_the_swing_stance_and_rest():
    keys, _ = SHOTS["pull"]()
    hit = int(round(-keys[0][0] * 30))
    frames = int(round((keys[-1][0] - keys[0][0]) * 30)) + 1
    held = bat_frame(np.array([-0.3, -0.9, 0.2]), np.array([0.0, 0.3, 1.0]))
    rolled = held @ rot_axis(2, 40.0)
    fitted = fitted_keys(keys, np.broadcast_to(rolled, (frames, 3, 3)), hit)
    times = [t for t, _, _ in fitted]
    assert set(times) <= set(bat_times(keys)) and times
    assert all(abs(t) >= SWING_S and STANCE_S < t < keys[-1][0] - REST_S for t in times)
    for _, d, n in fitted:      # a bat held still is keyed still: its axis and its face as held
        assert np.allclose(d, -rolled[:, 2], atol=1e-4) and np.allclose(n, rolled[:, 1], atol=1e-4)


def test_the_library_grip_has_no_refitted_keys():
    assert all(bat_keys(name, GRIPS["library"]) == [] for name in SHOTS)


@pytest.mark.parametrize("name", sorted(SHOTS))
def test_the_anatomical_grips_refitted_keys_are_bat_keys_of_the_shot(name):
    keys, _ = SHOTS[name]()
    fitted = bat_keys(name, GRIPS["anatomical"])
    for t, d, n in fitted:
        assert t in bat_times(keys) and abs(t) >= SWING_S
        assert abs(np.linalg.norm(d) - 1) < 1e-3 and abs(np.linalg.norm(n) - 1) < 1e-3 and abs(d @ n) < 1e-3
    refit(keys, fitted)


def test_rank_puts_a_missed_bound_before_any_score():
    fine = {"hit_problems": 0, "face_turn": 10.0, "jerk": -1.0, "clamp": 0.0, "score": 500.0}
    jerky = {**fine, "jerk": 0.5, "score": 1.0}
    assert rank(fine) < rank(jerky)
