"""Orbit camera: a pivot, yaw/pitch/distance, a vertical field of view.

Matrices use the column-vector convention (``p_camera = view @ p_world``), as
``app.render.SceneView`` expects.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DEFAULT_PIVOT = (0.0, 95.0, 30.0)


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """World->camera matrix ``(4,4)`` float32 looking from ``eye`` at ``target``."""
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    if np.linalg.norm(s) < 1e-9:  # looking straight up/down: any side vector will do
        s = np.cross(f, (1.0, 0.0, 0.0))
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m.astype(np.float32)


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL perspective projection ``(4,4)`` float32."""
    t = 1.0 / np.tan(np.radians(fovy_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = t / aspect, t
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m.astype(np.float32)


@dataclass
class OrbitCamera:
    pivot: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_PIVOT))
    yaw: float = -38.0        # degrees about +Y; 0 looks from the bowler's end (+Z)
    pitch: float = 12.0       # degrees above the horizon
    distance: float = 560.0   # cm
    fovy: float = 38.0
    near: float = 5.0
    far: float = 12000.0

    def reset(self) -> None:
        fresh = OrbitCamera()
        self.pivot, self.yaw, self.pitch, self.distance = fresh.pivot, fresh.yaw, fresh.pitch, fresh.distance

    @property
    def eye(self) -> np.ndarray:
        yaw, pitch = np.radians(self.yaw), np.radians(self.pitch)
        direction = np.array([np.cos(pitch) * np.sin(yaw), np.sin(pitch), np.cos(pitch) * np.cos(yaw)])
        return self.pivot + self.distance * direction

    def view(self) -> np.ndarray:
        return look_at(self.eye, self.pivot)

    def proj(self, aspect: float) -> np.ndarray:
        return perspective(self.fovy, max(aspect, 1e-3), self.near, self.far)

    # -- mouse gestures (deltas in pixels) ---------------------------------
    def orbit(self, dx: float, dy: float) -> None:
        self.yaw = (self.yaw - 0.3 * dx + 180.0) % 360.0 - 180.0
        self.pitch = float(np.clip(self.pitch + 0.3 * dy, -5.0, 89.0))

    def pan(self, dx: float, dy: float, viewport_height: float) -> None:
        # One pixel moves the pivot by the size of a pixel at the pivot's depth.
        scale = 2 * self.distance * np.tan(np.radians(self.fovy) / 2) / max(viewport_height, 1.0)
        v = self.view()
        right, up = v[0, :3].astype(float), v[1, :3].astype(float)
        self.pivot = self.pivot + scale * (-dx * right + dy * up)
        self.pivot = np.clip(self.pivot, -3000.0, 3000.0)

    def zoom(self, steps: float) -> None:
        self.distance = float(np.clip(self.distance * 0.88 ** steps, 60.0, 5000.0))
