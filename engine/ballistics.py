"""The ball before and after the hit.

Before: a straight line from the start point, timed to reach the desired hit
point exactly at the hit frame (2.5.1). After (2.3.2, done better): the ball
leaves the bat by a collision with the bat face — face normal, the incoming
velocity and the bat's own velocity at impact (finite difference of the Bat
joint) — then flies under gravity and bounces on the ground with restitution.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import quat

BALL_SPEED = 3000.0      # cm/s incoming (108 km/h, a medium-pace delivery)
GRAVITY = 981.0          # cm/s^2
RESTITUTION_BAT = 0.5    # along the face normal, ball on a bat
RESTITUTION_GROUND = 0.5  # vertical, ball on turf
FRICTION_GROUND = 0.7    # horizontal speed kept at each bounce
TANGENT_KEEP = 0.8       # share of the along-face relative velocity kept (spin, friction)


def _finite(a, what: str, n: int = 3) -> np.ndarray:
    a = np.asarray(a, float).reshape(-1)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be {n} finite numbers")
    return a


def incoming_ball(ball_start, desired_hit_point, hit_frame: int, frame, fps: float,
                  speed: float = BALL_SPEED) -> np.ndarray:
    """Ball position ``(3,)`` (or ``(K,3)`` for an array of frames) on the straight
    line start -> hit point, at the hit point exactly at the hit frame. Before
    release it waits at the start; after the hit frame it keeps going (the
    caller switches to :func:`ball_after_impact`)."""
    s = _finite(ball_start, "ball start")
    p = _finite(desired_hit_point, "desired hit point")
    d = p - s
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        return np.broadcast_to(p, np.shape(frame) + (3,)).copy()
    t = (np.asarray(frame, float) - hit_frame) / float(fps)     # s, 0 at the hit
    travelled = np.maximum(length + speed * t, 0.0)
    return s + (travelled / length)[..., None] * d if np.ndim(t) else s + travelled / length * d


def outgoing_velocity(face_normal, ball_velocity, bat_velocity,
                      e_bat: float = RESTITUTION_BAT, tangent_keep: float = TANGENT_KEEP) -> np.ndarray:
    """Ball velocity after the impact (cm/s), in the bat's rest frame a
    collision with a heavy plane: the normal part reverses with restitution,
    the tangential part is kept in part."""
    n = np.asarray(face_normal, float)
    n = n / np.linalg.norm(n)
    rel = np.asarray(ball_velocity, float) - np.asarray(bat_velocity, float)
    vn = float(rel @ n)
    if vn > 0:          # ball already moving away from the face: hit the other side
        n = -n
        vn = -vn
    rel_t = rel - vn * n
    return np.asarray(bat_velocity, float) + tangent_keep * rel_t - e_bat * vn * n


def fly(position, velocity, duration: float = 3.0, dt: float = 1 / 120,
        e_ground: float = RESTITUTION_GROUND, friction: float = FRICTION_GROUND,
        radius: float = 3.6) -> np.ndarray:
    """Polyline ``(K,3)`` of a ball under gravity bouncing on the ground (y = radius),
    sampled every ``dt`` seconds. Each flight between bounces is a closed-form
    parabola: a scalar loop over bounces finds where each starts, one compiled pass
    samples them all; once a bounce is too small to see, the ball rolls on."""
    count = int(np.ceil(duration / dt)) + 1
    starts, origins, velocities, airborne = _bounces(position, velocity, duration, e_ground, friction, radius)
    return _sample_pieces(starts, origins, velocities, airborne, float(dt), count, float(radius), GRAVITY)


@njit(cache=True)
def _sample_pieces(starts, origins, velocities, airborne, dt, count, radius, gravity):
    """``count`` samples ``(K,3)`` every ``dt`` s of the pieces from ``_bounces``.
    Compiled: it runs on every solve while the target is dragged."""
    out = np.empty((count, 3))
    seg = 0
    for k in range(count):
        t = k * dt
        while seg + 1 < starts.shape[0] and starts[seg + 1] <= t:    # the piece this sample is on
            seg += 1
        tt = t - starts[seg]
        for c in range(3):
            out[k, c] = origins[seg, c] + tt * velocities[seg, c]
        out[k, 1] = out[k, 1] - 0.5 * gravity * tt * tt if airborne[seg] else radius
    return out


def _bounces(position, velocity, duration, e_ground, friction, radius):
    """Start time ``(B,)``, start point ``(B,3)``, start velocity ``(B,3)`` of each piece
    of the flight, and whether it is a parabola ``(B,)`` (else rolling or at rest)."""
    p = [float(x) for x in position]
    v = [float(x) for x in velocity]
    p[1] = max(p[1], radius)
    starts, origins, velocities, airborne = [], [], [], []
    t0 = 0.0
    for _ in range(64):
        height = p[1] - radius
        t_land = (v[1] + math.sqrt(max(v[1] * v[1] + 2 * GRAVITY * height, 0.0))) / GRAVITY
        starts.append(t0)
        origins.append(list(p))
        if t_land < 1e-3:                       # too small to see: rolls on along the ground
            velocities.append([v[0], 0.0, v[2]])
            airborne.append(False)
            break
        velocities.append(list(v))
        airborne.append(True)
        p = [p[0] + t_land * v[0], radius, p[2] + t_land * v[2]]
        v = [v[0] * friction, -(v[1] - GRAVITY * t_land) * e_ground, v[2] * friction]
        t0 += t_land
        if t0 > duration:
            break
    else:                                       # out of bounces: it rests where it landed
        starts.append(t0)
        origins.append(list(p))
        velocities.append([0.0, 0.0, 0.0])
        airborne.append(False)
    return np.array(starts), np.array(origins), np.array(velocities), np.array(airborne)


def ball_after_impact(global_rotations, global_positions, bat_joint: int, hand_joint: int,
                      face_normal_local, hit_frame: int, fps: float, ball_start, hit_point,
                      speed: float = BALL_SPEED, duration: float = 3.0) -> np.ndarray:
    """Trajectory ``(K,3)`` of the ball after the hit.

    global_rotations (F,J,4), global_positions (F,J,3): the (adapted) shot;
    the face normal is ``face_normal_local`` in the hand joint's frame; the
    bat's velocity is the central difference of the bat joint at the hit frame.
    """
    s = _finite(ball_start, "ball start")
    p = _finite(hit_point, "hit point")
    F = global_positions.shape[0]
    a, b = max(hit_frame - 1, 0), min(hit_frame + 1, F - 1)
    bat_v = (global_positions[b, bat_joint] - global_positions[a, bat_joint]) * fps / max(b - a, 1)
    n = quat.rotate(global_rotations[hit_frame, hand_joint], np.asarray(face_normal_local, float))
    d = p - s
    ball_v = speed * d / max(np.linalg.norm(d), 1e-9)
    v = outgoing_velocity(n, ball_v, bat_v)
    return fly(p, v, duration)
