"""The ball a synthesised take meets (the PC pad's takes, app.pcpad): bowled from the ball's
start at the take's bat at the take's hit frame (the clean-up brought the bat to the shot's hit
point there, engine.cleanup_hit), it leaves off what the take's bat has there, face, edge or
back, as the adapted shot's does (engine.ballistics). An aborted take that leaves the ball
(engine.synth.leaves_ball) lets it pass the shot's hit point untouched. The viewport shows that
ball, its flight and the impact's readouts while the take plays, not the adapted shot's."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.viewer.state import Readouts
from engine import ballistics


@dataclass(frozen=True)
class TakeImpact:
    hit_frame: int              # on the take's timeline
    hit_point: np.ndarray       # (3,) cm: the take's Bat joint there
    ball_start: np.ndarray      # (3,) cm
    fps: float
    flight: ballistics.Flight
    readouts: Readouts          # contact, face_to_ball, face_angle_deg (vs the source's), azimuth, elevation


def take_impact(rig, shot, global_rotations, global_positions, hit_frame: int, ball_start,
                leaves: bool = False) -> TakeImpact:
    """The impact of a take (its FK ``(F, J, 4)``, ``(F, J, 3)``) with a ball bowled at its bat;
    ``leaves``: the take leaves the ball, bowled at the shot's hit point (contact "none")."""
    if leaves:
        hit_point = np.asarray(shot.hit_point, float)
        fl, angle = ballistics.passing_flight(ball_start, hit_point), float("nan")
    else:
        hit_point = np.asarray(global_positions[hit_frame, rig.bat_joint], float)
        fl, angle = ballistics.shot_flight(rig, shot, global_rotations, global_positions, ball_start, hit_point,
                                           hit_frame=hit_frame)
    r = Readouts(contact=fl.contact, face_to_ball=float(fl.face_to_ball), face_angle_deg=angle,
                 ball_azimuth_deg=fl.azimuth_deg, ball_elevation_deg=fl.elevation_deg)
    return TakeImpact(int(hit_frame), hit_point, np.asarray(ball_start, float), float(shot.clip.fps), fl, r)


def ball_in_take(impact: TakeImpact, frame: float) -> np.ndarray:
    """The ball ``(3,)`` at a (fractional) frame of the take."""
    return ballistics.ball_at_frame(impact.ball_start, impact.hit_point, impact.hit_frame, impact.fps,
                                    impact.flight.path, ballistics.FLY_DT, frame)
