"""Everything the viewer derived from the settings: the library, the chosen
shot, the last good adaptation, the pose on screen, readouts and messages.
Written by ``app.update`` (and ``app.interaction`` for hover/drag), read by
the panel and by render submission."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from app.viewer.pcpad import PadState
    from app.viewer.warmup import EngineWarmup


@dataclass
class Readouts:
    bat_error_cm: float = float("nan")     # |bat - desired| at the hit frame
    grip_error_cm: float = float("nan")    # right hand vs source grip, this frame
    grip_error_deg: float = float("nan")
    max_grip_error_cm: float = float("nan")
    contact: str = ""                       # what the ball met at the hit frame: "face" | "edge" | "back"
    face_to_ball: float = float("nan")      # cosine of the face normal and the direction toward the ball
    face_angle_deg: float = float("nan")    # the adapted face against the source's, at the hit frame
    trunk_turn_deg: float = float("nan")    # the chest's largest turn from the source's over the shot
    trunk_jump_deg: float = float("nan")    # its largest turn between two frames beyond the source's
    ball_azimuth_deg: float = float("nan")  # where the ball goes (DESIGN.md: 0 straight, + off side)
    ball_elevation_deg: float = float("nan")
    source_azimuth_deg: float = float("nan")  # where the source shot sends the ball from its own hit point
    aim_reached: bool | None = None         # the asked direction reached (None: none asked / not yet aimed)
    aim_range_deg: tuple = ()               # the directions the shot can give with the face
    aim_elevation_reached: bool | None = None  # the asked elevation reached (None: none asked)
    aim_elevation_range_deg: tuple = ()     # the elevations the face's tilt can give there
    engine_ms: float = 0.0                  # engine time spent this frame
    solve_ms: float = 0.0                   # last whole-shot solve
    us_per_frame: float = float("nan")      # last whole-shot solve over the shot's frames
    compare: dict = field(default_factory=dict)  # the compared solver's figures (bat_error_cm, max_grip_error_cm, us_per_frame)
    render_ms: float = 0.0
    frame_ms: float = 0.0
    fps: float = 0.0


TIMING_PERIOD_S = 0.25


@dataclass
class TimingDisplay:
    """The timing readouts as a person can read them: means over the last quarter
    second, refreshed four times a second. A number that changes every frame cannot
    be read (and redraws its line of the panel every frame)."""
    shown: dict = field(default_factory=dict)        # name -> mean over the last period
    _sums: dict = field(default_factory=dict)
    _count: int = 0
    _since: float | None = None

    def add(self, now: float, **values: float) -> None:
        """One frame's values (seconds ``now`` on any monotonic clock)."""
        for name, v in values.items():
            self._sums[name] = self._sums.get(name, 0.0) + float(v)
        self._count += 1
        if self._since is None:
            self._since = now
        if not self.shown or now - self._since >= TIMING_PERIOD_S:
            self.shown = {name: total / self._count for name, total in self._sums.items()}
            self._sums, self._count, self._since = {}, 0, now


@dataclass(frozen=True)
class ExportNote:
    ok: bool
    line: str          # what was written, or why it failed


@dataclass
class Pose:
    """One frame of a skeleton in world space."""
    global_rotations: np.ndarray   # (J,4)
    global_positions: np.ndarray   # (J,3)


@dataclass
class AppState:
    rig: object = None
    shots: list = field(default_factory=list)
    hit_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))   # (N,3) FK hit points
    bind_positions: np.ndarray | None = None                                   # (J,3)
    adapters: dict = field(default_factory=dict)      # shot index -> engine.adapt.Adapter
    terrain: object = None                            # uneven ground drawn instead of the pitch (app.viewer.terrain)
    learnt: object = None                             # engine.learnt_solver.LearntSolver of the library (trained on demand)
    ball_start: np.ndarray = field(default_factory=lambda: np.array([0.0, 100.0, 1800.0]))
    # the last good solve
    shot_index: int = -1
    desired_hit_point: np.ndarray | None = None       # (3,)
    adaptation: object = None                         # engine.adapt.Adaptation
    compare_adaptation: object = None                 # the same shot and point by settings.compare_solver
    compared_key: tuple | None = None                 # settings.compare_key() of compare_adaptation
    flight: np.ndarray | None = None                  # (K,3) ball after impact
    flight_dt: float = 1.0 / 30.0                     # seconds between flight samples
    time_blend: np.ndarray | None = None              # (F,) the time-based curve of Figure 2.3
    solved_key: tuple | None = None
    aimed_key: tuple | None = None                    # settings.aim_key() of the last aimed solve
    still_s: float = 0.0                              # how long the engine key has held still
    azimuth_trail: list = field(default_factory=list)  # recent ball azimuths (deg), newest last
    source_azimuths: dict = field(default_factory=dict)  # shot index -> its source's ball azimuth (deg)
    solve_count: int = 0
    # this frame
    pose: Pose | None = None
    source_pose: Pose | None = None
    compare_pose: Pose | None = None                  # the compared solver's pose (drawn as the ghost)
    ball_position: np.ndarray | None = None
    shown_flight: np.ndarray | None = None            # (K,3) the flight drawn: the adapted shot's or a take's
    shown_impact: Readouts | None = None              # whose impact the panel reads: ``readouts`` or a take's
    # interaction
    viewport: tuple = (0, 0, 1, 1)                    # (x, y, w, h) window pixels, top-left origin
    camera_still_s: float = 1.0                       # how long the camera has held still
    hover_target: bool = False
    dragging_target: bool = False
    cursor: str = "arrow"
    readouts: Readouts = field(default_factory=Readouts)
    timing: TimingDisplay = field(default_factory=TimingDisplay)
    messages: list = field(default_factory=list)      # [(time, text)] newest last
    errors: int = 0                                   # count of reported errors
    status: dict = field(default_factory=dict)        # piece -> "ok" / why it is missing
    gesture: str = ""                                 # the mouse gesture in the viewport: "target" | "orbit" | "pan" | ""
    pc_pad: PadState | None = None                    # the PC pad's model (app.pcpad), made by its first step
    pose_source: str = "adapted"                      # what the viewport shows: "adapted" | "source" | "pc pad"
    engine_warmup: EngineWarmup | None = None         # the engine compiling behind the window (app.warmup)
    # what the panel's capture section says
    last_capture: str = ""                            # the last screenshot or export written
    last_export: ExportNote | None = None             # how the last export went
    export_progress: float | None = None              # the export under way, 0..1 (None: none runs)
    session_line: str = ""                            # where the session autosaves (app.session)

    @property
    def shot(self):
        return self.shots[self.shot_index] if 0 <= self.shot_index < len(self.shots) else None

    @property
    def num_frames(self) -> int:
        shot = self.shot
        return shot.num_frames if shot is not None else 1

    @property
    def fps(self) -> float:
        shot = self.shot
        return float(shot.clip.fps) if shot is not None else 30.0

    def report(self, text: str) -> None:
        """Show a one-line message in the panel (errors never kill the window)."""
        line = str(text).strip().splitlines()[0] if str(text).strip() else "error"
        self.errors += 1
        if self.messages and self.messages[-1][1] == line:
            self.messages[-1] = (time.time(), line)
        else:
            self.messages.append((time.time(), line))
            del self.messages[:-6]
