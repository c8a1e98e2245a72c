"""What the user asked for. The panel, the keys and the mouse write here; the
per-frame update (``app.update``) only reads it. Nothing derived lives here."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, fields

import numpy as np

from app.errors import UserError, number, position, shorten
from app.viewer.picking import TARGET_PLANE_Z, clamp_target
from engine import field as fielding
from engine.adapt import FACES, TWISTS, AdaptSettings
from engine.learnt_solver import SOLVERS

FALLOFF_RANGE = (20.0, 200.0)       # cm; the dissertation's useful band is 70-110
FALLOFF_BAND = (70.0, 110.0)
ITERATIONS_RANGE = (1, 500)
TOLERANCE_RANGE = (1e-4, 1.0)       # cm
SPEED_RANGE = (0.05, 4.0)
TRUNK_REACH_RANGE = (0.0, 45.0)     # deg a spine joint may turn from the source's, held
TRUNK_REACH_DEFAULT = 10.0
RENDER_SCALE_RANGE = (0.4, 1.0)     # 3D view resolution / window resolution (slow GPUs)
SLOW_MOTION_FACTOR = 0.25
GHOST_MODES = ("off", "mesh", "skeleton")
COMPARE_CHOICES = ("off",) + SOLVERS    # a second solver's pose, drawn as the ghost
WRIST_DOFS = (0, 2)
MAX_FRAME_SETTING = 1e6             # a playback frame far past any shot (playback clamps it to the shot)
MAX_SHOT_NAME_CHARS = 200           # a pinned shot's name
# What ``set`` checks beyond the type: ranges and choices per key.
SETTING_RANGES = {"falloff": FALLOFF_RANGE, "iterations": ITERATIONS_RANGE, "tolerance": TOLERANCE_RANGE,
                  "speed": SPEED_RANGE, "render_scale": RENDER_SCALE_RANGE, "frame": (0.0, MAX_FRAME_SETTING),
                  "direction": (-180.0, 180.0), "elevation": (-60.0, 60.0),
                  "trunk_reach": TRUNK_REACH_RANGE}
SETTING_CHOICES = {"solver": SOLVERS, "compare_solver": COMPARE_CHOICES, "twist": TWISTS, "face": FACES,
                   "overlays.ghost": GHOST_MODES, "wrist_dof": WRIST_DOFS}
# The overlay group is set field by field (``overlays.NAME``), never as a whole. One-off
# actions (screenshot, export, reload) are no settings: ``app.viewer.requests``.
NOT_SETTABLE = ("overlays",)


@dataclass
class Overlays:
    ghost: str = "mesh"             # source pose: "off" | "mesh" (translucent) | "skeleton"
    skeleton: bool = False          # adapted pose as lines on top of the mesh
    hit_points: bool = True         # the nine FK hit points, blue crosses
    ball_path: bool = True          # straight line from the ball's start to the target
    desired_point: bool = True
    bat_path: bool = True           # adapted bat over the whole shot
    source_bat_path: bool = True
    flight: bool = True             # ball after impact
    ball: bool = True
    target: bool = True             # the red-and-white target disc (what the user drags)
    pitch: bool = True


@dataclass
class ViewerSettings:
    # engine: the defaults are engine.adapt.AdaptSettings'
    falloff: float = AdaptSettings.falloff
    wrist_dof: int = AdaptSettings.wrist_dof
    solver: str = AdaptSettings.solver
    twist: str = AdaptSettings.twist
    face: str = AdaptSettings.face
    iterations: int = AdaptSettings.iterations
    tolerance: float = AdaptSettings.tolerance
    fix_right_hand: bool = AdaptSettings.fix_right_hand
    hold_trunk: bool = False          # the spine within trunk_reach deg a joint of the source's (AdaptSettings)
    trunk_reach: float = TRUNK_REACH_DEFAULT
    carry_lean: bool = AdaptSettings.carry_lean   # the hit's lean carried to the frames round it (engine.carry)
    learnt_leave_out: bool = False    # learnt solvers: the model trained without the shot it adapts
    compare_solver: str = "off"       # "off" or a solver whose adapted pose the ghost shows instead of the source
    # scene
    target: np.ndarray = field(default_factory=lambda: np.array([0.0, 60.0, TARGET_PLANE_Z]))
    pinned_shot: str | None = None  # None: chosen by the ball path
    # "hit it that way" (engine.direction): the ball's azimuth asked for, deg (0 straight, + off side)
    aim_direction: bool = False
    direction: float = 0.0
    # with a direction asked: the ball's elevation asked too (deg above the ground; the face tilted)
    aim_elevation: bool = False
    elevation: float = 0.0
    # playback (frame is fractional: slow motion shows in-between poses)
    frame: float = 0.0
    playing: bool = False
    speed: float = 1.0
    slow_motion: bool = False
    loop: bool = True
    overlays: Overlays = field(default_factory=Overlays)
    render_scale: float = 1.0
    clean_video: bool = False         # exports render the batsman and the ball without the editing aids
    antialias: bool = False           # FXAA over the moving things (~3 ms on llvmpipe); the static scene is
                                      # multisampled whenever the camera holds still (app.submit)

    def sanitise(self) -> None:
        """Clamp everything into range (scripts and sliders can send anything)."""
        d = AdaptSettings
        self.falloff = _clamp(_finite(self.falloff, d.falloff), *FALLOFF_RANGE)
        self.wrist_dof = 2 if int(_finite(self.wrist_dof, d.wrist_dof)) == 2 else 0
        self.solver = self.solver if self.solver in SOLVERS else d.solver
        self.compare_solver = self.compare_solver if self.compare_solver in COMPARE_CHOICES else "off"
        self.twist = self.twist if self.twist in TWISTS else d.twist
        self.face = self.face if self.face in FACES else d.face
        self.iterations = int(_clamp(_finite(self.iterations, d.iterations), *ITERATIONS_RANGE))
        self.tolerance = _clamp(_finite(self.tolerance, d.tolerance), *TOLERANCE_RANGE)
        self.speed = _clamp(_finite(self.speed, 1.0), *SPEED_RANGE)
        self.frame = float(max(_finite(self.frame, 0.0), 0.0))
        self.render_scale = _clamp(_finite(self.render_scale, 1.0), *RENDER_SCALE_RANGE)
        self.direction = _clamp(_finite(self.direction, 0.0), -180.0, 180.0)
        self.elevation = _clamp(_finite(self.elevation, 0.0), -60.0, 60.0)
        self.trunk_reach = _clamp(_finite(self.trunk_reach, TRUNK_REACH_DEFAULT), *TRUNK_REACH_RANGE)
        t = np.asarray(self.target, float).reshape(-1)[:3]
        self.target = clamp_target(t if t.size == 3 and np.isfinite(t).all() else (0.0, 60.0, 0.0))
        if self.overlays.ghost not in GHOST_MODES:
            self.overlays.ghost = "mesh"

    def adapt_settings(self):
        """The engine's view of these settings (``engine.adapt.AdaptSettings``)."""
        return AdaptSettings(falloff=self.falloff, wrist_dof=self.wrist_dof, solver=self.solver,
                             iterations=self.iterations, tolerance=self.tolerance,
                             fix_right_hand=self.fix_right_hand, twist=self.twist, face=self.face,
                             trunk_reach=self.trunk_reach if self.hold_trunk else math.inf,
                             carry_lean=bool(self.carry_lean))

    def aim_key(self) -> tuple | None:
        """The engine key with the asked direction, or None when no direction is asked."""
        if not self.aim_direction:
            return None
        return self.engine_key() + (round(self.direction, 3),) + ((round(self.elevation, 3),) if self.aim_elevation else ())

    def asked_elevation(self) -> float | None:
        """The elevation asked with the direction (deg), or None."""
        return self.elevation if self.aim_direction and self.aim_elevation else None

    def engine_key(self) -> tuple:
        """Everything the adaptation depends on; a change means re-solve."""
        return (tuple(np.round(self.target, 6)), self.pinned_shot, self.falloff, self.wrist_dof,
                self.solver, self.iterations, self.tolerance, self.fix_right_hand, self.twist,
                self.learnt_leave_out, self.face, self.hold_trunk and self.trunk_reach, bool(self.carry_lean))

    def compare_key(self) -> tuple | None:
        """The engine key with the compared solver, or None when no comparison is asked."""
        return None if self.compare_solver == "off" else self.engine_key() + (self.compare_solver,)

    @property
    def playback_rate(self) -> float:
        return self.speed * (SLOW_MOTION_FACTOR if self.slow_motion else 1.0)

    def set(self, key: str, value) -> None:
        """Set one setting by name (``overlays.flight`` for overlays) - used by scripts.
        ``value`` goes through :func:`check_setting` (UserError if it is no such
        setting or a wrong value); a value that passed it once never fails here. A
        ``direction`` set asks for it, as the CLI's ``--direction`` and a click on the wagon
        wheel do (``aim_direction`` false drops it again); an ``elevation`` set asks for it
        with the direction asked (``aim_elevation``)."""
        value = check_setting(key, value)
        obj, name = (self.overlays, key.split(".", 1)[1]) if key.startswith("overlays.") else (self, key)
        setattr(obj, name, value.copy() if isinstance(value, np.ndarray) else value)
        if key in ("direction", "elevation"):
            setattr(self, "aim_" + key, True)
        self.sanitise()


@functools.cache
def setting_kinds() -> dict[str, str]:
    """``{key: type name}`` of every setting ``set`` accepts: the dataclass fields of
    ViewerSettings and (as ``overlays.NAME``) Overlays, but no method or private field. The type names are the fields' annotations."""
    kinds = {f.name: str(f.type) for f in fields(ViewerSettings) if f.name not in NOT_SETTABLE}
    kinds.update({f"overlays.{f.name}": str(f.type) for f in fields(Overlays)})
    return {k: t for k, t in kinds.items() if not k.rsplit(".", 1)[-1].startswith("_")}


def check_setting(key, value):
    """``value`` for setting ``key`` as it will be stored, or UserError naming both:
    a bool only from true/false, an int from a whole JSON number, a float from a
    finite one, each within its SETTING_RANGES (the direction also a fielding position's
    name, engine.field); a string from SETTING_CHOICES;
    the target as 3 finite numbers (cm); the pinned shot a name or null."""
    kinds = setting_kinds()
    if not isinstance(key, str) or key not in kinds:
        top = [k for k in kinds if "." not in k]
        groups = "|".join(k.split(".", 1)[1] for k in kinds if k.startswith("overlays."))
        raise UserError(f"unknown setting {shorten(repr(key))} (known: {', '.join(top)}, overlays.{groups})")
    kind, low_high = kinds[key], SETTING_RANGES.get(key, (None, None))
    if kind == "bool":
        if not isinstance(value, bool):
            raise UserError(f"{key} must be true or false, got {shorten(repr(value))}")
        return value
    if key == "direction" and isinstance(value, str):
        try:                                            # as the CLI's --direction: "mid-off"
            return fielding.position_azimuth(value)
        except ValueError:
            raise UserError(f"direction must be degrees or a fielding position "
                            f"({', '.join(fielding.POSITIONS)}), got {shorten(repr(value))}") from None
    if kind in ("int", "float"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (kind == "int" and isinstance(value, float)):
            raise UserError(f"{key} must be {'a whole number' if kind == 'int' else 'a number'}, "
                            f"got {shorten(repr(value))}")
        return number(key, value, *low_high, integer=kind == "int", choices=SETTING_CHOICES.get(key))
    if kind == "str":
        choices = SETTING_CHOICES[key]
        if not isinstance(value, str) or value not in choices:
            raise UserError(f"{key} must be {' or '.join(choices)}, got {shorten(repr(value))}")
        return value
    if kind == "np.ndarray":
        if not isinstance(value, (list, tuple, np.ndarray)) or any(   # an array: a value this check returned
                isinstance(v, bool) or not isinstance(v, (int, float)) for v in np.asarray(value, object).reshape(-1)):
            raise UserError(f"{key} must be a list of 3 numbers (X Y Z cm), got {shorten(repr(value))}")
        return np.array(position(key, value), float)
    if kind == "str | None":
        if value is not None and (not isinstance(value, str) or len(value) > MAX_SHOT_NAME_CHARS):
            raise UserError(f"{key} must be a shot name (up to {MAX_SHOT_NAME_CHARS} characters) or null, "
                            f"got {shorten(repr(value))}")
        return value
    raise UserError(f"{key} cannot be set by name")      # a field of a type added later


def _finite(v, default):
    try:
        f = float(v)
    except (TypeError, ValueError):
        return default
    return f if math.isfinite(f) else default


def _clamp(v: float, lo: float, hi: float) -> float:
    """``v`` in [lo, hi], as a Python float (np.clip on a scalar costs ~10x; this runs every frame)."""
    return float(min(max(v, lo), hi))
