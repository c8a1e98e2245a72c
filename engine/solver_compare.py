"""CCD vs DLS vs learnt vs learnt+CCD side by side (issue 17 item 5).

Every shot is adapted over a grid of offsets from its own hit point (each of
``distances`` cm along +-x, +-y, +-z) by each solver, and measured:

* ``bat_error_cm``: the bat joint's distance from the desired point at the hit frame;
* ``grip_error_cm``: the trail hand's largest distance from its source grip (any frame);
* ``limit_hits``: (frame, joint) pairs the adapted pose puts on or past one of the
  rig's joint limits (a free Euler axis within LIMIT_MARGIN_DEG of it, limit-branch
  angles) where the source pose was not;
* ``us_per_frame``: the whole shot's solve time (median of ``reps`` runs after one
  warm-up) over its frames;
* ``style_rmse``: the style error of 2.5.5 (the adapted shot in its source's first 3
  upper-body PCs, engine.pca.style_error);
* ``face_angle_deg``: the bat face's normal at the hit frame against the source's
  (engine.face.face_angle_deg).

Per shot and solver the median over offsets; over shots the median of those.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from . import pca as pcam
from .adapt import Adapter, AdaptSettings
from .ccd import limit_euler
from .face import face_angle_deg
from .learnt_solver import LearntSolver, SOLVERS

LIMIT_MARGIN_DEG = 0.1
METRICS = ("bat_error_cm", "grip_error_cm", "limit_hits", "us_per_frame", "style_rmse", "face_angle_deg")
AXES = np.eye(3)


def offset_grid(distances=(15.0, 30.0)) -> np.ndarray:
    """``(6 * len(distances), 3)`` offsets, cm: each distance along +-x, +-y, +-z."""
    return np.array([s * d * AXES[a] for a in range(3) for d in distances for s in (1.0, -1.0)])


def on_limits(rig, local_rotations: np.ndarray, wrist_dof: int = 0) -> np.ndarray:
    """``(..., J)`` bool: a free axis of the joint on or past its limit."""
    e = limit_euler(local_rotations, rig.limits)
    lo, hi = rig.limits[..., 0], rig.limits[..., 1]
    free = rig.dof_mask(wrist_dof) & (hi - lo > 2 * LIMIT_MARGIN_DEG)
    return (((e <= lo + LIMIT_MARGIN_DEG) | (e >= hi - LIMIT_MARGIN_DEG)) & free).any(-1)


def _timed(fn, reps: int):
    out = fn()
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, float(np.median(times))


def measure(rig, shot, adapter, solver: LearntSolver, desired, settings: AdaptSettings, leave_out: bool,
            style_space, source_on_limits, reps: int = 1) -> dict:
    """The METRICS of one shot adapted to ``desired`` by ``settings.solver``."""
    a, seconds = _timed(lambda: solver.adapt(adapter, desired, settings, leave_out), reps)
    h = shot.hit_frame
    hits = on_limits(rig, a.local_rotations, settings.wrist_dof) & ~source_on_limits
    face = face_angle_deg(a.global_rotations[h], shot.fk[0][h], rig.bat_joint, rig.bat["face_normal"])
    return {"bat_error_cm": float(a.bat_error_cm), "grip_error_cm": float(a.grip_error_cm.max()),
            "limit_hits": int(hits.sum()), "us_per_frame": seconds * 1e6 / shot.num_frames,
            "style_rmse": pcam.style_error(style_space, a.root_positions, a.local_rotations, 3),
            "face_angle_deg": float(face)}


def compare(rig, shots, distances=(15.0, 30.0), solvers=SOLVERS, settings: AdaptSettings | None = None,
            leave_out: bool = False, reps: int = 1) -> dict:
    """The comparison: ``{"offsets_cm", "solvers", "shots": [{name, solvers: {s: medians}}],
    "overall": {s: medians over shots}}`` (every figure finite; see the module's text)."""
    settings = settings or AdaptSettings()
    learnt = LearntSolver(rig, shots)
    grid = offset_grid(distances)
    rows, per_solver = [], {s: {m: [] for m in METRICS} for s in solvers}
    for shot in shots:
        adapter = Adapter(rig, shot)
        space = pcam.fit_clip(rig, shot.clip, "upper")
        src_limits = on_limits(rig, shot.clip.local_rotations, settings.wrist_dof)
        row = {}
        for s in solvers:
            got = [measure(rig, shot, adapter, learnt, shot.hit_point + off, replace(settings, solver=s),
                           leave_out, space, src_limits, reps) for off in grid]
            row[s] = {m: float(np.median([g[m] for g in got])) for m in METRICS}
            row[s]["bat_error_max_cm"] = float(max(g["bat_error_cm"] for g in got))
            for m in METRICS:
                per_solver[s][m].append(row[s][m])
        rows.append({"name": shot.name, "frames": shot.num_frames, "solvers": row})
    overall = {s: {m: float(np.median(v)) for m, v in per_solver[s].items()} for s in solvers}
    return {"offsets_cm": grid.tolist(), "solvers": list(solvers), "leave_out": bool(leave_out),
            "settings": {"falloff": settings.falloff, "wrist_dof": settings.wrist_dof, "twist": settings.twist},
            "metrics": list(METRICS), "shots": rows, "overall": overall}
