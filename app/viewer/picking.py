"""Mouse picking: pixel -> world ray, ray-plane intersection, world -> pixel.

Pixels are window coordinates (origin top-left, y down), as glfw reports the
cursor; ``viewport`` is ``(x, y, w, h)`` of the 3D view in those coordinates.
"""
from __future__ import annotations

import numpy as np

TARGET_PLANE_Z = -60.0        # the target slides on the vertical plane z = -60 (behind the stumps)
TARGET_NORMAL = (0.0, 0.0, 1.0)
TARGET_RADIUS = 30.0          # cm, the red-and-white disc's radius (app.render.props.target_disc)
# The target stays within a sane box so nothing downstream sees huge numbers.
TARGET_BOUNDS = np.array([[-400.0, 400.0], [-20.0, 400.0]])  # rows x, y: [lo, hi]


def pixel_ray(px: float, py: float, viewport, view: np.ndarray, proj: np.ndarray):
    """World ray ``(origin (3,), unit direction (3,))`` through a window pixel."""
    x, y, w, h = viewport
    ndc = np.array([2.0 * (px - x) / max(w, 1) - 1.0, 1.0 - 2.0 * (py - y) / max(h, 1)])
    inv = np.linalg.inv(proj.astype(float) @ view.astype(float))
    near = inv @ np.array([ndc[0], ndc[1], -1.0, 1.0])
    far = inv @ np.array([ndc[0], ndc[1], 1.0, 1.0])
    near, far = near[:3] / near[3], far[:3] / far[3]
    d = far - near
    return near, d / np.linalg.norm(d)


def ray_plane(origin, direction, plane_point, plane_normal):
    """Intersection point ``(3,)`` of a ray with a plane, or ``None`` (parallel or behind)."""
    n = np.asarray(plane_normal, float)
    denom = float(np.dot(direction, n))
    if abs(denom) < 1e-6:
        return None
    t = float(np.dot(np.asarray(plane_point, float) - origin, n)) / denom
    if not np.isfinite(t) or t <= 0:
        return None
    return origin + t * np.asarray(direction, float)


def target_plane_hit(px, py, viewport, view, proj):
    """Where the pixel's ray meets the target plane, or ``None``."""
    o, d = pixel_ray(px, py, viewport, view, proj)
    return ray_plane(o, d, (0.0, 0.0, TARGET_PLANE_Z), TARGET_NORMAL)


def hits_target(px, py, viewport, view, proj, target, radius: float = TARGET_RADIUS) -> bool:
    """Is the pixel over the target disc (ray meets the plane within ``radius``)?"""
    p = target_plane_hit(px, py, viewport, view, proj)
    return p is not None and float(np.linalg.norm(p - np.asarray(target, float))) <= radius


def clamp_target(p) -> np.ndarray:
    """Keep a target on its plane and inside ``TARGET_BOUNDS``."""
    p = np.asarray(p, float).copy()
    for axis in (0, 1):         # scalar clamps: np.clip per scalar costs ~10x (every frame)
        lo, hi = TARGET_BOUNDS[axis]
        p[axis] = min(max(p[axis], lo), hi)
    p[2] = TARGET_PLANE_Z
    return p


def project(points, viewport, view, proj) -> np.ndarray:
    """Window pixels ``(..., 2)`` of world points ``(..., 3)`` (NaN behind the camera)."""
    p = np.asarray(points, float)
    hom = np.concatenate([p, np.ones(p.shape[:-1] + (1,))], axis=-1)
    clip = hom @ (proj.astype(float) @ view.astype(float)).T
    w = clip[..., 3:4]
    ndc = np.where(w > 1e-9, clip[..., :2] / np.where(w > 1e-9, w, 1.0), np.nan)
    x, y, vw, vh = viewport
    return np.stack([x + (ndc[..., 0] + 1) / 2 * vw, y + (1 - ndc[..., 1]) / 2 * vh], axis=-1)
