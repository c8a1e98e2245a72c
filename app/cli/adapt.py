"""``hitpoint adapt``: adapt a library shot to a new hit point, print a JSON summary."""
from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from app.errors import UserError, cli_errors, number, position, shorten
from app.errors import falloff as falloff_cm
from app.errors import trunk_reach as trunk_reach_deg
from engine import choice, field
from engine.export import EXTENSIONS, write_take
from engine.library import find_shot
from engine.userlib import load_shots
from engine.skeleton import Clip

WRIST_DOFS = (0, 2)   # the left wrist locked, or free in two axes


def run_adapt(target=None, shot_name=None, hit=None, falloff=90.0, wrist_dof=0, solver="ccd",
              twist="follow", direction=None, elevation=None, out: Optional[Path] = None, bvh=None,
              profile="auto",
              hit_frame="auto", handed=None, scale=None, offset=None, library=None,
              csv_rotations="euler", leave_out=False, facing="auto", trunk_reach=None, carry_lean=True) -> dict:
    """The adapt command's work, returned as the JSON-able summary."""
    from engine.adapt import Adapter, AdaptSettings  # numba (0.25 s): when the command runs
    from engine.learnt_solver import LEARNT_SOLVERS, LearntSolver, check

    if out is not None:
        check_out(out)
    if elevation is not None and (direction is None or bvh is not None):
        raise UserError("--elevation goes with --direction AZ (the ball's azimuth and elevation together)")
    settings = AdaptSettings(falloff=falloff, wrist_dof=wrist_dof, solver=solver, twist=twist,
                             trunk_reach=math.inf if trunk_reach is None else trunk_reach, carry_lean=carry_lean)
    check(settings)
    learnt = solver in LEARNT_SOLVERS
    if leave_out and not learnt:
        raise UserError("--leave-out goes with --solver learnt or learnt+ccd (the model's training)")
    if learnt and direction is not None:
        raise UserError("--direction is solved by ccd or dls, not by the learnt solvers")
    if bvh is not None:
        if target is not None or shot_name is not None or library is not None:
            raise UserError("--bvh adapts one capture: give --offset or --hit, not --target, --shot or --library")
        return run_capture(Path(bvh), settings, profile, hit_frame, handed, scale, offset, hit, out, leave_out,
                           facing)
    if offset is not None:
        raise UserError("--offset goes with --bvh FILE (with --shot, give --hit X Y Z)")
    if facing != "auto":
        raise UserError("--facing goes with --bvh FILE (a library's captures: hitpoint library init --facing)")
    rig, shots = load_shots(library)
    shot, desired = _pick_shot(shots, target, shot_name, hit)
    adapter = Adapter(rig, shot)
    solver_ = LearntSolver(rig, shots)
    solver_.adapt(adapter, desired, settings, leave_out)  # compile / load the kernels, train, before timing
    t0 = time.perf_counter()
    aimed = None
    if direction is None:
        a = solver_.adapt(adapter, desired, settings, leave_out)
    else:
        from engine.direction import aim
        aimed = aim(rig, shot, desired, direction, settings, elevation_deg=elevation)
        a = aimed.adaptation
    solve_ms = (time.perf_counter() - t0) * 1e3
    if out is not None and shot.capture is not None:
        shot.capture.write(out, a.local_rotations, a.root_positions, a.blend, f"{shot.name}_adapted")
    elif out is not None:
        _write(out, rig, shot, a, csv_rotations)
    return {**_summary(rig, shot, a, target, aimed), "falloff": falloff, "wrist_dof": wrist_dof, "solver": solver,
            "trunk_reach_deg": trunk_reach, "carry_lean": carry_lean,
            **(learnt_summary(solver_, shot, leave_out) if learnt else {}),
            "solve_ms": round(solve_ms, 3), "out": None if out is None else str(out)}


def _pick_shot(shots, target, shot_name, hit):
    """(the shot, the desired hit point): chosen by the ball's path to ``target`` (2.5.1), or named."""
    if target is not None:
        if shot_name is not None or hit is not None:
            raise UserError("give either --target, or --shot with --hit, not both")
        idx, desired = choice.choose_shot([s.hit_point for s in shots], choice.BALL_START, target)
        return shots[idx], desired
    if shot_name is None or hit is None:
        raise UserError("give --target X Y Z, or --shot NAME with --hit X Y Z")
    return find_shot(shots, shot_name), np.asarray(hit, float)


def _summary(rig, shot, a, target, aimed) -> dict:
    """The JSON fields of an adaptation: hit points, errors, the blend, what the ball does and,
    when a direction was asked, how far it was met."""
    r = lambda v: [round(float(x), 4) for x in v]  # noqa: E731
    out = {
        "shot": shot.name, "hit_frame": shot.hit_frame, "frames": shot.num_frames,
        "source_hit_point": r(shot.hit_point), "desired_hit_point": r(a.desired_hit_point),
        "target": None if target is None else r(target),
        "bat_error_cm": round(a.bat_error_cm, 6), "blend": r(a.blend),
        "grip_error_cm": r(a.grip_error_cm), "grip_error_deg": r(a.grip_error_deg),
        "max_grip_error_cm": round(float(a.grip_error_cm.max()), 4),
        "max_grip_error_deg": round(float(a.grip_error_deg.max()), 4),
    }
    if "face_normal" in rig.bat:
        out.update(hit_summary(rig, shot, a.global_rotations, a.global_positions, choice.BALL_START,
                               a.desired_hit_point))
        out["ball_region"] = field.region(out["ball_azimuth_deg"])
    if aimed is not None:
        out.update({"direction_requested_deg": round(aimed.requested_deg, 2),
                    "direction_requested_region": field.region(aimed.requested_deg), "direction_reached": aimed.reached,
                    "direction_range_deg": [round(v, 1) for v in aimed.range_deg],
                    "face_yaw_deg": round(aimed.yaw_deg, 2), "forearm_twist_deg": round(aimed.twist_deg, 2)})
    if aimed is not None and aimed.requested_elevation_deg is not None:
        out.update({"elevation_requested_deg": round(aimed.requested_elevation_deg, 2),
                    "elevation_reached": aimed.elevation_reached,
                    "elevation_range_deg": [round(v, 1) for v in aimed.elevation_range_deg],
                    "face_tilt_deg": round(aimed.tilt_deg, 2)})
    return out


def run_capture(path: Path, settings, profile, hit_frame, handed, scale, offset, hit, out,
                leave_out=False, facing="auto") -> dict:
    """``adapt --bvh``: a capture on its own skeleton, moved by ``offset`` (or to ``hit``) at its
    hit frame, written back on its own skeleton and units (a learnt solver learns from it)."""
    from engine.adapt import Adapter
    from engine.capture import load_capture
    from engine.learnt_solver import LEARNT_SOLVERS, LearntSolver

    if (offset is None) == (hit is None):
        raise UserError("--bvh needs --offset DX DY DZ or --hit X Y Z (cm), one of them")
    cap = load_capture(path, profile, hit_frame, handed, scale, facing)
    source = cap.shot.hit_point
    desired = source + np.asarray(offset, float) if offset is not None else np.asarray(hit, float)
    adapter = Adapter(cap.rig, cap.shot)
    solver = LearntSolver(cap.rig, [cap.shot])
    if settings.solver in LEARNT_SOLVERS:     # trained and compiled before timing
        solver.adapt(adapter, desired, settings, leave_out)
    t0 = time.perf_counter()
    a = solver.adapt(adapter, desired, settings, leave_out)
    solve_ms = (time.perf_counter() - t0) * 1e3
    if out is not None:
        cap.write(out, a.local_rotations, a.root_positions, a.blend)
    r = lambda v: [round(float(x), 4) for x in v]  # noqa: E731
    rig = cap.rig
    return {
        "bvh": str(path), "profile": cap.profile.name, "handedness": cap.profile.handedness,
        "scale": cap.scale, "units": "cm", "frames": cap.shot.num_frames, "fps": round(cap.shot.clip.fps, 4),
        "hit_frame": cap.hit.frame, "hit_frame_method": cap.hit.method,
        "effector": rig.skeleton.names[rig.bat_joint] if not cap.appended else
        f"{cap.profile.implement.get('hit_point', 'hands_midpoint')} of "
        f"{rig.skeleton.names[cap.lead_hand]} and {rig.skeleton.names[cap.trail_hand]}",
        "lead_hand": rig.skeleton.names[cap.lead_hand],
        "facing_deg": cap.facing_deg,
        "source_hit_point": r(source), "desired_hit_point": r(a.desired_hit_point),
        "offset": r(a.desired_hit_point - source),
        "bat_error_cm": round(a.bat_error_cm, 6),
        "max_grip_error_cm": round(float(a.grip_error_cm.max()), 4),
        "max_grip_error_deg": round(float(a.grip_error_deg.max()), 4),
        "falloff": settings.falloff, "wrist_dof": settings.wrist_dof, "solver": settings.solver,
        **(learnt_summary(solver, cap.shot, leave_out) if settings.solver in LEARNT_SOLVERS else {}),
        "solve_ms": round(solve_ms, 3), "out": None if out is None else str(out),
    }


def learnt_summary(solver, shot, leave_out: bool) -> dict:
    """What the learnt model was trained on (the JSON's learnt_* keys)."""
    model = solver.model(shot.name if leave_out else None)
    return {"leave_out": bool(leave_out),
            "learnt_training_shots": sum(s.name != shot.name or not leave_out for s in solver.shots),
            "learnt_clusters": int(len(model.p_mu)), "learnt_angle_clusters": int(model.angle_clusters)}


def hit_summary(rig, shot, global_rotations, global_positions, ball_start, hit_point) -> dict:
    """The face and the ball at the hit frame of a (adapted) shot: ``face_angle_deg``
    (vs the source's face), ``face_to_ball`` (cosine), ``contact`` (face|edge|back),
    ``ball_azimuth_deg`` and ``ball_elevation_deg`` of the ball just after the impact."""
    from engine import ballistics  # numba (ballistics' flight kernel): when the command runs

    fl, angle = ballistics.shot_flight(rig, shot, global_rotations, global_positions, ball_start, hit_point,
                                       duration=0.0)
    return {"face_angle_deg": round(angle, 3), "face_to_ball": round(fl.face_to_ball, 4),
            "contact": fl.contact, "ball_azimuth_deg": round(fl.azimuth_deg, 2),
            "ball_elevation_deg": round(fl.elevation_deg, 2)}


OUT_EXTENSIONS = EXTENSIONS


def check_out(out: Path) -> None:
    """UserError before any solving for an --out the command cannot write."""
    if out.suffix.lower() not in OUT_EXTENSIONS:
        raise UserError(f"--out: unknown extension {out.suffix or '(none)'!r} (use {', '.join(OUT_EXTENSIONS)})")
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise UserError(f"--out: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UserError(f"--out: folder {folder} is not writable")
    if out.is_dir():
        raise UserError(f"--out {out} is a folder")


def _write(out: Path, rig, shot, a, csv_rotations: str = "euler") -> None:
    """The adapted take to ``out``; a glTF holds the source take too, each with its ball;
    a CSV has Euler angles (degrees, BVH's numbers) or quaternions (``csv_rotations``)."""
    clip = Clip(a.root_positions, a.local_rotations, shot.clip.fps)
    takes = None
    if out.suffix.lower() in (".glb", ".gltf"):
        from engine.export import shot_takes
        takes = shot_takes(rig, shot, clip, a.desired_hit_point, choice.BALL_START, shot.hit_point)
    write_take(out, shot.skeleton, clip, name=f"{shot.name}_adapted", limits=rig.limits, blend=a.blend,
               takes=takes, csv_rotations=csv_rotations)


_FLAGS = {"--target": 3, "--shot": 1, "--hit": 3, "--falloff": 1, "--wrist-dof": 1,
          "--solver": 1, "--twist": 1, "--direction": 1, "--elevation": 1, "--out": 1, "--bvh": 1, "--profile": 1,
          "--hit-frame": 1, "--handed": 1, "--scale": 1, "--offset": 3, "--library": 1,
          "--csv-rotations": 1, "--leave-out": 0, "--facing": 1, "--trunk-reach": 1,
          "--carry-lean": 0, "--no-carry-lean": 0}
CSV_ROTATIONS = ("euler", "quaternion")
MAX_SCALE = 1e4        # cm per file unit: beyond a kilometre a unit is a mistake


def parse_args(args: list[str]) -> dict:
    """The adapt options from raw arguments; every mistake is one UserError line
    (click's own usage errors would print several)."""
    got: dict = {}
    i = 0
    while i < len(args):
        flag, _, inline = args[i].partition("=")
        if flag not in _FLAGS:
            raise UserError(f"unknown option {shorten(args[i])!r} (see hitpoint adapt --help)")
        n = _FLAGS[flag]
        vals = [inline] if inline else args[i + 1:i + 1 + n]
        if n == 0 and inline:
            raise UserError(f"{flag} takes no value")
        if len(vals) < n or any(v.startswith("--") for v in vals):
            raise UserError(f"{flag} needs {n} value{'s' if n > 1 else ''}")
        got[flag] = vals
        i += 1 + (0 if inline else n)

    out = {"target": None, "shot_name": None, "hit": None, "falloff": 90.0, "wrist_dof": 0,
           "solver": "ccd", "twist": "follow", "direction": None, "elevation": None, "out": None}
    out.update(capture_args(got))
    if "--target" in got:
        out["target"] = position("--target", got["--target"])
    if "--hit" in got:
        out["hit"] = position("--hit", got["--hit"])
    if "--shot" in got:
        out["shot_name"] = got["--shot"][0]
    if "--falloff" in got:
        out["falloff"] = falloff_cm("--falloff", got["--falloff"][0])
    if "--trunk-reach" in got:
        out["trunk_reach"] = trunk_reach_deg("--trunk-reach", got["--trunk-reach"][0])
    if "--wrist-dof" in got:
        out["wrist_dof"] = number("--wrist-dof", got["--wrist-dof"][0], choices=WRIST_DOFS)
    if "--solver" in got:
        out["solver"] = got["--solver"][0]
    out["leave_out"] = "--leave-out" in got
    if "--carry-lean" in got and "--no-carry-lean" in got:
        raise UserError("--carry-lean and --no-carry-lean contradict each other")
    if "--no-carry-lean" in got:
        out["carry_lean"] = False
    if "--twist" in got:
        from engine.adapt import TWISTS  # numba (0.25 s): only when the option is given
        out["twist"] = got["--twist"][0]
        if out["twist"] not in TWISTS:
            raise UserError(f"--twist must be one of {', '.join(TWISTS)}, got {shorten(out['twist'])!r}")
    if "--direction" in got:
        out["direction"] = direction_arg(got["--direction"][0])
    if "--elevation" in got:
        out["elevation"] = number("--elevation", got["--elevation"][0], -90.0, 90.0)
    if "--out" in got:
        out["out"] = Path(got["--out"][0])
    return out


def direction_arg(text: str) -> float:
    """--direction: degrees (0 straight back past the bowler, + toward the off side), or a
    fielding position's name ("mid-off", "square-leg": engine.field.POSITIONS)."""
    try:
        float(text)
    except ValueError:
        try:
            return field.position_azimuth(text)
        except ValueError:
            raise UserError(f"--direction: {shorten(text)!r} is neither degrees nor a fielding position "
                            f"({', '.join(field.POSITIONS)})") from None
    return number("--direction", text, -180.0, 180.0)


def capture_args(got: dict) -> dict:
    """The options of ``adapt --bvh`` (a capture on its own skeleton) and ``--library``."""
    out = {}
    for flag, key in (("--bvh", "bvh"), ("--profile", "profile"), ("--library", "library")):
        if flag in got:
            out[key] = got[flag][0]
    if "--hit-frame" in got:
        v = got["--hit-frame"][0]
        out["hit_frame"] = v if v == "auto" else number("--hit-frame", v, 0, None, integer=True)
    if "--handed" in got:
        out["handed"] = got["--handed"][0]
        if out["handed"] not in ("right", "left"):
            raise UserError(f"--handed must be right or left, got {shorten(out['handed'])!r}")
    if "--scale" in got:
        out["scale"] = number("--scale", got["--scale"][0], 1.0 / MAX_SCALE, MAX_SCALE)
    if "--facing" in got:
        from engine.capture_facing import check_facing
        try:
            out["facing"] = check_facing(got["--facing"][0])
        except ValueError as e:
            raise UserError(f"--facing: {e}") from None
    if "--offset" in got:
        out["offset"] = position("--offset", got["--offset"])
    if "--csv-rotations" in got:
        out["csv_rotations"] = got["--csv-rotations"][0]
        if out["csv_rotations"] not in CSV_ROTATIONS:
            raise UserError(f"--csv-rotations must be euler or quaternion, got {shorten(out['csv_rotations'])!r}")
    return out


def register(cli: typer.Typer) -> None:
    @cli.command("adapt", context_settings={"ignore_unknown_options": True, "allow_extra_args": True})
    @cli_errors
    def adapt(ctx: typer.Context):
        """Adapt a shot so the bat meets the ball at a new point; print a JSON summary.

        Options:
          --target X Y Z      ball target (cm); the shot is chosen by the ball's line
          --shot NAME --hit X Y Z   pin a shot and give the desired hit point (cm)
          --falloff CM        importance-blend falloff distance (default 90)
          --wrist-dof 0|2     left wrist locked (0, default) or 2 DOF
          --trunk-reach DEG   hold each spine joint within DEG of the source's
                              on each axis (default: free); the face and the
                              right hand's grip give where the arms cannot
                              keep them, the bat goes further only to reach
          --no-carry-lean     every frame solved on its own, as the
                              dissertation (default: the hit frame first and
                              the frames round it started from its lean;
                              --carry-lean says so)
          --solver ccd|dls|learnt|learnt+ccd   IK solver (default ccd); learnt:
                              the lead arm where the library's learnt-IK model
                              (Ong & Hilton 2005) says it is for the bat's
                              handle (bat_error_cm is what the data gives);
                              learnt+ccd: that pose as CCD's start, then exact
          --leave-out         learnt solvers: train without the adapted shot
          --twist follow|lead CCD: the left arm's roll joints keep the source's
                              twist (follow, default: the face stays square) or
                              are turned by CCD too (lead, the dissertation's)
          --direction AZ      send the ball this way (deg; 0 straight back past the
                              bowler, + toward the off side, or a fielding
                              position: mid-off, cover, point, square-leg, ...)
                              by turning the kept face about the vertical at
                              the hit; out of the shot's reach: the closest it
                              gives, and direction_reached false in the JSON
          --elevation EL      with --direction: and this far up (deg above the
                              ground) by tilting the bat face; out of reach: the
                              closest, elevation_reached false and
                              elevation_range_deg in the JSON
          --out FILE          write the adapted shot (atomic): .bvh, .csv, .glb
                              or .gltf (skinned batsman, the adapted and the
                              source take, the ball; metres)
          --csv-rotations euler|quaternion   the CSV's rotation columns
          --bvh FILE --offset DX DY DZ | --hit X Y Z   your own capture, on its
                              own skeleton (--profile NAME|auto, --hit-frame
                              N|auto, --handed right|left, --scale CM_PER_UNIT,
                              --facing auto|0|90|180|270: its turn to meet
                              the ball; offsets and points are on the pitch)
          --library DIR       shots from your own library (hitpoint library init)
        JSON keys: shot, hit_frame, source_hit_point, desired_hit_point,
        bat_error_cm, blend (per frame), grip_error_cm, grip_error_deg,
        face_angle_deg (bat face at the hit frame vs the source's), face_to_ball
        (cosine of the face normal and the direction toward the incoming ball),
        contact (face|edge|back), ball_azimuth_deg (0 straight back past the
        bowler, + toward the off side), ball_elevation_deg, solve_ms, ...
        """
        print(json.dumps(run_adapt(**parse_args(list(ctx.args)))))
