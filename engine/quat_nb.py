"""Scalar rotation helpers for compiled (numba) kernels: quaternions as (w, x, y, z)
tuples and vectors as 3-tuples (no allocation inside numba), ZYX Euler angles in
radians (R = Rz Ry Rx, as ``quat.to_euler(q, "ZYX")``) with the limit clamps and
branch choice the solvers share, and tuple views of flat arrays. The vectorised
numpy counterparts are in :mod:`engine.quat`; these are for the inner loops of
:mod:`engine.ccd`, :mod:`engine.dls`, :mod:`engine.adapt` and :mod:`engine.cleanup`.
"""
from __future__ import annotations

import math

from numba import njit

TINY = 1e-9            # cm: shorter vectors have no direction (a lever this short cannot move the effector)



@njit(cache=True)
def qmul(a, b):
    return (a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


@njit(cache=True)
def qconj(q):
    return (q[0], -q[1], -q[2], -q[3])


@njit(cache=True)
def cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@njit(cache=True)
def dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@njit(cache=True)
def vsub(u, v):
    return (u[0] - v[0], u[1] - v[1], u[2] - v[2])


@njit(cache=True)
def vadd(u, v):
    return (u[0] + v[0], u[1] + v[1], u[2] + v[2])


@njit(cache=True)
def vnorm(u):
    return math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])


@njit(cache=True)
def qrot(q, v):
    """Rotate vector v by unit quaternion q."""
    u = (q[1], q[2], q[3])
    t = cross(u, v)
    t = (2.0 * t[0], 2.0 * t[1], 2.0 * t[2])
    c = cross(u, t)
    return (v[0] + q[0] * t[0] + c[0], v[1] + q[0] * t[1] + c[1], v[2] + q[0] * t[2] + c[2])


@njit(cache=True)
def qnormalize(q):
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n < 1e-300:
        return (1.0, 0.0, 0.0, 0.0)
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@njit(cache=True)
def axis_angle(axis, angle):
    """Unit axis (tuple) and angle (rad) -> quaternion."""
    s = math.sin(0.5 * angle)
    return (math.cos(0.5 * angle), axis[0] * s, axis[1] * s, axis[2] * s)


@njit(cache=True)
def between(u, v):
    """Shortest-arc rotation taking direction u onto v (identity if either is ~0)."""
    nu = vnorm(u)
    nv = vnorm(v)
    if nu < TINY or nv < TINY:
        return (1.0, 0.0, 0.0, 0.0)
    u = (u[0] / nu, u[1] / nu, u[2] / nu)
    v = (v[0] / nv, v[1] / nv, v[2] / nv)
    w = 1.0 + dot(u, v)
    if w < 1e-12:
        # opposite: 180 degrees about any axis perpendicular to u
        alt = (1.0, 0.0, 0.0) if abs(u[0]) < 0.9 else (0.0, 1.0, 0.0)
        p = cross(u, alt)
        return qnormalize((0.0, p[0], p[1], p[2]))
    c = cross(u, v)
    return qnormalize((w, c[0], c[1], c[2]))


@njit(cache=True)
def q_angle(a, b):
    """Rotation angle (rad) between two unit quaternions."""
    r = qmul(qconj(a), b)
    s = math.sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3])
    return 2.0 * math.atan2(s, abs(r[0]))


@njit(cache=True)
def from_euler_zyx(z, y, x):
    """R = Rz(z) Ry(y) Rx(x), radians -> quaternion."""
    cz, sz = math.cos(0.5 * z), math.sin(0.5 * z)
    cy, sy = math.cos(0.5 * y), math.sin(0.5 * y)
    cx, sx = math.cos(0.5 * x), math.sin(0.5 * x)
    # (cz + sz k)(cy + sy j)(cx + sx i)
    w = cz * cy * cx + sz * sy * sx
    qx = cz * cy * sx - sz * sy * cx
    qy = cz * sy * cx + sz * cy * sx
    qz = sz * cy * cx - cz * sy * sx
    return (w, qx, qy, qz)


@njit(cache=True)
def to_euler_zyx(q):
    """Quaternion -> (z, y, x) radians, the same branch as ``quat.to_euler(q, "ZYX")``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    m00 = 1.0 - 2.0 * (y * y + z * z)
    m10 = 2.0 * (x * y + w * z)
    m20 = 2.0 * (x * z - w * y)
    m21 = 2.0 * (y * z + w * x)
    m22 = 1.0 - 2.0 * (x * x + y * y)
    sb = min(1.0, max(-1.0, -m20))
    b = math.atan2(sb, math.hypot(m22, m21))
    if abs(sb) > 1.0 - 1e-10:
        m01 = 2.0 * (x * y - w * z)
        m11 = 1.0 - 2.0 * (x * x + z * z)
        return (math.atan2(-m01, m11), b, 0.0)
    return (math.atan2(m10, m00), b, math.atan2(m21, m22))


@njit(cache=True)
def wrap(a):
    """Angle into (-pi, pi]."""
    if -math.pi < a <= math.pi:
        return a
    a = (a + math.pi) % (2.0 * math.pi)      # in [0, 2 pi)
    if a == 0.0:
        return math.pi
    return a - math.pi


@njit(cache=True)
def into_range(a, lo, hi):
    """``a`` turned by a whole turn into [lo, hi] where that fits (a range may run
    past +-180, e.g. [-225, 90] deg: a crossed arm's frontal-plane angle wraps
    there), else ``a`` wrapped into (-pi, pi]."""
    if lo <= a <= hi:
        return a
    a = wrap(a)
    if a > hi and lo <= a - 2.0 * math.pi:
        return a - 2.0 * math.pi
    if a < lo and a + 2.0 * math.pi <= hi:
        return a + 2.0 * math.pi
    return a


@njit(cache=True)
def clamp_angle(a, lo, hi):
    """Clamp an angle to [lo, hi] going to the bound that is nearer on the circle
    (a turn just past +180 must not jump to the far lower limit)."""
    a = into_range(a, lo, hi)
    if lo <= a <= hi:
        return a
    if abs(wrap(lo - a)) < abs(wrap(a - hi)):
        return lo
    return hi


@njit(cache=True)
def other_branch(e):
    """The second Euler triple of the same rotation: (z + pi, pi - y, x + pi)."""
    return (wrap(e[0] + math.pi), wrap(math.pi - e[1]), wrap(e[2] + math.pi))


@njit(cache=True)
def outside(a, lo, hi):
    """How far (rad) angle a lies outside [lo, hi] on the circle (0 inside)."""
    a = into_range(a, lo, hi)
    if lo <= a <= hi:
        return 0.0
    return min(abs(wrap(lo - a)), abs(wrap(a - hi)))


@njit(cache=True)
def narrow_limits(lo, hi, centre, reach):
    """The limits ``lo/hi (n,3)`` radians, in place, brought within ``reach (n,)`` radians of
    ``centre (n,3)`` (inside them: :func:`widen_limits` first) on every axis of each joint."""
    for j in range(lo.shape[0]):
        for c in range(3):
            lo[j, c] = max(lo[j, c], centre[j, c] - reach[j])
            hi[j, c] = min(hi[j, c], centre[j, c] + reach[j])


@njit(cache=True)
def widen_limits(lo, hi, euler, out_lo, out_hi):
    """The limits ``lo/hi (n,3)`` radians widened to take in the start angles ``euler
    (n,3)``: a pose already outside its limits may stay there or move back in, never
    further out. An angle outside is first unwrapped, in place, to the side of the
    limits it is nearer on the circle (as :func:`outside` measures it): a crossed arm a
    hair below -225 deg of [-225, 90] reads +135 once wrapped, and taking that in as the
    upper bound would open the 45 deg the limits shut."""
    for k in range(lo.shape[0]):
        for c in range(3):
            a = into_range(euler[k, c], lo[k, c], hi[k, c])
            if a > hi[k, c]:
                d = (lo[k, c] - a) % (2.0 * math.pi)       # below lo going down
                if d < a - hi[k, c]:
                    a = lo[k, c] - d
            elif a < lo[k, c]:
                d = (a - hi[k, c]) % (2.0 * math.pi)       # above hi going up
                if d < lo[k, c] - a:
                    a = hi[k, c] + d
            euler[k, c] = a
            out_lo[k, c] = min(lo[k, c], a)
            out_hi[k, c] = max(hi[k, c], a)


@njit(cache=True)
def pick_branch(e, euler, src_euler, free, lo, hi, k):
    """Of the two Euler triples of one rotation, the one that keeps the locked
    columns nearest their source values and the free ones inside the limits;
    on a tie the one nearest the joint's current angles. A ZYX middle angle is
    only ever in [-90, 90] degrees, so an elbow bent past 90 needs the other
    branch."""
    e2 = other_branch(e)
    s1 = 0.0
    s2 = 0.0
    d1 = 0.0
    d2 = 0.0
    for c in range(3):
        if free[k, c]:
            s1 += outside(e[c], lo[k, c], hi[k, c])
            s2 += outside(e2[c], lo[k, c], hi[k, c])
        else:
            s1 += abs(wrap(e[c] - src_euler[k, c]))
            s2 += abs(wrap(e2[c] - src_euler[k, c]))
        d1 += abs(wrap(e[c] - euler[k, c]))
        d2 += abs(wrap(e2[c] - euler[k, c]))
    if s2 < s1 - 1e-12 or (abs(s2 - s1) <= 1e-12 and d2 < d1):
        return e2
    return e


@njit(cache=True)
def q_at(arr, k):
    return (arr[k, 0], arr[k, 1], arr[k, 2], arr[k, 3])


@njit(cache=True)
def v_at(arr, k):
    return (arr[k, 0], arr[k, 1], arr[k, 2])


@njit(cache=True)
def q_put(arr, k, q):
    arr[k, 0] = q[0]
    arr[k, 1] = q[1]
    arr[k, 2] = q[2]
    arr[k, 3] = q[3]


@njit(cache=True)
def v_put(arr, k, v):
    arr[k, 0] = v[0]
    arr[k, 1] = v[1]
    arr[k, 2] = v[2]
