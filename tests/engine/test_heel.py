"""engine.heel: the heel's lift about the ball of the foot, against a brute-force search."""
import numpy as np

from engine import heel, quat


def _search(axis, to_ankle, from_hip, reach, most, steps=20001):
    """The least turn on a fine grid that brings the ankle within ``reach`` (else the closest)."""
    t = np.linspace(0.0, most, steps)
    ankles = quat.rotate(quat.from_axis_angle(np.broadcast_to(axis, (steps, 3)), t), np.broadcast_to(to_ankle, (steps, 3)))
    dist = np.linalg.norm(from_hip + ankles, axis=-1)
    within = np.flatnonzero(dist <= reach)
    return (t[within[0]] if within.size else t[np.argmin(dist)]), dist


def test_the_closed_form_lift_is_the_least_one_a_search_finds():
    rng = np.random.default_rng(3)
    most = np.radians(heel.HEEL_MAX)
    checked = {"reached": 0, "not": 0}
    for _ in range(300):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        to_ankle = rng.normal(size=3) * 10.0
        from_hip = rng.normal(size=3) * 50.0
        d0 = np.linalg.norm(from_hip + to_ankle)
        reach = d0 * rng.uniform(0.8, 1.0)
        got = heel.least_lift(axis[None], to_ankle[None], from_hip[None], reach, most)[0]
        want, dist = _search(axis, to_ankle, from_hip, reach, most)
        ankle = quat.rotate(quat.from_axis_angle(axis, got), to_ankle)
        if dist.min() <= reach:
            checked["reached"] += 1
            assert abs(got - want) < 2e-4 and np.linalg.norm(from_hip + ankle) <= reach + 1e-6
        else:
            checked["not"] += 1
            assert np.linalg.norm(from_hip + ankle) <= dist.min() + 1e-6
    assert min(checked.values()) > 20          # both cases seen


def test_a_lift_keeps_the_ball_and_raises_the_heel():
    """A flat foot (ball 15 cm ahead of the ankle along +z) with the hip out of reach above
    it: the ball stays put, the ankle rises and comes within reach, the foot pitches toe down
    by the lift; a hip within reach lifts nothing."""
    t_pos = np.array([[0.0, 8.0, 0.0], [0.0, 8.0, 0.0]])
    t_rot = quat.identity((2,))
    ball_offset = np.array([[0.0, -6.0, 15.0], [0.0, -6.0, 15.0]])
    hip = np.array([[0.0, 100.0, 0.0], [0.0, 80.0, 0.0]])
    leg = 88.0
    pos, rot, deg, reached = heel.lift_heels(t_pos, t_rot, ball_offset, hip, leg)
    assert reached.all() and deg[0] > 1.0 and deg[1] == 0.0
    assert np.allclose(pos[0] + quat.rotate(rot[0], [0.0, -6.0, 15.0]), t_pos[0] + ball_offset[0])
    assert pos[0, 1] > t_pos[0, 1] and np.isclose(np.linalg.norm(pos[0] - hip[0]), leg)
    assert np.isclose(quat.angle_between(rot[0], t_rot[0]), deg[0])
    assert np.array_equal(pos[1], t_pos[1]) and np.array_equal(rot[1], t_rot[1])
