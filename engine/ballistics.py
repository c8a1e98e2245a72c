"""The ball before and after the hit.

Before: a straight line from the start point, timed to reach the desired hit
point exactly at the hit frame (2.5.1). After (2.3.2, done better): the ball
leaves the bat by a collision with the bat face — face normal, the incoming
velocity and the bat's own velocity at impact (finite difference of the Bat
joint) — then flies under gravity and bounces on the ground with restitution.

The ball meets the surface that is really there (no silent flip): the face
when the face looks at the incoming ball (engine.face.face_to_ball >= EDGE_COS),
the back of the bat when it looks away, the rounded edge in between; the
:class:`Flight` says which (``contact``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from . import face, quat

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


def outgoing_velocity(normal, ball_velocity, bat_velocity,
                      e_bat: float = RESTITUTION_BAT, tangent_keep: float = TANGENT_KEEP) -> np.ndarray:
    """Ball velocity after the impact (cm/s), in the bat's rest frame a
    collision with a heavy surface of outward ``normal`` (the face, the back or
    the edge the ball meets): the normal part reverses with restitution, the
    tangential part is kept in part. A ball that does not approach the surface
    (the bat runs away from it) keeps its velocity: there is no collision."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    rel = np.asarray(ball_velocity, float) - np.asarray(bat_velocity, float)
    vn = float(rel @ n)
    if vn >= 0:
        return np.asarray(ball_velocity, float).copy()
    rel_t = rel - vn * n
    return np.asarray(bat_velocity, float) + tangent_keep * rel_t - e_bat * vn * n


def contact_normal(face_n, toward, kind: str, bat_axis=None) -> np.ndarray:
    """Outward normal of the surface the ball meets: the face normal, its
    opposite for the back, and for the edge the rounded edge's normal facing the
    ball (``toward`` without its part along the bat's axis; ``toward`` itself
    when the axis is not given)."""
    n = np.asarray(face_n, float)
    if kind == "face":
        return n
    if kind == "back":
        return -n
    t = np.asarray(toward, float)
    if bat_axis is not None:
        a = np.asarray(bat_axis, float)
        a = a / np.linalg.norm(a)
        e = t - (t @ a) * a
        if np.linalg.norm(e) > 1e-9:
            t = e
    return t / np.linalg.norm(t)


FLY_DT = 1.0 / 120.0     # s between the samples of a flight (fly's default)


def fly(position, velocity, duration: float = 3.0, dt: float = FLY_DT,
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


@dataclass
class Flight:
    """The ball after the hit."""
    path: np.ndarray          # (K,3) polyline, every 1/120 s
    velocity: np.ndarray      # (3,) cm/s just after the impact
    contact: str              # "face" | "edge" | "back": what the ball met; "none": the ball was left
    face_to_ball: float       # cosine between the face normal and the direction toward the ball
    face_normal: np.ndarray   # (3,) world face normal at the hit frame
    bat_velocity: np.ndarray  # (3,) cm/s, central difference of the bat joint
    azimuth_deg: float        # of ``velocity``, DESIGN.md's convention
    elevation_deg: float


def ball_at_frame(ball_start, hit_point, hit_frame: int, fps: float, flight_path, flight_dt: float,
                  frame: float) -> np.ndarray:
    """The ball ``(3,)`` at a (fractional) frame of a shot: on its way in until the hit frame,
    then along ``flight_path (K, 3)`` (samples ``flight_dt`` s apart; None or empty: it
    keeps coming in)."""
    if frame <= hit_frame or flight_path is None or len(flight_path) == 0:
        return np.asarray(incoming_ball(ball_start, hit_point, hit_frame, min(frame, hit_frame), fps), float)
    s = (frame - hit_frame) / fps / max(flight_dt, 1e-6)
    k = int(np.clip(np.floor(s), 0, len(flight_path) - 1))
    k1, a = min(k + 1, len(flight_path) - 1), float(np.clip(s - k, 0, 1))
    return (1 - a) * flight_path[k] + a * flight_path[k1]


def bat_velocities(global_positions, joint: int, fps: float) -> np.ndarray:
    """Velocity (cm/s) of ``joint`` at every frame ``(F, 3)``: central differences, one-sided
    at the ends; zero for a single frame."""
    p = np.asarray(global_positions, float)[:, joint]
    return np.gradient(p, axis=0) * fps if len(p) > 1 else np.zeros_like(p)


def bat_velocity(global_positions, joint: int, frame: int, fps: float) -> np.ndarray:
    """Velocity (cm/s) of ``joint`` at ``frame`` (:func:`bat_velocities`)."""
    F = global_positions.shape[0]
    a, b = max(frame - 1, 0), min(frame + 2, F)
    return bat_velocities(global_positions[a:b], joint, fps)[frame - a]


def impact(normal, ball_start, hit_point, bat_v, bat_axis=None, speed: float = BALL_SPEED,
           edge_cos: float = face.EDGE_COS) -> tuple[np.ndarray, str, float]:
    """(velocity after the impact (3,), contact, face_to_ball) for a ball from
    ``ball_start`` meeting a bat of world face ``normal`` at ``hit_point``."""
    s = _finite(ball_start, "ball start")
    p = _finite(hit_point, "hit point")
    toward = face.toward_ball(s, p)
    cos = float(face.face_to_ball(normal, s, p))
    kind = face.contact(cos, edge_cos)
    ball_v = -speed * toward
    v = outgoing_velocity(contact_normal(normal, toward, kind, bat_axis), ball_v, bat_v)
    return v, kind, cos


def flight(global_rotations, global_positions, bat_joint: int, face_normal_local, hit_frame: int,
           fps: float, ball_start, hit_point, bat_axis_local=None, speed: float = BALL_SPEED,
           duration: float = 3.0) -> Flight:
    """The ball after the hit of a shot ``(F,J,4)``, ``(F,J,3)``: the face normal
    is ``face_normal_local`` and the bat's axis ``bat_axis_local`` in the bat
    joint's frame; the bat's velocity the central difference of the bat joint."""
    grot = np.asarray(global_rotations, float)
    n = face.face_normal(grot[hit_frame], bat_joint, face_normal_local)
    axis = None if bat_axis_local is None else quat.rotate(grot[hit_frame, bat_joint],
                                                           np.asarray(bat_axis_local, float))
    bat_v = bat_velocity(np.asarray(global_positions, float), bat_joint, hit_frame, fps)
    v, kind, cos = impact(n, ball_start, hit_point, bat_v, axis, speed)
    p = _finite(hit_point, "hit point")
    return Flight(fly(p, v, duration), v, kind, cos, n, bat_v,
                  float(face.azimuth_deg(v)), float(face.elevation_deg(v)))


def shot_flight(rig, shot, global_rotations, global_positions, ball_start, hit_point,
                duration: float = 3.0, hit_frame: int | None = None) -> tuple[Flight, float]:
    """The ball after the hit of an adapted ``shot`` on ``rig`` (its bat's face normal and
    axis, the shot's hit frame and rate), and the angle (deg) of the bat face at the hit
    frame against the source's at its own: what the viewer, ``adapt``'s JSON and the
    direction search all report. ``hit_frame``: the motion's own (a synthesised take's),
    when it is not the shot's."""
    bat, normal = rig.bat_joint, rig.bat["face_normal"]
    h = shot.hit_frame if hit_frame is None else int(hit_frame)
    fl = flight(global_rotations, global_positions, bat, normal, h, shot.clip.fps, ball_start, hit_point,
                rig.bat.get("axis"), duration=duration)
    angle = face.face_angle_deg(np.asarray(global_rotations)[h], shot.fk[0][shot.hit_frame], bat, normal)
    return fl, float(angle)


def passing_flight(ball_start, hit_point, speed: float = BALL_SPEED, duration: float = 3.0) -> Flight:
    """The ball a batsman leaves (an aborted take, engine.synth.leaves_ball): on through
    ``hit_point`` untouched, under gravity; contact "none", no face."""
    s = _finite(ball_start, "ball start")
    p = _finite(hit_point, "hit point")
    v = -speed * face.toward_ball(s, p)
    return Flight(fly(p, v, duration), v, "none", float("nan"), np.zeros(3), np.zeros(3),
                  float(face.azimuth_deg(v)), float(face.elevation_deg(v)))


def ball_after_impact(global_rotations, global_positions, bat_joint: int, hand_joint: int,
                      face_normal_local, hit_frame: int, fps: float, ball_start, hit_point,
                      speed: float = BALL_SPEED, duration: float = 3.0, bat_axis_local=None) -> np.ndarray:
    """Trajectory ``(K,3)`` of the ball after the hit (:func:`flight`'s path).

    The face normal is ``face_normal_local`` in the bat joint's frame (the bat
    is a fixed child of ``hand_joint``, kept for the callers)."""
    del hand_joint
    return flight(global_rotations, global_positions, bat_joint, face_normal_local, hit_frame, fps,
                  ball_start, hit_point, bat_axis_local, speed, duration).path
