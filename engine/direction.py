"""Hit the ball in a chosen direction (dissertation 4.2: "controlling the direction of
the ball"), by the face.

At the hit point the ball's direction is set by the bat face and the bat's velocity
(engine.ballistics). With the hit point fixed and the face kept (AdaptSettings.face
"keep", the default), the kept face is turned about the vertical by ``theta``
(AdaptSettings.face_yaw, carried by the importance blend: 0 at the shot's ends, full
at the hit), and the face-keeping solve turns the arm to give it while the bat stays
on the point; ``theta`` is searched within ``MAX_YAW_DEG`` for the requested azimuth.
With the face free (position only), the chain's twist-only joint nearest the hand gets
an extra twist ``theta`` blended in the same way, within the joint's limits and
``MAX_TWIST_DEG`` of the source's twist. A request out of reach gets the closest
direction the shot can give, and says so.

The elevation (``elevation_deg``) is set by tilting the kept face (AdaptSettings.face_tilt:
the face normal turned up or down about the horizontal across it, carried by the blend;
the arm's limits bound what it can give): the tilt is searched within ``MAX_TILT_DEG``
for the requested elevation at the turn found, then the turn again for the azimuth at
that tilt (a tilt moves the azimuth a little, a turn the elevation).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import ballistics, face, quat
from .adapt import TWIST_COLUMN, Adaptation, AdaptSettings, Adapter, twist_only
from .ccd import limit_euler

MAX_TWIST_DEG = 45.0      # extra forearm twist at the hit: further would no longer read as the same shot
MAX_TILT_DEG = 30.0       # face tilted up or down at the hit, for the elevation
MAX_YAW_DEG = 45.0        # kept face turned about the vertical at the hit, for the azimuth
COARSE_STEPS = 19         # the turn's range sampled before refining
REFINE_STEPS = 12         # golden-section steps around the best sample (~0.1 deg)
REACHED_DEG = 3.0         # closer than this to the request counts as reached


@dataclass
class Aim:
    adaptation: Adaptation
    twist_deg: float          # the extra forearm twist at the hit frame (face free; 0 when kept)
    azimuth_deg: float        # where the ball goes
    requested_deg: float
    reached: bool             # within REACHED_DEG of the request
    range_deg: tuple          # the (min, max) azimuth the twist range gives with the face
    elevation_deg: float = float("nan")         # where the ball goes, up from the ground
    requested_elevation_deg: float | None = None  # None: no elevation asked (no tilt)
    elevation_reached: bool | None = None       # within REACHED_DEG of the requested elevation
    elevation_range_deg: tuple = ()             # the (min, max) elevation the tilt range gives
    tilt_deg: float = 0.0                       # the face tilt at the hit frame
    yaw_deg: float = 0.0                        # the kept face's turn about the vertical at the hit


def twist_joint(rig, wrist_dof: int = 0) -> int:
    """The left arm chain's twist-only joint nearest the hand (from the DOFs, no names)."""
    ch = rig.chains["left_arm"]
    joints = np.asarray(ch.joints)
    roll = twist_only(rig.dof_mask(wrist_dof)[joints])
    if not roll.any():
        raise ValueError("the left arm has no twist joint to turn the face with")
    return int(joints[np.flatnonzero(roll)[-1]])


def _twisted_shot(shot, joint: int, twist_rad: float, weights: np.ndarray):
    """The shot with ``twist_rad * weights (F,)`` added to ``joint``'s twist."""
    axis = np.zeros((len(weights), 3))
    axis[:, 0] = 1.0                          # the twist is about the bone: the joint's local x
    extra = quat.from_axis_angle(axis, twist_rad * weights)
    clip = shot.clip.copy()
    clip.local_rotations[:, joint] = quat.normalize(quat.mul(clip.local_rotations[:, joint], extra))
    return replace(shot, clip=clip)


def _twist_range(rig, shot, joint: int) -> tuple[float, float]:
    """Extra twist (rad) allowed at the hit frame: the joint's limits and MAX_TWIST_DEG."""
    src = limit_euler(shot.clip.local_rotations[shot.hit_frame:shot.hit_frame + 1, [joint]], rig.limits[[joint]])[0, 0]
    lo, hi = rig.limits[joint, TWIST_COLUMN]
    x = src[TWIST_COLUMN]
    return (np.radians(max(lo - x, -MAX_TWIST_DEG)), np.radians(min(hi - x, MAX_TWIST_DEG)))


def _minimise(miss, lo: float, hi: float):
    """The argument in [lo, hi] where ``miss`` is least: COARSE_STEPS samples, then
    golden-section steps around the best (the miss is smooth near its minimum).
    Returns (argument, the samples)."""
    grid = np.linspace(lo, hi, COARSE_STEPS)
    best = min(grid, key=miss)
    step = grid[1] - grid[0]
    a, b = max(best - step, lo), min(best + step, hi)
    golden = (np.sqrt(5.0) - 1) / 2
    for _ in range(REFINE_STEPS):
        c, d = b - golden * (b - a), a + golden * (b - a)
        a, b = (a, d) if miss(c) < miss(d) else (c, b)
    return min([best, (a + b) / 2], key=miss), grid


def aim(rig, shot, desired_hit_point, azimuth_deg: float, settings: AdaptSettings | None = None,
        ball_start=None, elevation_deg: float | None = None) -> Aim:
    """The shot adapted to ``desired_hit_point`` with the ball sent as close as it can
    go to ``azimuth_deg`` (DESIGN.md's convention: 0 straight, + toward the off side)
    and, when given, ``elevation_deg`` (up from the ground) by the face's tilt."""
    from .choice import BALL_START
    settings = settings or AdaptSettings()
    start = BALL_START if ball_start is None else np.asarray(ball_start, float)
    kept = settings.face == "keep"
    adapter = Adapter(rig, shot)
    joint = None if kept else twist_joint(rig, settings.wrist_dof)
    weights = adapter.blend(settings.falloff)
    cache: dict = {}
    tilted = elevation_deg is not None and kept

    def solve(theta: float, tilt: float):
        """The adaptation with the face turned ``theta`` about the vertical (kept face) or
        the forearm twisted ``theta`` (free face), and tilted ``tilt`` (rad)."""
        key = (float(theta), float(tilt))
        if key not in cache:
            if kept:
                a = adapter.adapt(desired_hit_point, replace(settings, face_yaw=float(np.degrees(theta)),
                                                             face_tilt=float(np.degrees(tilt))))
            else:
                a = Adapter(rig, _twisted_shot(shot, joint, theta, weights)).adapt(desired_hit_point, settings)
            fl, _ = ballistics.shot_flight(rig, shot, a.global_rotations, a.global_positions, start,
                                           a.desired_hit_point, duration=0.0)
            cache[key] = (a, fl.azimuth_deg, fl.elevation_deg, fl.contact == "face")
        return cache[key]

    def off_by(value: float, request: float, on_face: bool) -> float:
        """Degrees off the request; the edge or the back of the bat counts as further than any face hit."""
        return abs(float(face.wrap_deg(value - request))) + (0.0 if on_face else 360.0)

    lo, hi = (np.radians(-MAX_YAW_DEG), np.radians(MAX_YAW_DEG)) if kept else _twist_range(rig, shot, joint)
    tilt = 0.0
    theta, grid = _minimise(lambda t: off_by(solve(t, tilt)[1], azimuth_deg, solve(t, tilt)[3]), lo, hi)
    tilts = ()
    if tilted:
        t_lo, t_hi = np.radians(-MAX_TILT_DEG), np.radians(MAX_TILT_DEG)
        for _ in range(2):          # the tilt for the elevation, then the twist again for the azimuth
            tilt, tilts = _minimise(lambda u: off_by(solve(theta, u)[2], elevation_deg, solve(theta, u)[3]),
                                    t_lo, t_hi)
            theta, grid = _minimise(lambda t: off_by(solve(t, tilt)[1], azimuth_deg, solve(t, tilt)[3]), lo, hi)
    adaptation, az, el, on_face = solve(theta, tilt)
    # the range is sampled on the coarse grid; the refined answer can lie past its ends
    # (the pull's face gives -135 deg between two samples that give -129 and the edge)
    reach = [solve(t, tilt)[1] for t in grid if solve(t, tilt)[3]] + ([az] if on_face else [])
    reach = reach or [az]
    turn = float(np.degrees(theta))
    out = Aim(adaptation, 0.0 if kept else turn, float(az), float(azimuth_deg),
              off_by(az, azimuth_deg, on_face) <= REACHED_DEG, (float(min(reach)), float(max(reach))),
              elevation_deg=float(el), tilt_deg=float(np.degrees(tilt)), yaw_deg=turn if kept else 0.0)
    if elevation_deg is not None:
        ups = [solve(theta, u)[2] for u in tilts if solve(theta, u)[3]] + ([el] if on_face else [])
        ups = ups or [el]
        out.requested_elevation_deg = float(elevation_deg)
        out.elevation_reached = off_by(el, elevation_deg, on_face) <= REACHED_DEG
        out.elevation_range_deg = (float(min(ups)), float(max(ups)))
    return out
