"""Small rotation maths for the shot authoring (tools/shots_ik and its helpers): rotation
matrices ``(..., 3, 3)`` whose columns are a frame's axes in its parent (or the world), degrees
in and out; quaternions (w, x, y, z) only through engine.quat."""
from __future__ import annotations

import numpy as np

from engine import quat


def unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors ``(..., 3)``."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def perp(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Component of ``v`` perpendicular to the unit ``axis`` (both ``(..., 3)``)."""
    return v - np.sum(v * axis, axis=-1, keepdims=True) * axis


def rot_axis(axis: int, deg: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` about a principal axis (0 x, 1 y, 2 z)."""
    return quat.to_matrix(quat._axis_quat(axis, np.asarray(deg, float)))


def turn(axis: np.ndarray, deg: float, v: np.ndarray) -> np.ndarray:
    """``v`` turned ``deg`` degrees about the unit ``axis`` (Rodrigues)."""
    a = np.radians(deg)
    return v * np.cos(a) + np.cross(axis, v) * np.sin(a) + axis * (axis @ v) * (1 - np.cos(a))


def frame_from_yz(y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Orthonormal frame with Y exactly along ``y`` and Z as close to ``z`` as possible."""
    Y = unit(y)
    Z = unit(perp(z, Y))
    X = np.cross(Y, Z)
    return np.stack([X, Y, Z], axis=-1)


def ypr(yaw, pitch, roll) -> np.ndarray:
    """World orientation of a body part from yaw (about world Y; 0 faces +Z),
    pitch (forward bend about the part's own X) and roll (about its own Z):
    R = Ry(yaw) Rx(pitch) Rz(roll), ``(F, 3, 3)``."""
    return rot_axis(1, yaw) @ rot_axis(0, pitch) @ rot_axis(2, roll)


def to_q(m: np.ndarray) -> np.ndarray:
    return quat.normalize(quat.from_matrix(m))


def euler(m: np.ndarray, order: str) -> np.ndarray:
    """Euler degrees of rotation matrices in ``order`` (R = R_o0 R_o1 R_o2)."""
    return quat.to_euler(to_q(m), order)


def rel(parent: np.ndarray, child: np.ndarray) -> np.ndarray:
    """Local rotation of ``child`` under ``parent`` (both global, ``(F, 3, 3)``)."""
    return np.swapaxes(parent, -1, -2) @ child


def split_rotation(m: np.ndarray, parts: int) -> np.ndarray:
    """The rotation whose ``parts``-th power is ``m`` (same axis, angle / parts)."""
    return quat.to_matrix(quat.exp(quat.log(to_q(m)) / parts))


# ----------------------------------------------------------------- two-bone IK
def two_bone(root: np.ndarray, target: np.ndarray, l1: float, l2: float,
             hint: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Middle-joint position for a two-bone chain ``(F, 3)``.

    The middle joint lies on the circle of solutions on the side of ``hint``.
    Returns (middle, reached_target, bend_dir) where ``bend_dir`` is the unit
    direction from the root-target line toward the middle joint.
    Out-of-reach targets are pulled in to 99.9 % of full extension.
    """
    d = target - root
    D = np.linalg.norm(d, axis=-1, keepdims=True)
    u = d / np.maximum(D, 1e-9)
    Dc = np.clip(D, abs(l1 - l2) + 1e-3, (l1 + l2) * 0.999)
    reached = root + u * Dc
    k = unit(perp(hint - root, u))
    a = (l1 * l1 - l2 * l2 + Dc * Dc) / (2 * Dc)
    h = np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))
    return root + a * u + h * k, reached, k


def look_rotation(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """A level head (no roll) whose +Z looks from ``eye`` at ``target``, ``(F, 3, 3)``."""
    z = unit(target - eye)
    x = unit(np.cross(np.array([0.0, 1.0, 0.0]), z))
    return np.stack([x, np.cross(z, x), z], -1)


def gaussian_smooth(x: np.ndarray, sigma: float, radius: int) -> np.ndarray:
    """``x (F, D)`` smoothed over frames by a normalised Gaussian (``sigma`` frames, taps
    -radius..radius), the ends held (edge padding)."""
    k = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    k /= k.sum()
    pad = np.pad(x, ((radius, radius), (0, 0)), mode="edge")
    return np.stack([np.convolve(pad[:, i], k, "valid") for i in range(x.shape[1])], -1)
