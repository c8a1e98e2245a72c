"""The carried lean's start pose, compiled (engine.carry.carried_start calls it once per
whole-shot solve): written with numpy's quaternion helpers it cost 0.8 ms a call on this
machine, as much as solving the square cut's blended frames."""
from __future__ import annotations

import math

from numba import njit

from .ccd import limit_euler_one
from .quat_nb import axis_angle, from_euler_zyx, q_at, qmul


@njit(cache=True)
def _axis_and_angle(q):
    """A rotation (tuple) as a unit axis and an angle in [0, pi] (the shorter arc)."""
    sg = 1.0 if q[0] >= 0.0 else -1.0
    x, y, z = sg * q[1], sg * q[2], sg * q[3]
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return (1.0, 0.0, 0.0), 0.0
    return (x / s, y / s, z / s), 2.0 * math.atan2(s, abs(q[0]))


@njit(cache=True)
def _bounded(angle, lo, hi, start):
    """A free axis (lo < hi) clamped into its limits; a locked one keeps the start's angle."""
    return min(max(angle, lo), hi) if lo < hi else start


@njit(cache=True)
def carry_trunk(start_local, start_euler, disp, blend, rows, trunk, lo, hi, local_out, euler_out):
    """For each frame of ``rows`` and each ``trunk`` joint j: the start's rotation turned by
    ``blend[frame]`` of the displacement ``disp[k]`` (along the shorter arc, as a slerp from
    the identity), read in the Euler branch that fits ``lo``/``hi (J, 3)`` radians, its free
    axes clamped into them and its locked axes the start's; written to ``local_out (F, J, 4)``
    and ``euler_out (F, J, 3)`` radians (the other entries left as they are)."""
    for k in range(trunk.shape[0]):
        j = trunk[k]
        axis, angle = _axis_and_angle(q_at(disp, k))
        for r in rows:
            q = qmul(axis_angle(axis, blend[r] * angle), q_at(start_local[r], j))
            z, y, x = limit_euler_one(q, lo[j], hi[j])
            z = _bounded(z, lo[j, 0], hi[j, 0], start_euler[r, j, 0])
            y = _bounded(y, lo[j, 1], hi[j, 1], start_euler[r, j, 1])
            x = _bounded(x, lo[j, 2], hi[j, 2], start_euler[r, j, 2])
            euler_out[r, j, 0], euler_out[r, j, 1], euler_out[r, j, 2] = z, y, x
            out = from_euler_zyx(z, y, x)
            for c in range(4):
                local_out[r, j, c] = out[c]
