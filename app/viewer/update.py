"""The per-frame update: reads the settings (and the PC pad's requests), writes the state.
It re-adapts the shot through the engine when anything the adaptation depends on changed,
puts the pose and ball of the frame into the state, and runs the PC pad's model, whose pose
the viewport shows instead while it drives it. Playback has already moved ``settings.frame``
(``app.playback``, time as an input). No GL, no imgui here."""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from app.viewer import padrequests, pcpad
from app.viewer.picking import TARGET_PLANE_Z, clamp_target
from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState, Pose
from engine import ballistics
from engine.adapt import Adapter, trunk_jump_deg, trunk_turn_deg
from engine.choice import BALL_START, choose_shot
from engine.direction import aim
from engine.learnt_solver import LEARNT_SOLVERS, LearntSolver
from engine.rig import default_rig
from engine.userlib import load_shots
from engine.skeleton import bind_positions


AIM_SETTLE_S = 0.25       # the target holds still this long before the face is turned for a direction
TRAIL_LENGTH = 90         # ball directions kept for the wagon wheel (the live Fig. 2.6)


def load_library(state: AppState, manifest=None) -> bool:
    """(Re)load the rig and shot library; on failure keep what was loaded."""
    try:
        state.rig = state.rig or _first_rig(manifest)   # the stage still draws without shots
        rig, shots = load_shots(manifest)
        if not shots:
            raise ValueError("the shot library is empty")
        if rig.skeleton.names != state.rig.skeleton.names and state.shots:
            raise ValueError("its skeleton changed (restart the viewer to draw another skeleton)")
    except Exception as e:  # a bad file: say so, keep the last good library
        state.report(f"library: {e}")
        if not state.shots:   # nothing to fall back on: keep saying so
            state.status["library"] = str(e).splitlines()[0] if str(e) else type(e).__name__
        return False
    state.rig, state.shots = rig, shots
    state.hit_points = np.array([s.hit_point for s in shots], float)
    state.bind_positions = bind_positions(rig.skeleton)
    state.adapters.clear()
    state.learnt = None                 # the learnt model trains on the new library when asked
    state.compare_adaptation = state.compared_key = None
    state.source_azimuths.clear()
    state.shot_index = min(max(state.shot_index, 0), len(shots) - 1)
    state.solved_key = None
    state.status["library"] = "ok"
    state.ball_start = np.asarray(BALL_START, float)
    return True


def _first_rig(manifest):
    """The rig the viewer starts with: the library's, or the bundled one when it cannot be read
    (the stage and the message still show)."""
    try:
        return load_shots(manifest)[0]
    except (ValueError, OSError):
        return default_rig()


def default_target(state: AppState, index: int | None = None) -> np.ndarray:
    """A target whose ball path passes exactly through shot ``index``'s FK hit
    point (default: the shot whose target sits nearest waist height behind the
    stumps, so the disc starts clear of the ground and unadapted)."""
    if not len(state.hit_points):
        return clamp_target((0.0, 60.0, TARGET_PLANE_Z))
    if index is None:
        targets = [default_target(state, i) for i in range(len(state.hit_points))]
        index = int(np.argmin([abs(t[1] - 60.0) + 0.5 * abs(t[0]) for t in targets]))
    start, hit = state.ball_start, state.hit_points[index]
    d = hit - start
    t = (TARGET_PLANE_Z - start[2]) / d[2] if abs(d[2]) > 1e-9 else 1.0
    return clamp_target(start + t * d)


def update(state: AppState, settings: ViewerSettings, dt: float, pad_requests=()) -> None:
    """One frame: re-solve if needed, the frame's pose and ball, the PC pad (``pad_requests``:
    what its widget and scripts asked this frame, in order)."""
    state.readouts.engine_ms = 0.0
    if not state.shots:
        state.pose = state.source_pose = None
        return
    key = settings.engine_key()
    if key != state.solved_key and solver_ready(state):
        # the first solve builds the adapter: solved once more, the panel's readout shows a re-solve
        if solve(state, settings) and state.solved_key is None:
            solve(state, settings)
        state.solved_key, state.aimed_key, state.still_s = key, None, 0.0
    elif state.adaptation is None:       # the solver compiles: the source of the shot it will adapt
        state.shot_index = choose(state, settings)[0]
    else:
        state.still_s += dt
        aim_step(state, settings)
    compare_step(state, settings)
    t0 = time.perf_counter()
    pose_at(state, settings.frame)
    ball_at(state, settings.frame)
    state.shown_flight, state.shown_impact = state.flight, state.readouts
    if pad_ready(state):
        padrequests.step(state, pad_requests, dt)
        pad_pose(state)
    state.readouts.engine_ms += (time.perf_counter() - t0) * 1e3
    if not state.gesture and not settings.playing and solver_ready(state):
        prewarm(state)      # idle frames only; not in the readout: it is no work of this frame's


def aim_step(state: AppState, settings: ViewerSettings) -> None:
    """"Hit it that way": once the target holds still (AIM_SETTLE_S; the search costs ~0.1 s,
    too much for every frame of a drag), the shot re-solved with the face turned toward
    ``settings.direction``; back to the plain solve when the request is dropped."""
    want = settings.aim_key() if settings.solver not in LEARNT_SOLVERS else None  # the face is turned by CCD/DLS
    if want is None:
        if state.aimed_key is not None:
            solve(state, settings)
            state.aimed_key = None
        return
    if want != state.aimed_key and state.still_s >= AIM_SETTLE_S and solver_ready(state):
        solve(state, settings, settings.direction)
        state.aimed_key = want


def solver_ready(state: AppState) -> bool:
    """False while the engine compiles behind the window (``app.warmup``)."""
    return state.engine_warmup is None or state.engine_warmup.solver_ready.is_set()


def pad_ready(state: AppState) -> bool:
    return state.engine_warmup is None or state.engine_warmup.ready.is_set()


def pad_pose(state: AppState) -> None:
    """While the PC pad drives the pose (live marker or a synthesised take), the viewport
    shows its pose instead of the shot, and the ball that pose meets: a take's (app.takeball),
    none for the marker's still pose."""
    pose = pcpad.active_pose(state)
    if pose is not None and np.isfinite(pose.global_positions).all():
        state.pose, state.pose_source = pose, "pc pad"
        state.ball_position, state.shown_flight, state.shown_impact = pcpad.active_ball(state)


def choose(state: AppState, settings: ViewerSettings) -> tuple[int, np.ndarray]:
    """Shot index and desired hit point for the ball path to ``settings.target`` (a pinned
    shot no longer in the library counts as none: ``app.playback`` unpins it)."""
    start, target = state.ball_start, np.asarray(settings.target, float)
    names = [s.name for s in state.shots]
    if settings.pinned_shot not in names:
        index, desired = choose_shot(state.hit_points, start, target)
        return int(index), np.asarray(desired, float)
    index = names.index(settings.pinned_shot)
    # Same rule as the automatic choice: the point of the ball's line nearest the FK hit point.
    d = target - start
    t = float(np.dot(state.hit_points[index] - start, d) / max(np.dot(d, d), 1e-12))
    return index, start + np.clip(t, 0.0, 1.0) * d


def adapt_by(state: AppState, index: int, desired, adapt_settings, leave_out: bool):
    """Shot ``index`` adapted to ``desired`` by ``adapt_settings.solver``; the learnt solvers
    train their model here on first use (and per left-out shot), never in the panel."""
    if adapt_settings.solver not in LEARNT_SOLVERS:
        return adapter_for(state, index).adapt(desired, adapt_settings)
    return learnt_for(state, index, leave_out).adapt(adapter_for(state, index), desired, adapt_settings, leave_out)


def learnt_for(state: AppState, index: int, leave_out: bool) -> LearntSolver:
    """The library's learnt solver with the model shot ``index`` needs trained."""
    if state.learnt is None:
        state.learnt = LearntSolver(state.rig, state.shots)
    state.learnt.model(state.shots[index].name if leave_out else None)
    return state.learnt


def compare_step(state: AppState, settings: ViewerSettings) -> None:
    """The shot and point of the last solve adapted by ``settings.compare_solver`` too (the
    ghost shows it); its figures in ``readouts.compare``. On an engine error: no comparison."""
    key = settings.compare_key()
    if key is None or state.adaptation is None:
        state.compare_adaptation, state.compared_key, state.readouts.compare = None, None, {}
        return
    if key == state.compared_key or not solver_ready(state):
        return
    state.compared_key = key
    try:
        if settings.compare_solver in LEARNT_SOLVERS:
            learnt_for(state, state.shot_index, settings.learnt_leave_out)
        t0 = time.perf_counter()
        a = adapt_by(state, state.shot_index, state.desired_hit_point,
                     replace(settings.adapt_settings(), solver=settings.compare_solver), settings.learnt_leave_out)
        check_finite(a)
    except Exception as e:
        state.report(f"engine: compare {settings.compare_solver}: {type(e).__name__}: {e}")
        state.compare_adaptation, state.readouts.compare = None, {}
        return
    ms = (time.perf_counter() - t0) * 1e3
    state.readouts.engine_ms += ms
    state.compare_adaptation = a
    state.readouts.compare = {"solver": settings.compare_solver, "bat_error_cm": float(a.bat_error_cm),
                              "max_grip_error_cm": float(np.max(a.grip_error_cm)),
                              "us_per_frame": ms * 1e3 / max(len(a.blend), 1)}


def adapter_for(state: AppState, index: int):
    """The shot's ``engine.adapt.Adapter`` (built once: its __init__ precomputes)."""
    if state.adapters.get(index) is None:
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


def solve(state: AppState, settings: ViewerSettings, direction: float | None = None) -> bool:
    """Re-adapt the whole shot (with ``direction``: the ball sent that way by the face,
    engine.direction); on any engine error keep the last good state."""
    t0 = time.perf_counter()
    aimed = None
    try:
        index, desired = choose(state, settings)
        if direction is None:
            if settings.solver in LEARNT_SOLVERS:     # trained first: not in the us-a-frame figure
                learnt_for(state, index, settings.learnt_leave_out)
            t1 = time.perf_counter()
            adaptation = adapt_by(state, index, desired, settings.adapt_settings(), settings.learnt_leave_out)
            state.readouts.us_per_frame = (time.perf_counter() - t1) * 1e6 / max(len(adaptation.blend), 1)
        else:
            aimed = aim(state.rig, state.shots[index], desired, direction, settings.adapt_settings(),
                        state.ball_start, elevation_deg=settings.asked_elevation())
            adaptation = aimed.adaptation
        check_finite(adaptation)
        flight, flight_dt = ball_flight(state, index, adaptation, desired)
    except Exception as e:
        state.report(f"engine: {type(e).__name__}: {e}")
        return False
    finally:
        ms = (time.perf_counter() - t0) * 1e3
        state.readouts.engine_ms += ms
        state.readouts.solve_ms = ms
    state.shot_index, state.desired_hit_point, state.adaptation = index, desired, adaptation
    state.flight, state.flight_dt = flight, flight_dt
    state.time_blend = time_based_blend(state.shots[index].num_frames, state.shots[index].hit_frame,
                                        adaptation.blend)
    state.readouts.bat_error_cm = float(adaptation.bat_error_cm)
    state.readouts.max_grip_error_cm = float(np.max(adaptation.grip_error_cm))
    turn = trunk_turn_deg(state.rig, state.shots[index].fk[0], adaptation.global_rotations)
    state.readouts.trunk_turn_deg = float("nan") if turn is None else turn
    jump = trunk_jump_deg(state.rig, state.shots[index].fk[0], adaptation.global_rotations)
    state.readouts.trunk_jump_deg = float("nan") if jump is None else jump
    state.readouts.aim_reached = None if aimed is None else bool(aimed.reached)
    state.readouts.aim_range_deg = () if aimed is None else tuple(aimed.range_deg)
    state.readouts.aim_elevation_reached = None if aimed is None else aimed.elevation_reached
    state.readouts.aim_elevation_range_deg = () if aimed is None else tuple(aimed.elevation_range_deg)
    _trail(state, index)
    state.solve_count += 1
    return True


def _trail(state: AppState, index: int) -> None:
    """The ball's direction after each solve, for the wagon wheel; a new shot starts a new trail."""
    if state.azimuth_trail and state.azimuth_trail[-1][0] != index:
        state.azimuth_trail.clear()
    state.azimuth_trail.append((index, state.readouts.ball_azimuth_deg))
    del state.azimuth_trail[:-TRAIL_LENGTH]


def check_finite(adaptation) -> None:
    for name in ("global_rotations", "global_positions", "local_rotations", "blend"):
        if not np.isfinite(np.asarray(getattr(adaptation, name))).all():
            raise FloatingPointError(f"adaptation has non-finite {name}")


def ball_flight(state: AppState, index: int, adaptation, desired) -> tuple[np.ndarray | None, float]:
    """Ball after impact ``(K,3)`` and the time between its samples (s); the impact's
    readouts (what the ball met, the face against the source's, where the ball goes)."""
    shot = state.shots[index]
    rig = state.rig
    hit, face_angle = ballistics.shot_flight(rig, shot, adaptation.global_rotations,
                                             adaptation.global_positions, state.ball_start, desired)
    polyline = np.asarray(hit.path, float)
    if polyline.ndim != 2 or polyline.shape[-1] != 3 or not np.isfinite(polyline).all():
        raise FloatingPointError("ball flight is not a finite (K,3) polyline")
    r = state.readouts
    r.contact, r.face_to_ball = hit.contact, float(hit.face_to_ball)
    r.ball_azimuth_deg, r.ball_elevation_deg = hit.azimuth_deg, hit.elevation_deg
    r.face_angle_deg = face_angle
    if index not in state.source_azimuths:     # the source's own direction, once per shot
        grot, gpos = shot.fk
        src, _ = ballistics.shot_flight(rig, shot, grot, gpos, state.ball_start, shot.hit_point, duration=0.0)
        state.source_azimuths[index] = src.azimuth_deg
    r.source_azimuth_deg = state.source_azimuths[index]
    return polyline, ballistics.FLY_DT


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
    state.pose_source = "adapted" if adaptation is not None else "source"
    compare = state.compare_adaptation
    state.compare_pose = None
    if compare is not None and compare.global_positions.shape[0] == shot.num_frames:
        state.compare_pose = _interpolate(compare.global_rotations, compare.global_positions, frame)
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
    state.ball_position = ballistics.ball_at_frame(state.ball_start, desired, shot.hit_frame, shot.clip.fps,
                                                   state.flight, state.flight_dt, frame)
