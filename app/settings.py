"""What the user asked for. The panel, the keys and the mouse write here; the
per-frame update (``app.update``) only reads it. Nothing derived lives here."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from app.picking import TARGET_PLANE_Z, clamp_target

FALLOFF_RANGE = (20.0, 200.0)       # cm; the dissertation's useful band is 70-110
FALLOFF_BAND = (70.0, 110.0)
ITERATIONS_RANGE = (1, 500)
TOLERANCE_RANGE = (1e-4, 1.0)       # cm
SPEED_RANGE = (0.05, 4.0)
RENDER_SCALE_RANGE = (0.4, 1.0)     # 3D view resolution / window resolution (slow GPUs)
SLOW_MOTION_FACTOR = 0.25
GHOST_MODES = ("off", "mesh", "skeleton")
SOLVERS = ("ccd", "dls")


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
    pitch: bool = True


@dataclass
class ViewerSettings:
    # engine (engine.adapt.AdaptSettings)
    falloff: float = 90.0
    wrist_dof: int = 0
    solver: str = "ccd"
    iterations: int = 200
    tolerance: float = 0.001
    fix_right_hand: bool = True
    # scene
    target: np.ndarray = field(default_factory=lambda: np.array([0.0, 60.0, TARGET_PLANE_Z]))
    pinned_shot: str | None = None  # None: chosen by the ball path
    # playback (frame is fractional: slow motion shows in-between poses)
    frame: float = 0.0
    playing: bool = False
    speed: float = 1.0
    slow_motion: bool = False
    loop: bool = True
    overlays: Overlays = field(default_factory=Overlays)
    render_scale: float = 1.0
    antialias: bool = False           # FXAA over the moving things (~3 ms on llvmpipe); the static scene is
                                      # multisampled whenever the camera holds still (app.submit)
    # capture requests, consumed by the loop
    screenshot_requested: bool = False
    export_requested: bool = False
    reload_requested: bool = False    # re-read the shot library (a bad file keeps the old one)

    def sanitise(self) -> None:
        """Clamp everything into range (scripts and sliders can send anything)."""
        self.falloff = _clamp(_finite(self.falloff, 90.0), *FALLOFF_RANGE)
        self.wrist_dof = 2 if int(_finite(self.wrist_dof, 0)) == 2 else 0
        self.solver = self.solver if self.solver in SOLVERS else "ccd"
        self.iterations = int(_clamp(_finite(self.iterations, 200), *ITERATIONS_RANGE))
        self.tolerance = _clamp(_finite(self.tolerance, 1e-3), *TOLERANCE_RANGE)
        self.speed = _clamp(_finite(self.speed, 1.0), *SPEED_RANGE)
        self.frame = float(max(_finite(self.frame, 0.0), 0.0))
        self.render_scale = _clamp(_finite(self.render_scale, 1.0), *RENDER_SCALE_RANGE)
        t = np.asarray(self.target, float).reshape(-1)[:3]
        self.target = clamp_target(t if t.size == 3 and np.isfinite(t).all() else (0.0, 60.0, 0.0))
        if self.overlays.ghost not in GHOST_MODES:
            self.overlays.ghost = "mesh"

    def adapt_settings(self):
        """The engine's view of these settings (``engine.adapt.AdaptSettings``)."""
        from engine.adapt import AdaptSettings
        return AdaptSettings(falloff=self.falloff, wrist_dof=self.wrist_dof, solver=self.solver,
                             iterations=self.iterations, tolerance=self.tolerance,
                             fix_right_hand=self.fix_right_hand)

    def engine_key(self) -> tuple:
        """Everything the adaptation depends on; a change means re-solve."""
        return (tuple(np.round(self.target, 6)), self.pinned_shot, self.falloff, self.wrist_dof,
                self.solver, self.iterations, self.tolerance, self.fix_right_hand)

    @property
    def playback_rate(self) -> float:
        return self.speed * (SLOW_MOTION_FACTOR if self.slow_motion else 1.0)

    def set(self, key: str, value) -> None:
        """Set one setting by name (``overlays.flight`` for overlays) - used by scripts."""
        obj, name = (self.overlays, key.split(".", 1)[1]) if key.startswith("overlays.") else (self, key)
        if not hasattr(obj, name) or name.startswith("_"):
            raise KeyError(f"unknown setting {key!r}")
        current = getattr(obj, name)
        if isinstance(current, bool):
            value = bool(value)
        elif isinstance(current, int):
            value = int(value)
        elif isinstance(current, float):
            value = float(value)
        elif isinstance(current, np.ndarray):
            value = np.asarray(value, float)
        setattr(obj, name, value)
        self.sanitise()


def _finite(v, default):
    try:
        f = float(v)
    except (TypeError, ValueError):
        return default
    return f if math.isfinite(f) else default


def _clamp(v: float, lo: float, hi: float) -> float:
    """``v`` in [lo, hi], as a Python float (np.clip on a scalar costs ~10x; this runs every frame)."""
    return float(min(max(v, lo), hi))
