"""Measurements of authored shots, shared by make_shots (diagnostics) and the tests.

Everything takes FK arrays: global rotations ``(F, J, 4)`` and positions ``(F, J, 3)``.
"""
from __future__ import annotations

import numpy as np

from engine import cleanup, quat


def _outside(a, lo, hi):
    """Degrees by which angles lie outside [lo, hi] on the circle (0 inside)."""
    d_lo = np.abs((lo - a + 180.0) % 360.0 - 180.0)
    d_hi = np.abs((a - hi + 180.0) % 360.0 - 180.0)
    return np.where((a >= lo) & (a <= hi), 0.0, np.minimum(d_lo, d_hi))


def dof_euler(rig, local_rotations: np.ndarray) -> np.ndarray:
    """Euler (z, y, x) degrees ``(F, J, 3)`` in whichever ZYX branch fits the
    rig's DOFs and limits: ``quat.to_euler`` keeps the middle angle within
    +/-90, so an elbow flexed 120 degrees (pure y) comes out as (180, -60, 180)
    while its other branch, (0, -120, 0), is the one the rig means."""
    e1 = quat.to_euler(np.asarray(local_rotations, float), "ZYX")
    e2 = (np.stack([e1[..., 0] + 180.0, 180.0 - e1[..., 1], e1[..., 2] + 180.0], -1) + 180.0) % 360.0 - 180.0
    lim = np.where(rig.dof[..., None], rig.limits, 0.0)
    s1 = _outside(e1, lim[..., 0], lim[..., 1]).sum(-1)
    s2 = _outside(e2, lim[..., 0], lim[..., 1]).sum(-1)
    return np.where((s2 < s1 - 1e-9)[..., None], e2, e1)


def euler_zyx(rig, local_rotations: np.ndarray) -> np.ndarray:
    """Euler (z, y, x) degrees ``(F, J, 3)`` as the bundled BVH files store them."""
    return dof_euler(rig, local_rotations)


def limit_violations(rig, local_rotations: np.ndarray, tol: float = 0.5) -> list[str]:
    """Human-readable list of limit / DOF violations beyond ``tol`` degrees."""
    e = dof_euler(rig, local_rotations)
    out = []
    J = rig.skeleton.num_joints
    for j in range(1, J):
        if not rig.skeleton.channel_orders[j]:
            continue
        for a, axis in enumerate("zyx"):
            v = e[:, j, a]
            if rig.dof[j, a]:
                lo, hi = rig.limits[j, a]
                bad = (v < lo - tol) | (v > hi + tol)
            else:
                lo = hi = 0.0
                bad = np.abs(v) > tol
            if np.any(bad):
                f = int(np.argmax(np.abs(np.where(bad, v - np.clip(v, lo, hi), 0))))
                out.append(f"{rig.skeleton.names[j]}.{axis} = {v[f]:.1f} at frame {f} "
                           f"(limits {lo:.0f}..{hi:.0f}, {int(bad.sum())} frames)")
    return out


def right_grip_points(rig, global_rotations, global_positions):
    """Where the right palm is ``(F, 3)`` and where it should be on the handle ``(F, 3)``."""
    sk = rig.skeleton
    lh, rh = sk.index("LeftHand"), sk.index("RightHand")
    grip = np.array(rig.bat["left_grip"], float)
    axis = np.array(rig.bat["axis"], float)
    want = global_positions[:, lh] + quat.rotate(global_rotations[:, lh],
                                                  grip + axis * rig.bat["right_grip_below_left"])
    right_palm = grip * np.array([-1.0, 1.0, 1.0])
    have = global_positions[:, rh] + quat.rotate(global_rotations[:, rh], right_palm)
    return have, want


def right_in_left(rig, global_rotations, global_positions):
    """Right hand position ``(F, 3)`` and rotation ``(F, 4)`` in the left hand's frame."""
    sk = rig.skeleton
    lh, rh = sk.index("LeftHand"), sk.index("RightHand")
    inv = quat.conjugate(global_rotations[:, lh])
    pos = quat.rotate(inv, global_positions[:, rh] - global_positions[:, lh])
    return pos, quat.mul(inv, global_rotations[:, rh])


def planted_runs(positions: np.ndarray, fps: float, height_tol: float = 0.5,
                 speed_tol: float = 6.0) -> list[tuple[int, int]]:
    """Runs of frames ``[a, b)`` where a foot joint ``(F, 3)`` is down (within ``height_tol``
    cm of its lowest height) and still (below ``speed_tol`` cm/s): the engine's detector
    with the authoring check's tighter tolerances."""
    return cleanup.planted_runs(positions, fps, height_tol, speed_tol)


def foot_drift(positions: np.ndarray, fps: float) -> float:
    """Largest horizontal drift (cm) of a foot joint within any planted run."""
    worst = 0.0
    for a, b in planted_runs(positions, fps):
        p = positions[a:b][:, [0, 2]]
        worst = max(worst, float(np.max(np.linalg.norm(p - p[0], axis=-1))))
    return worst


def centre_of_mass(rig, global_positions: np.ndarray) -> np.ndarray:
    """Approximate whole-body centre of mass ``(F, 3)`` (segment fractions after
    Winter's anthropometric tables: head 8.1 %, trunk 49.7 %, upper arm 2.8 %,
    forearm 1.6 %, hand 0.6 %, thigh 10 %, shank 4.65 %, foot 1.45 %)."""
    sk = rig.skeleton
    P = lambda n: global_positions[:, sk.index(n)]
    segs = [(0.081, P("Head")), (0.497, (P("Hips") + P("Spine2")) / 2)]
    for s in ("Left", "Right"):
        segs += [(0.028, (P(s + "Arm") + P(s + "ForeArm")) / 2),
                 (0.016, (P(s + "ForeArm") + P(s + "Hand")) / 2),
                 (0.006, P(s + "Hand")),
                 (0.100, (P(s + "UpLeg") + P(s + "Leg")) / 2),
                 (0.0465, (P(s + "Leg") + P(s + "Foot")) / 2),
                 (0.0145, (P(s + "Foot") + P(s + "ToeBase")) / 2)]
    m = sum(w for w, _ in segs)
    return sum(w * p for w, p in segs) / m
