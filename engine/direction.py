"""Hit the ball in a chosen direction (dissertation 4.2: "controlling the direction of
the ball"), by the face.

At the hit point the ball's direction is set by the bat face and the bat's velocity
(engine.ballistics). With the hit point fixed, the face is turned by twisting the left
forearm about its bone: the chain's twist-only joint nearest the hand gets an extra
twist ``theta`` blended in with the importance blend (0 at the shot's ends, full at the
hit), so the shot starts and ends as captured and the rest of the swing keeps its
style; the adaptation (CCD, roll joints following) then puts the bat back on the hit
point. ``theta`` is searched for the requested azimuth within the joint's limits and
``MAX_TWIST_DEG`` of the source's twist; a request out of reach gets the closest
direction the shot can give, and says so.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import ballistics, face, quat
from .adapt import TWIST_COLUMN, Adaptation, AdaptSettings, Adapter, twist_only
from .ccd import limit_euler

MAX_TWIST_DEG = 45.0      # extra forearm twist at the hit: further would no longer read as the same shot
COARSE_STEPS = 19         # the twist range sampled before refining
REFINE_STEPS = 12         # golden-section steps around the best sample (~0.1 deg)
REACHED_DEG = 3.0         # closer than this to the request counts as reached


@dataclass
class Aim:
    adaptation: Adaptation
    twist_deg: float          # the extra forearm twist at the hit frame
    azimuth_deg: float        # where the ball goes
    requested_deg: float
    reached: bool             # within REACHED_DEG of the request
    range_deg: tuple          # the (min, max) azimuth the twist range gives with the face


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


def aim(rig, shot, desired_hit_point, azimuth_deg: float, settings: AdaptSettings | None = None,
        ball_start=None) -> Aim:
    """The shot adapted to ``desired_hit_point`` with the ball sent as close as it can
    go to ``azimuth_deg`` (DESIGN.md's convention: 0 straight, + toward the off side)."""
    from .choice import BALL_START
    settings = settings or AdaptSettings()
    start = BALL_START if ball_start is None else np.asarray(ball_start, float)
    joint = twist_joint(rig, settings.wrist_dof)
    weights = Adapter(rig, shot).blend(settings.falloff)
    cache: dict = {}

    def solve(theta: float):
        if theta not in cache:
            a = Adapter(rig, _twisted_shot(shot, joint, theta, weights)).adapt(desired_hit_point, settings)
            fl, _ = ballistics.shot_flight(rig, shot, a.global_rotations, a.global_positions, start,
                                           a.desired_hit_point, duration=0.0)
            cache[theta] = (a, fl.azimuth_deg, fl.contact == "face")
        return cache[theta]

    def miss(theta: float) -> float:
        """Degrees off the request; a twist that meets the ball with the edge or the back
        of the bat counts as further than any face hit."""
        a, az, on_face = solve(theta)
        return abs(float(face.wrap_deg(az - azimuth_deg))) + (0.0 if on_face else 360.0)

    lo, hi = _twist_range(rig, shot, joint)
    grid = np.linspace(lo, hi, COARSE_STEPS)
    best = min(grid, key=miss)
    step = grid[1] - grid[0]
    a, b = max(best - step, lo), min(best + step, hi)
    golden = (np.sqrt(5.0) - 1) / 2
    for _ in range(REFINE_STEPS):             # the miss is smooth near its minimum
        c, d = b - golden * (b - a), a + golden * (b - a)
        a, b = (a, d) if miss(c) < miss(d) else (c, b)
    theta = min([best, (a + b) / 2], key=miss)
    adaptation, az, _ = solve(theta)
    reach = [solve(t)[1] for t in grid if solve(t)[2]] or [az]
    return Aim(adaptation, float(np.degrees(theta)), float(az), float(azimuth_deg),
               miss(theta) <= REACHED_DEG, (float(min(reach)), float(max(reach))))
