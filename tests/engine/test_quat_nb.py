"""Angle ranges of the limits (engine.quat_nb, engine.ccd): a range may pass +-180
(the crossed arm's frontal-plane angle), and a pose on the ZYX gimbal is read in
the split of z and x that its limits allow."""
import math

import numpy as np
import pytest

from engine import ccd, quat
from engine.euler import within
from engine.quat_nb import clamp_angle, into_range, outside

R = math.radians


@pytest.mark.parametrize("deg,inside", [(170.0, True), (-170.0, True), (130.0, False), (100.0, True), (135.0, True)])
def test_a_range_past_180_holds_the_angles_a_turn_away(deg, inside):
    lo, hi = R(-225.0), R(100.0)                 # [-225, 100]: all but (100, 135) on the circle
    assert (outside(R(deg), lo, hi) == 0.0) == inside
    assert bool(within(np.array(deg), -225.0, 100.0)) == inside
    a = into_range(R(deg), lo, hi)
    if inside:
        assert lo <= a <= hi and math.isclose(math.cos(a), math.cos(R(deg)), abs_tol=1e-12)


def test_clamp_goes_to_the_nearer_bound_on_the_circle():
    lo, hi = R(-225.0), R(90.0)                  # the gap is (90, 135)
    assert math.isclose(clamp_angle(R(100.0), lo, hi), hi)
    assert math.isclose(clamp_angle(R(130.0), lo, hi), lo)        # 130 is 5 from -225 (= 135)
    assert math.isclose(outside(R(130.0), lo, hi), R(5.0))
    assert math.isclose(clamp_angle(R(170.0), lo, hi), R(-190.0))  # inside: a turn away


def test_a_pose_on_the_gimbal_is_read_inside_when_an_equal_split_is():
    """At y = -90 only z + x is the rotation: (137.5, -90, 0) is (90, -90, 47.5)."""
    lim = np.array([[[-180.0, 90.0], [-90.0, 60.0], [-90.0, 90.0]]])
    q = quat.from_euler(np.array([[137.5, -90.0, 0.0]]), "ZYX")
    same = quat.from_euler(np.array([[90.0, -90.0, 47.5]]), "ZYX")
    assert quat.angle_between(q, same).max() < 1e-6
    assert ccd.limit_violation(q, lim).max() < 1e-6
    e = ccd.limit_euler(q, lim)[0]
    assert -180.0 - 1e-6 <= e[0] <= 90.0 + 1e-6 and abs(e[2]) <= 90.0 + 1e-6
    assert abs((e[0] + e[2] - 137.5 + 180.0) % 360.0 - 180.0) < 1e-4
    # off the gimbal the reading is the rotation's own
    q2 = quat.from_euler(np.array([[137.5, -60.0, 0.0]]), "ZYX")
    assert ccd.limit_violation(q2, lim).max() == pytest.approx(42.5, abs=1e-6)   # from -180, round the wrap
