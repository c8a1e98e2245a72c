"""Writing a take (a skeleton and a clip) to the formats users load elsewhere:
BVH, CSV and glTF (binary .glb or .gltf). One entry point, :func:`write_take`,
chosen by the file's extension; every writer is atomic."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from . import bvh, quat
from .gltf_export import EXTENSIONS as GLTF_EXTENSIONS
from .skeleton import Clip, Skeleton

EXTENSIONS = (".bvh", ".csv") + GLTF_EXTENSIONS


def write_take(out: str | Path, skeleton: Skeleton, clip: Clip, *, name: str, limits: np.ndarray | None = None,
               blend: np.ndarray | None = None, reference: np.ndarray | None = None, takes: list | None = None,
               csv_rotations: str = "euler", csv_all_columns: bool = False) -> None:
    """Write ``clip`` on ``skeleton`` to ``out`` (format by extension).

    ``name`` names the animation (glTF); BVH and CSV Euler angles are continuous
    over frames (:func:`engine.bvh.file_euler`), from the branch inside ``limits``
    (J, 3, 2) degrees (each joint's channel order) at frame 0, keeping
    ``reference`` (F, J, 3) -- the source file's numbers -- where the rotation is
    unchanged; ``blend`` (F,) is the importance blend written as the CSV's second
    column. ``takes``: the glTF's animations (:func:`shot_takes`: the adapted
    take and the source, with the ball); default one take, ``clip``.
    ``csv_rotations`` "euler" (degrees) or "quaternion"; ``csv_all_columns`` keeps
    columns that are zero in every frame (see :func:`csv_columns`)."""
    suffix = Path(out).suffix.lower()
    if suffix == ".bvh":
        bvh.write(out, skeleton, clip, limits=limits, reference=reference)
    elif suffix in (".glb", ".gltf"):
        from .gltf_export import write_gltf  # pygltflib: only when a glTF is written
        write_gltf(out, skeleton, clip if takes is None else takes, name=name)
    elif suffix == ".csv":
        write_csv(out, skeleton, clip, limits, blend, reference, csv_rotations, csv_all_columns)
    else:
        raise ValueError(f"unknown extension {suffix or '(none)'!r} (use {', '.join(EXTENSIONS)})")


CSV_ROTATIONS = ("euler", "quaternion")


def csv_columns(skeleton: Skeleton, clip: Clip, limits: np.ndarray | None = None, blend: np.ndarray | None = None,
                reference: np.ndarray | None = None, rotations: str = "euler",
                all_columns: bool = False) -> tuple[list[str], np.ndarray]:
    """The CSV's header names and values ``(F, C)``: ``frame``, ``time_s``, ``blend``
    (when given), ``root_x_cm``.., then per joint in the skeleton's order either its
    Euler angles in its channel order (``LeftArm_rz_deg, LeftArm_ry_deg,
    LeftArm_rx_deg`` for ZYX: R = Rz Ry Rx, the BVH's numbers) or its quaternion
    (``LeftArm_qw..qz``, signs continuous). Columns that are zero in every frame
    (a locked axis, the fixed Bat) are left out unless ``all_columns``."""
    if rotations not in CSV_ROTATIONS:
        raise ValueError(f"CSV rotations must be one of {', '.join(CSV_ROTATIONS)}, got {rotations!r}")
    F = clip.num_frames
    names = ["frame", "time_s"] + ([] if blend is None else ["blend"]) + [f"root_{a}_cm" for a in "xyz"]
    cols = [np.arange(F), np.arange(F) / clip.fps] + ([] if blend is None else [np.asarray(blend, float)])
    cols += list(np.asarray(clip.root_positions, float).T)
    if rotations == "euler":
        e = bvh.file_euler(skeleton, clip, limits, reference)
        for j, (joint, order) in enumerate(zip(skeleton.names, skeleton.channel_orders)):
            names += [f"{joint}_r{a.lower()}_deg" for a in order]
            cols += [e[:, j, k] for k in range(len(order))]
    else:
        q = quat.make_continuous(quat.normalize(clip.local_rotations), axis=0)
        for j, joint in enumerate(skeleton.names):
            names += [f"{joint}_q{a}" for a in "wxyz"]
            cols += list(q[:, j].T)
    data = np.stack(cols, 1)
    keep = [i for i, n in enumerate(names) if all_columns or i < 2 or np.any(np.round(data[:, i], 6) != 0)]
    return [names[i] for i in keep], data[:, keep]


def write_csv(out, skeleton: Skeleton, clip: Clip, limits: np.ndarray | None, blend: np.ndarray | None,
              reference: np.ndarray | None = None, rotations: str = "euler", all_columns: bool = False) -> None:
    """One row a frame, the columns of :func:`csv_columns` (6 decimals), atomically."""
    names, data = csv_columns(skeleton, clip, limits, blend, reference, rotations, all_columns)
    buf = io.StringIO()
    np.savetxt(buf, data, fmt=["%d"] + ["%.6f"] * (len(names) - 1), delimiter=",", header=",".join(names),
               comments="")
    bvh.atomic_write_text(out, buf.getvalue().replace("-0.000000", "0.000000"))


def ball_track(rig, shot, clip: Clip, hit_point: np.ndarray, ball_start: np.ndarray, hit_frame: int | None = None,
               flight_path: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ball of a take ``(K,)`` s and ``(K, 3)`` cm: on its straight line from
    ``ball_start``, at ``hit_point`` exactly at the hit frame (the shot's, or ``hit_frame``),
    then its flight (``flight_path``, samples 1/120 s apart; by default off the bat,
    engine.ballistics.shot_flight) to the end of the clip."""
    from . import ballistics  # numba: only when a glTF with the ball is written
    from .skeleton import clip_fk
    h = shot.hit_frame if hit_frame is None else int(hit_frame)
    fps, F = clip.fps, clip.num_frames
    before = np.arange(h + 1)
    incoming = ballistics.incoming_ball(ball_start, hit_point, h, before, fps)
    after = max(F - 1 - h, 0) / fps
    if flight_path is None:
        g_rot, g_pos = clip_fk(shot.skeleton, clip)
        flight_path = ballistics.shot_flight(rig, shot, g_rot, g_pos, ball_start, hit_point, duration=after,
                                             hit_frame=h)[0].path
    dt = ballistics.FLY_DT                            # the flight's own sampling (Flight.path)
    k = np.arange(1, len(flight_path))
    keep = k * dt <= after + 1e-9
    times = np.concatenate([before / fps, h / fps + k[keep] * dt])
    return times, np.concatenate([incoming, np.asarray(flight_path)[1:][keep]])


def take_animation(rig, shot, clip: Clip, kind: str, name: str, hit_point: np.ndarray, ball_start: np.ndarray,
                   hit_frame: int | None = None, flight_path: np.ndarray | None = None):
    """One animation of a glTF (engine.gltf_export.Take): ``clip`` with its ball (:func:`ball_track`)
    and its extras (take ``kind``, shot, fps, hit frame and time, hit point in m and cm, units)."""
    from .gltf_export import METRES_PER_CM, Take
    h = shot.hit_frame if hit_frame is None else int(hit_frame)
    cm = [round(float(v), 2) for v in hit_point]
    times, ball = ball_track(rig, shot, clip, np.asarray(hit_point, float), ball_start, h, flight_path)
    extras = {"take": kind, "shot": shot.name, "hit_frame": h, "hit_time_s": round(h / clip.fps, 6),
              "hit_point_cm": cm, "hit_point_m": [round(v * METRES_PER_CM, 6) for v in cm],
              "frame_numbering": "frame n at n / fps s (frame 0 at 0 s): Blender at the same frame rate "
                                 "shows frame n at its frame n"}
    return Take(name, clip, extras, times, ball)


def shot_takes(rig, shot, clip: Clip, hit_point: np.ndarray, ball_start: np.ndarray,
               source_hit_point: np.ndarray | None = None) -> list:
    """The two animations of an adapted shot's glTF: the adapted ``clip`` (meeting
    ``hit_point``, cm) and the source, each with its ball (:func:`take_animation`)."""
    from .skeleton import clip_fk
    src_point = clip_fk(shot.skeleton, shot.clip)[1][shot.hit_frame, shot.bat_joint] \
        if source_hit_point is None else np.asarray(source_hit_point, float)
    point = np.asarray(hit_point, float)
    return [take_animation(rig, shot, clip, "adapted", f"{shot.name}_hit_{'_'.join(f'{v:.0f}' for v in point)}cm",
                           point, ball_start),
            take_animation(rig, shot, shot.clip, "source", f"{shot.name}_source", src_point, ball_start)]
