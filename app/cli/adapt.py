"""``hitpoint adapt``: adapt a library shot to a new hit point, print a JSON summary."""
from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from app.errors import UserError, cli_errors, number, position, shorten
from app.errors import falloff as falloff_cm
from engine import choice
from engine.export import EXTENSIONS, write_take
from engine.library import find_shot, load_library
from engine.rig import default_rig
from engine.skeleton import Clip

WRIST_DOFS = (0, 2)   # the left wrist locked, or free in two axes


def run_adapt(target=None, shot_name=None, hit=None, falloff=90.0, wrist_dof=0, solver="ccd",
              twist="follow", direction=None, out: Optional[Path] = None) -> dict:
    """The adapt command's work, returned as the JSON-able summary."""
    from engine.adapt import Adapter, AdaptSettings, check_settings  # numba (0.25 s): when the command runs

    if out is not None:
        check_out(out)
    settings = AdaptSettings(falloff=falloff, wrist_dof=wrist_dof, solver=solver, twist=twist)
    check_settings(settings)
    rig = default_rig()
    shots = load_library(rig=rig)
    if target is not None:
        if shot_name is not None or hit is not None:
            raise UserError("give either --target, or --shot with --hit, not both")
        idx, desired = choice.choose_shot([s.hit_point for s in shots], choice.BALL_START, target)
        shot = shots[idx]
    else:
        if shot_name is None or hit is None:
            raise UserError("give --target X Y Z, or --shot NAME with --hit X Y Z")
        shot = find_shot(shots, shot_name)
        desired = np.asarray(hit, float)
    adapter = Adapter(rig, shot)
    adapter.adapt(desired, settings)            # compile / load the kernels before timing
    t0 = time.perf_counter()
    aimed = None
    if direction is None:
        a = adapter.adapt(desired, settings)
    else:
        from engine.direction import aim
        aimed = aim(rig, shot, desired, direction, settings)
        a = aimed.adaptation
    solve_ms = (time.perf_counter() - t0) * 1e3
    if out is not None:
        _write(out, rig, shot, a)
    r = lambda v: [round(float(x), 4) for x in v]  # noqa: E731
    return {
        "shot": shot.name,
        "hit_frame": shot.hit_frame,
        "frames": shot.num_frames,
        "source_hit_point": r(shot.hit_point),
        "desired_hit_point": r(a.desired_hit_point),
        "target": None if target is None else r(target),
        "bat_error_cm": round(a.bat_error_cm, 6),
        "blend": r(a.blend),
        "grip_error_cm": r(a.grip_error_cm),
        "grip_error_deg": r(a.grip_error_deg),
        "max_grip_error_cm": round(float(a.grip_error_cm.max()), 4),
        "max_grip_error_deg": round(float(a.grip_error_deg.max()), 4),
        "falloff": falloff, "wrist_dof": wrist_dof, "solver": solver,
        **hit_summary(rig, shot, a.global_rotations, a.global_positions, choice.BALL_START, a.desired_hit_point),
        **({} if aimed is None else {
            "direction_requested_deg": round(aimed.requested_deg, 2), "direction_reached": aimed.reached,
            "direction_range_deg": [round(v, 1) for v in aimed.range_deg],
            "forearm_twist_deg": round(aimed.twist_deg, 2)}),
        "solve_ms": round(solve_ms, 3),
        "out": None if out is None else str(out),
    }


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


def _write(out: Path, rig, shot, a) -> None:
    clip = Clip(a.root_positions, a.local_rotations, shot.clip.fps)
    write_take(out, shot.skeleton, clip, name=f"{shot.name}_adapted", limits=rig.limits, blend=a.blend)


_FLAGS = {"--target": 3, "--shot": 1, "--hit": 3, "--falloff": 1, "--wrist-dof": 1,
          "--solver": 1, "--twist": 1, "--direction": 1, "--out": 1}


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
        if len(vals) < n or any(v.startswith("--") for v in vals):
            raise UserError(f"{flag} needs {n} value{'s' if n > 1 else ''}")
        got[flag] = vals
        i += 1 + (0 if inline else n)

    out = {"target": None, "shot_name": None, "hit": None, "falloff": 90.0, "wrist_dof": 0,
           "solver": "ccd", "twist": "follow", "direction": None, "out": None}
    if "--target" in got:
        out["target"] = position("--target", got["--target"])
    if "--hit" in got:
        out["hit"] = position("--hit", got["--hit"])
    if "--shot" in got:
        out["shot_name"] = got["--shot"][0]
    if "--falloff" in got:
        out["falloff"] = falloff_cm("--falloff", got["--falloff"][0])
    if "--wrist-dof" in got:
        out["wrist_dof"] = number("--wrist-dof", got["--wrist-dof"][0], choices=WRIST_DOFS)
    if "--solver" in got:
        out["solver"] = got["--solver"][0]
    if "--twist" in got:
        from engine.adapt import TWISTS  # numba (0.25 s): only when the option is given
        out["twist"] = got["--twist"][0]
        if out["twist"] not in TWISTS:
            raise UserError(f"--twist must be one of {', '.join(TWISTS)}, got {shorten(out['twist'])!r}")
    if "--direction" in got:
        out["direction"] = number("--direction", got["--direction"][0], -180.0, 180.0)
    if "--out" in got:
        out["out"] = Path(got["--out"][0])
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
          --solver ccd|dls    IK solver (default ccd)
          --twist follow|lead CCD: the left arm's roll joints keep the source's
                              twist (follow, default: the face stays square) or
                              are turned by CCD too (lead, the dissertation's)
          --direction AZ      send the ball this way (deg; 0 straight back past the
                              bowler, + toward the off side) by turning the face
                              (an extra left-forearm twist at the hit); out of
                              the shot's reach: the closest it gives, and
                              direction_reached false in the JSON
          --out FILE          write the adapted shot (atomic): .bvh, .csv, .glb
                              or .gltf (skinned batsman + animation, metres)
        JSON keys: shot, hit_frame, source_hit_point, desired_hit_point,
        bat_error_cm, blend (per frame), grip_error_cm, grip_error_deg,
        face_angle_deg (bat face at the hit frame vs the source's), face_to_ball
        (cosine of the face normal and the direction toward the incoming ball),
        contact (face|edge|back), ball_azimuth_deg (0 straight back past the
        bowler, + toward the off side), ball_elevation_deg, solve_ms, ...
        """
        print(json.dumps(run_adapt(**parse_args(list(ctx.args)))))
