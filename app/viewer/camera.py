"""Orbit camera: a pivot, yaw/pitch/distance, a vertical field of view.

Matrices use the column-vector convention (``p_camera = view @ p_world``), as
``app.render.SceneView`` expects.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.render.scene import look_at, perspective  # noqa: F401  (one definition, shared)

DEFAULT_PIVOT = (0.0, 95.0, 30.0)


@dataclass
class OrbitCamera:
    pivot: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_PIVOT))
    yaw: float = -38.0        # degrees about +Y; 0 looks from the bowler's end (+Z)
    pitch: float = 12.0       # degrees above the horizon
    distance: float = 560.0   # cm
    fovy: float = 38.0
    # the default window's scene viewport (920 x 674 px): in a narrower one (a window snapped to
    # half a screen, a portrait one) the view keeps this one's horizontal field of view, so the
    # batsman is not cut off at the sides
    min_aspect: float = 920.0 / 674.0
    near: float = 5.0
    far: float = 12000.0
    _view_cache: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def reset(self) -> None:
        fresh = OrbitCamera()
        self.pivot, self.yaw, self.pitch, self.distance = fresh.pivot, fresh.yaw, fresh.pitch, fresh.distance

    @property
    def eye(self) -> np.ndarray:
        yaw, pitch = np.radians(self.yaw), np.radians(self.pitch)
        direction = np.array([np.cos(pitch) * np.sin(yaw), np.sin(pitch), np.cos(pitch) * np.cos(yaw)])
        return self.pivot + self.distance * direction

    def view(self) -> np.ndarray:
        """World->camera ``(4,4)``; remembered for the last pose (asked for several times a frame)."""
        key = (*np.asarray(self.pivot, float).tolist(), float(self.yaw), float(self.pitch), float(self.distance))
        if self._view_cache is None or self._view_cache[0] != key:
            self._view_cache = (key, look_at(self.eye, self.pivot))
        return self._view_cache[1].copy()

    def fovy_for(self, aspect: float) -> float:
        """The vertical field of view (deg) at viewport ``aspect`` (width / height): ``fovy``,
        widened below ``min_aspect`` to keep the horizontal one (at most 150)."""
        aspect = max(aspect, 1e-3)
        if aspect >= self.min_aspect:
            return self.fovy
        half = np.arctan(np.tan(np.radians(self.fovy) / 2) * self.min_aspect / aspect)
        return float(min(np.degrees(2 * half), 150.0))

    def proj(self, aspect: float) -> np.ndarray:
        return perspective(self.fovy_for(aspect), max(aspect, 1e-3), self.near, self.far)

    # -- mouse gestures (deltas in pixels) ---------------------------------
    def orbit(self, dx: float, dy: float) -> None:
        self.yaw = (self.yaw - 0.3 * dx + 180.0) % 360.0 - 180.0
        self.pitch = float(np.clip(self.pitch + 0.3 * dy, -5.0, 89.0))

    def pan(self, dx: float, dy: float, viewport_width: float, viewport_height: float) -> None:
        # One pixel moves the pivot by the size of a pixel at the pivot's depth.
        fovy = self.fovy_for(viewport_width / max(viewport_height, 1.0))
        scale = 2 * self.distance * np.tan(np.radians(fovy) / 2) / max(viewport_height, 1.0)
        v = self.view()
        right, up = v[0, :3].astype(float), v[1, :3].astype(float)
        self.pivot = self.pivot + scale * (-dx * right + dy * up)
        self.pivot = np.clip(self.pivot, -3000.0, 3000.0)

    def zoom(self, steps: float) -> None:
        self.distance = float(np.clip(self.distance * 0.88 ** steps, 60.0, 5000.0))
