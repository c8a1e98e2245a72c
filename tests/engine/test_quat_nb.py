"""Angle ranges of the limits (engine.quat_nb, engine.ccd): a range may pass +-180
(the crossed arm's frontal-plane angle), and a pose on the ZYX gimbal is read in
the split of z and x that its limits allow."""
import math

import numpy as np
import pytest

from engine import ccd, quat
from engine.euler import within
from engine.quat_nb import clamp_angle, into_range, outside, widen_limits

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


@pytest.mark.parametrize("start,lo_deg,hi_deg", [(134.99, -225.01, 90.0),    # a hair below -225: the lower bound
                                                 (95.0, -225.0, 95.0),       # past 90: the upper bound
                                                 (0.0, -225.0, 90.0)])       # inside: unchanged
def test_widening_takes_in_a_start_outside_by_the_near_side(start, lo_deg, hi_deg):
    """A start pose outside its limits may stay there, never go further out: only the
    bound it is nearer on the circle moves (the pull's crossed left arm sat 1e-5 deg below
    -225; widening the far bound to its wrapped +135 let the adaptation turn it 1 deg
    into the gap the limits shut)."""
    lo, hi = np.array([[R(-225.0), -1.0, -1.0]]), np.array([[R(90.0), 1.0, 1.0]])
    e = np.array([[R(start), 0.0, 0.0]])
    out_lo, out_hi = np.empty_like(lo), np.empty_like(hi)
    widen_limits(lo, hi, e, out_lo, out_hi)
    assert np.allclose(np.degrees([out_lo[0, 0], out_hi[0, 0]]), [lo_deg, hi_deg])
    assert out_lo[0, 0] <= e[0, 0] <= out_hi[0, 0]
    assert math.isclose(math.cos(e[0, 0]), math.cos(R(start)), abs_tol=1e-12)
    assert clamp_angle(R(120.0), out_lo[0, 0], out_hi[0, 0]) in (out_lo[0, 0], out_hi[0, 0])

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
