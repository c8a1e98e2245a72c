"""The per-frame update: read the settings, advance playback, re-adapt the
shot through the engine when anything it depends on changed, and put the pose
and ball of the current frame into the state. No GL, no imgui here."""
from __future__ import annotations

import time

import numpy as np

from app.settings import ViewerSettings
from app.state import AppState, Pose


FLIGHT_DT = 1.0 / 120.0   # s between samples of engine.ballistics.fly (its default step)


def load_library(state: AppState, manifest=None) -> bool:
    """(Re)load the rig and shot library; on failure keep what was loaded."""
    try:
        from engine.library import load_library as _load
        from engine.rig import default_rig
        from engine.skeleton import bind_positions
        rig = state.rig = state.rig or default_rig()   # the stage still draws without shots
        shots = _load(manifest, rig=rig)
        if not shots:
            raise ValueError("the shot library is empty")
    except Exception as e:  # a bad file: say so, keep the last good library
        state.report(f"library: {e}")
        if not state.shots:   # nothing to fall back on: keep saying so
            state.status["library"] = str(e).splitlines()[0] if str(e) else type(e).__name__
        return False
    state.rig, state.shots = rig, shots
    state.hit_points = np.array([s.hit_point for s in shots], float)
    state.bind_positions = bind_positions(rig.skeleton)
    state.adapters.clear()
    state.shot_index = min(max(state.shot_index, 0), len(shots) - 1)
    state.solved_key = None
    state.status["library"] = "ok"
    try:
        from engine.choice import BALL_START
        state.ball_start = np.asarray(BALL_START, float)
    except ImportError:
        pass
    return True


def default_target(state: AppState, index: int | None = None) -> np.ndarray:
    """A target whose ball path passes exactly through shot ``index``'s FK hit
    point (default: the shot whose target sits nearest waist height behind the
    stumps, so the disc starts clear of the ground and unadapted)."""
    from app.picking import TARGET_PLANE_Z, clamp_target
    if not len(state.hit_points):
        return clamp_target((0.0, 60.0, TARGET_PLANE_Z))
    if index is None:
        targets = [default_target(state, i) for i in range(len(state.hit_points))]
        index = int(np.argmin([abs(t[1] - 60.0) + 0.5 * abs(t[0]) for t in targets]))
    start, hit = state.ball_start, state.hit_points[index]
    d = hit - start
    t = (TARGET_PLANE_Z - start[2]) / d[2] if abs(d[2]) > 1e-9 else 1.0
    return clamp_target(start + t * d)


def update(state: AppState, settings: ViewerSettings, dt: float) -> None:
    """One frame: playback, re-solve if needed, current pose and ball."""
    settings.sanitise()
    state.readouts.engine_ms = 0.0
    if not state.shots:
        state.pose = state.source_pose = None
        return
    key = settings.engine_key()
    if key != state.solved_key:
        solve(state, settings)
        state.solved_key = key
    advance_playback(state, settings, dt)
    t0 = time.perf_counter()
    pose_at(state, settings.frame)
    ball_at(state, settings.frame)
    state.readouts.engine_ms += (time.perf_counter() - t0) * 1e3


def advance_playback(state: AppState, settings: ViewerSettings, dt: float) -> None:
    last = state.num_frames - 1
    if settings.playing:
        settings.frame += max(dt, 0.0) * state.fps * settings.playback_rate
        if settings.frame > last:
            settings.frame = settings.frame % (last + 1) if settings.loop else float(last)
            settings.playing = settings.playing and settings.loop
    settings.frame = float(np.clip(settings.frame, 0.0, last))


def choose(state: AppState, settings: ViewerSettings) -> tuple[int, np.ndarray]:
    """Shot index and desired hit point for the ball path to ``settings.target``."""
    from engine.choice import choose_shot
    start, target = state.ball_start, np.asarray(settings.target, float)
    if settings.pinned_shot is None:
        index, desired = choose_shot(state.hit_points, start, target)
        return int(index), np.asarray(desired, float)
    names = [s.name for s in state.shots]
    if settings.pinned_shot not in names:
        settings.pinned_shot = None
        return choose(state, settings)
    index = names.index(settings.pinned_shot)
    # Same rule as the automatic choice: the point of the ball's line nearest the FK hit point.
    d = target - start
    t = float(np.dot(state.hit_points[index] - start, d) / max(np.dot(d, d), 1e-12))
    return index, start + np.clip(t, 0.0, 1.0) * d


def adapter_for(state: AppState, index: int):
    """The shot's ``engine.adapt.Adapter`` (built once: its __init__ precomputes)."""
    if state.adapters.get(index) is None:
        from engine.adapt import Adapter
        state.adapters[index] = Adapter(state.rig, state.shots[index])
    return state.adapters[index]


def prewarm(state: AppState) -> bool:
    """Build one missing shot Adapter (a few ms) so that a later drag which
    switches shots does not stall on it; True while some were missing."""
    for index in range(len(state.shots)):
        if index not in state.adapters:
            try:
                adapter_for(state, index)
            except Exception as e:  # a broken shot: it will report again if chosen
                state.report(f"engine: {state.shots[index].name}: {type(e).__name__}: {e}")
                state.adapters[index] = None
            return True
    return False


def warm_up(state: AppState, settings: ViewerSettings) -> None:
    """Solve before the first frame. The first solve loads the compiled engine and builds the
    shot's adapter (~150 ms here) and would stand in the panel's "whole-shot solve" readout
    until the target moved; solved once more, the readout shows what a re-solve costs."""
    if state.shots and solve(state, settings):
        solve(state, settings)
        state.solved_key = settings.engine_key()


def solve(state: AppState, settings: ViewerSettings) -> bool:
    """Re-adapt the whole shot; on any engine error keep the last good state."""
    t0 = time.perf_counter()
    try:
        index, desired = choose(state, settings)
        adaptation = adapter_for(state, index).adapt(desired, settings.adapt_settings())
        check_finite(adaptation)
        flight, flight_dt = ball_flight(state, index, adaptation, desired)
    except Exception as e:
        state.report(f"engine: {type(e).__name__}: {e}")
        return False
    finally:
        ms = (time.perf_counter() - t0) * 1e3
        state.readouts.engine_ms += ms
        state.readouts.solve_ms = ms
    if index != state.shot_index:
        old = state.shot
        if old is not None and not settings.playing and abs(settings.frame - old.hit_frame) < 1e-6:
            settings.frame = float(state.shots[index].hit_frame)   # watching the hit: stay on it
        settings.frame = min(settings.frame, state.shots[index].num_frames - 1)
    state.shot_index, state.desired_hit_point, state.adaptation = index, desired, adaptation
    state.flight, state.flight_dt = flight, flight_dt
    state.time_blend = time_based_blend(state.shots[index].num_frames, state.shots[index].hit_frame,
                                        adaptation.blend)
    state.readouts.bat_error_cm = float(adaptation.bat_error_cm)
    state.readouts.max_grip_error_cm = float(np.max(adaptation.grip_error_cm))
    state.solve_count += 1
    return True


def check_finite(adaptation) -> None:
    for name in ("global_rotations", "global_positions", "local_rotations", "blend"):
        if not np.isfinite(np.asarray(getattr(adaptation, name))).all():
            raise FloatingPointError(f"adaptation has non-finite {name}")


def ball_flight(state: AppState, index: int, adaptation, desired) -> tuple[np.ndarray | None, float]:
    """Ball after impact ``(K,3)`` and the time between its samples (s)."""
    from engine import ballistics
    shot = state.shots[index]
    rig = state.rig
    hand = int(rig.skeleton.parents[rig.bat_joint])      # the bat hangs off the left hand
    polyline = ballistics.ball_after_impact(
        adaptation.global_rotations, adaptation.global_positions, rig.bat_joint, hand,
        rig.bat["face_normal"], shot.hit_frame, shot.clip.fps, state.ball_start, desired)
    polyline = np.asarray(polyline, float)
    if polyline.ndim != 2 or polyline.shape[-1] != 3 or not np.isfinite(polyline).all():
        raise FloatingPointError("ball flight is not a finite (K,3) polyline")
    return polyline, FLIGHT_DT


def time_based_blend(num_frames: int, hit_frame: int, importance: np.ndarray) -> np.ndarray:
    """A time-based blend for comparison (Figure 2.3): a cosine bell peaking at
    the hit frame, as wide as the importance-based blend's support."""
    f = np.arange(num_frames, dtype=float)
    support = np.nonzero(np.asarray(importance) > 1e-6)[0]
    lo = support[0] - 1 if support.size else max(hit_frame - 5, 0)
    hi = support[-1] + 1 if support.size else min(hit_frame + 5, num_frames - 1)
    left = np.clip((f - lo) / max(hit_frame - lo, 1), 0, 1)
    right = np.clip((hi - f) / max(hi - hit_frame, 1), 0, 1)
    return np.where(f <= hit_frame, 0.5 - 0.5 * np.cos(np.pi * left), 0.5 - 0.5 * np.cos(np.pi * right))


def _interpolate(global_rotations, global_positions, frame: float) -> Pose:
    """Pose at a fractional frame: lerp positions, nlerp rotations (vectorised over joints)."""
    last = global_positions.shape[0] - 1
    f0 = int(np.clip(np.floor(frame), 0, last))
    f1, a = min(f0 + 1, last), float(np.clip(frame - f0, 0.0, 1.0))
    if a < 1e-6 or f1 == f0:
        return Pose(global_rotations[f0], global_positions[f0])
    q0, q1 = global_rotations[f0], global_rotations[f1]
    sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    q = (1 - a) * q0 + a * sign * q1
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return Pose(q, (1 - a) * global_positions[f0] + a * global_positions[f1])


def pose_at(state: AppState, frame: float) -> None:
    shot, adaptation = state.shot, state.adaptation
    if shot is None:
        return
    src_rot, src_pos = shot.fk
    state.source_pose = _interpolate(src_rot, src_pos, frame)
    if adaptation is not None and adaptation.global_positions.shape[0] == shot.num_frames:
        state.pose = _interpolate(adaptation.global_rotations, adaptation.global_positions, frame)
        f = int(round(frame))
        state.readouts.grip_error_cm = float(adaptation.grip_error_cm[f])
        state.readouts.grip_error_deg = float(adaptation.grip_error_deg[f])
    else:
        state.pose = state.source_pose


def ball_at(state: AppState, frame: float) -> None:
    """The ball in sync with the frame: incoming until the hit frame, then its flight."""
    shot, desired = state.shot, state.desired_hit_point
    if shot is None or desired is None:
        state.ball_position = None
        return
    if frame <= shot.hit_frame or state.flight is None or len(state.flight) == 0:
        from engine.ballistics import incoming_ball
        state.ball_position = np.asarray(
            incoming_ball(state.ball_start, desired, shot.hit_frame, min(frame, shot.hit_frame),
                          shot.clip.fps), float)
        return
    # After impact: walk the flight polyline at its own sample spacing.
    s = (frame - shot.hit_frame) / shot.clip.fps / max(state.flight_dt, 1e-6)
    k = int(np.clip(np.floor(s), 0, len(state.flight) - 1))
    k1, a = min(k + 1, len(state.flight) - 1), float(np.clip(s - k, 0, 1))
    state.ball_position = (1 - a) * state.flight[k] + a * state.flight[k1]
