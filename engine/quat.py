"""Batched quaternion maths on ``(..., 4)`` arrays, order (w, x, y, z).

All functions broadcast over leading axes. Rotations act on column vectors:
``rotate(q, v) == to_matrix(q) @ v``. Euler angles are in degrees and follow
the BVH convention: for the channel order "ZYX" the rotation is
``Rz(z) @ Ry(y) @ Rx(x)`` (the first channel is the outermost rotation).
"""
from __future__ import annotations

import numpy as np

_AXES = {"X": 0, "Y": 1, "Z": 2}


def identity(shape=()) -> np.ndarray:
    """Identity quaternions of shape ``shape + (4,)``."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 0] = 1.0
    return q


def normalize(q: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """Unit quaternions; a zero quaternion becomes the identity."""
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    out = q / np.maximum(n, eps)
    bad = n[..., 0] < eps
    if np.any(bad):
        out[bad] = (1.0, 0.0, 0.0, 0.0)
    return out


def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` (apply b first, then a)."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, float), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, float), -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def conjugate(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def inverse(q: np.ndarray) -> np.ndarray:
    """Inverse of (not necessarily unit) quaternions."""
    q = np.asarray(q, float)
    return conjugate(q) / np.sum(q * q, axis=-1, keepdims=True)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of ``a (..., 3)`` and ``b (..., 3)`` (broadcast). Written out
    because ``np.cross`` moves axes and costs ~10x this on the small arrays of a frame."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)``."""
    q = np.asarray(q, float)
    v = np.asarray(v, float)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * cross(u, v)
    return v + w * t + cross(u, t)


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` -> rotation matrices ``(..., 3, 3)``."""
    w, x, y, z = np.moveaxis(np.asarray(q, float), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=-2)


def from_matrix(m: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` -> unit quaternions with w >= 0."""
    m = np.asarray(m, float)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    # Shepperd's method: pick the largest of w, x, y, z to divide by.
    cands = np.stack([
        1 + m00 + m11 + m22, 1 + m00 - m11 - m22,
        1 - m00 + m11 - m22, 1 - m00 - m11 + m22], -1)
    best = np.argmax(cands, axis=-1)
    q = np.empty(m.shape[:-2] + (4,))
    s = np.sqrt(np.maximum(np.take_along_axis(cands, best[..., None], -1)[..., 0], 1e-300)) * 2
    r = [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]]
    p = [m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1]]
    rows = [
        np.stack([s / 4, r[0] / s, r[1] / s, r[2] / s], -1),
        np.stack([r[0] / s, s / 4, p[0] / s, p[1] / s], -1),
        np.stack([r[1] / s, p[0] / s, s / 4, p[2] / s], -1),
        np.stack([r[2] / s, p[1] / s, p[2] / s, s / 4], -1),
    ]
    for k in range(4):
        sel = best == k
        q[sel] = rows[k][sel]
    q = np.where(q[..., :1] < 0, -q, q)
    return normalize(q)


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Axis ``(..., 3)`` (need not be unit) and angle in radians ``(...)``."""
    axis = np.asarray(axis, float)
    angle = np.asarray(angle, float)
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    axis = axis / np.maximum(n, 1e-12)
    h = angle[..., None] / 2
    return np.concatenate([np.cos(h), np.sin(h) * axis], axis=-1)


def _axis_quat(axis_index: int, degrees: np.ndarray) -> np.ndarray:
    h = np.radians(np.asarray(degrees, float)) / 2
    q = np.zeros(h.shape + (4,))
    q[..., 0] = np.cos(h)
    q[..., 1 + axis_index] = np.sin(h)
    return q


def from_euler(degrees: np.ndarray, order: str = "ZYX") -> np.ndarray:
    """Euler angles ``(..., 3)`` in degrees, listed in ``order`` -> quaternions.

    ``degrees[..., k]`` is the angle about axis ``order[k]``, and the rotation
    is ``R_order[0] @ R_order[1] @ R_order[2]`` (BVH channel semantics).
    """
    degrees = np.asarray(degrees, float)
    order = order.upper()
    q = _axis_quat(_AXES[order[0]], degrees[..., 0])
    for k in (1, 2):
        q = mul(q, _axis_quat(_AXES[order[k]], degrees[..., k]))
    return q


def to_euler(q: np.ndarray, order: str = "ZYX") -> np.ndarray:
    """Quaternions -> Euler angles ``(..., 3)`` in degrees in ``order``.

    Inverse of :func:`from_euler` for any of the six Tait-Bryan orders; the
    middle angle lies in [-90, 90].
    """
    order = order.upper()
    i, j, k = (_AXES[c] for c in order)
    m = to_matrix(q)
    # R = R_i(a) R_j(b) R_k(c); sign of the permutation decides the signs.
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    sb = np.clip(sign * m[..., i, k], -1.0, 1.0)
    # atan2 keeps full precision near +/-90 degrees, where arcsin does not.
    b = np.arctan2(sb, np.hypot(m[..., i, i], m[..., i, j]))
    a = np.arctan2(-sign * m[..., j, k], m[..., k, k])
    c = np.arctan2(-sign * m[..., i, j], m[..., i, i])
    # Gimbal lock: only a +/- c is defined; put it all into a.
    lock = np.abs(sb) > 1 - 1e-10
    if np.any(lock):
        a_l = np.arctan2(sign * m[..., k, j], m[..., j, j])
        a = np.where(lock, a_l, a)
        c = np.where(lock, 0.0, c)
    return np.degrees(np.stack([a, b, c], axis=-1))


def slerp(a: np.ndarray, b: np.ndarray, t) -> np.ndarray:
    """Spherical interpolation along the shorter arc; ``t`` broadcasts as ``(...)``."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    t = np.asarray(t, float)[..., None]
    d = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(d < 0, -b, b)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    s = np.sin(theta)
    small = s < 1e-8
    safe = np.where(small, 1.0, s)
    wa = np.where(small, 1 - t, np.sin((1 - t) * theta) / safe)
    wb = np.where(small, t, np.sin(t * theta) / safe)
    return normalize(wa * a + wb * b)


def between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc rotation taking direction ``u`` onto ``v`` (both ``(..., 3)``).

    Opposite vectors rotate by 180 degrees about an axis perpendicular to u;
    a zero vector gives the identity.
    """
    u = np.asarray(u, float)
    v = np.asarray(v, float)
    nu = np.linalg.norm(u, axis=-1, keepdims=True)
    nv = np.linalg.norm(v, axis=-1, keepdims=True)
    u = u / np.maximum(nu, 1e-12)
    v = v / np.maximum(nv, 1e-12)
    w = 1.0 + np.sum(u * v, axis=-1, keepdims=True)
    xyz = cross(u, v)
    opposite = w[..., 0] < 1e-9
    if np.any(opposite):
        # any axis perpendicular to u
        alt = np.where(np.abs(u[..., :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
        perp = cross(u, alt)
        xyz = np.where(opposite[..., None], perp, xyz)
        w = np.where(opposite[..., None], 0.0, w)
    q = normalize(np.concatenate([w, xyz], axis=-1))
    degenerate = (nu[..., 0] < 1e-12) | (nv[..., 0] < 1e-12)
    if np.any(degenerate):
        q[degenerate] = (1.0, 0.0, 0.0, 0.0)
    return q


def log(q: np.ndarray) -> np.ndarray:
    """Unit quaternions -> rotation vectors ``(..., 3)`` (axis * angle, radians)."""
    q = np.asarray(q, float)
    q = np.where(q[..., :1] < 0, -q, q)
    xyz = q[..., 1:]
    s = np.linalg.norm(xyz, axis=-1, keepdims=True)
    angle = 2 * np.arctan2(s, q[..., :1])
    scale = np.where(s < 1e-12, 2.0, angle / np.maximum(s, 1e-12))
    return xyz * scale


def exp(r: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` -> unit quaternions (inverse of :func:`log`)."""
    r = np.asarray(r, float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    h = angle / 2
    sinc = np.where(angle < 1e-12, 0.5, np.sin(h) / np.maximum(angle, 1e-12))
    return np.concatenate([np.cos(h), r * sinc], axis=-1)


def make_continuous(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` (time) so consecutive quaternions agree (dot >= 0)."""
    q = np.moveaxis(np.array(q, float, copy=True), axis, 0)
    if q.shape[0] > 1:
        step = np.where(np.sum(q[1:] * q[:-1], axis=-1) < 0, -1.0, 1.0)
        q[1:] *= np.cumprod(step, axis=0)[..., None]
    return np.moveaxis(q, 0, axis)


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle in degrees between two orientations ``(..., 4)``."""
    rel = mul(conjugate(normalize(a)), normalize(b))
    # atan2 of the relative rotation stays exact for tiny angles (arccos does not)
    return np.degrees(2 * np.arctan2(np.linalg.norm(rel[..., 1:], axis=-1), np.abs(rel[..., 0])))
