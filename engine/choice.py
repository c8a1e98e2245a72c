"""Shot choice from the ball's line (dissertation 2.5.1).

The ball travels in a straight line from a fixed start point to the user's
target (as in the dissertation, the bounce is not modelled before the hit).
The source shot is the one whose FK hit point lies nearest that line; the
desired hit point is the point of the line nearest that FK hit point.
"""
from __future__ import annotations

import numpy as np

# The bowler's release: 18.3 m up the pitch from the batting stumps (popping
# crease at the bowling end is 1890 cm from them), a little off-centre, 2 m up.
BALL_START = np.array([0.0, 200.0, 1800.0])


def _finite3(p, what: str) -> np.ndarray:
    a = np.asarray(p, float).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"{what} must be three numbers (x, y, z) in cm")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be finite numbers, got {a.tolist()}")
    return a


def closest_on_line(points, start, target) -> np.ndarray:
    """Points ``(N,3)`` of the line through start and target nearest each point.

    The whole line, not the segment: the bat meets the ball wherever the line
    passes the batsman, even if the target is drawn in front of him."""
    d = target - start
    dd = float(d @ d)
    if dd < 1e-12:
        raise ValueError("target coincides with the ball's start point")
    t = (np.asarray(points, float) - start) @ d / dd
    return start + t[..., None] * d


def choose_shot(hit_points, ball_start, target) -> tuple[int, np.ndarray]:
    """(index of the shot whose FK hit point ``hit_points (N,3)`` lies nearest
    the line ball_start -> target, desired hit point (3,) on that line)."""
    s = _finite3(ball_start, "ball start")
    t = _finite3(target, "target")
    hp = np.asarray(hit_points, float).reshape(-1, 3)
    if len(hp) == 0:
        raise ValueError("no shots to choose from")
    near = closest_on_line(hp, s, t)
    dist = np.linalg.norm(near - hp, axis=-1)
    i = int(np.argmin(dist))
    return i, near[i]
