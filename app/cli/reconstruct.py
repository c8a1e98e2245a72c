"""``hitpoint reconstruct``: a motion rebuilt from a few joints' positions (learnt IK,
reference 002 sections 5.2-5.3), written in the input's skeleton, RMSE as JSON."""
from __future__ import annotations

import json
import time
from pathlib import Path

import typer

from app.errors import UserError, cli_errors, shorten

JOINT_DECIMALS = 3


def load_source(shot_name: str | None, bvh_file: Path | None, profile: str, library: Path | None):
    """(rig, shot, training shots or None for a lone capture) from --shot or --bvh."""
    if (shot_name is None) == (bvh_file is None):
        raise UserError("give either --shot NAME or --bvh FILE")
    if bvh_file is not None:
        from engine.capture import load_capture
        if not bvh_file.is_file():
            raise UserError(f"--bvh {shorten(bvh_file)}: no such file")
        cap = load_capture(bvh_file, profile, hit_frame=0)    # no hit needed: frame 0 places the implement
        return cap.rig, cap.shot, None
    from engine.library import find_shot
    from engine.userlib import load_shots
    rig, shots = load_shots(library)
    return rig, find_shot(shots, shot_name), shots


def parse_keep(text: str) -> tuple[str, ...]:
    from engine.reconstruct import KEEP
    keep = tuple(k.strip() for k in text.split(",") if k.strip())
    if sorted(set(keep)) != sorted(KEEP):
        raise UserError(f"--keep must be {','.join(KEEP)} (in any order), got {shorten(text)!r}")
    return keep


def run_reconstruct(shot_name=None, bvh_file=None, profile="auto", library=None, keep="hips,hands,feet",
                    method="learnt", leave_out=False, out: Path | None = None) -> dict:
    from app.cli.adapt import check_out
    from engine import reconstruct as R
    if method not in R.METHODS:
        raise UserError(f"--method must be one of {', '.join(R.METHODS)}, got {shorten(method)!r}")
    keep_roles = parse_keep(keep)
    if out is not None:
        check_out(out)
    rig, shot, shots = load_source(shot_name, bvh_file, profile, library)
    t0 = time.perf_counter()
    if shots is None and leave_out:
        clip = R.two_fold(rig, shot, method, keep_roles)
        training = "two-fold: each half by a model of the other half"
    else:
        train = [s for s in (shots or [shot]) if not (leave_out and s is shot)]
        clip = R.rebuild_shot(rig, shot, [s.clip.local_rotations for s in train], method, keep_roles)
        training = f"{len(train)} shot{'s' if len(train) != 1 else ''}, {sum(s.num_frames for s in train)} frames"
    seconds = time.perf_counter() - t0
    capture = getattr(shot, "capture", None)
    J = capture.file_skeleton.num_joints if capture is not None else shot.skeleton.num_joints
    per_joint, _ = R.position_rmse(shot.skeleton, shot.clip, clip)
    per_joint = per_joint[:J]        # a capture's appended implement joint is not the file's
    if out is not None:
        if capture is not None:
            capture.write(out, clip.local_rotations, clip.root_positions, name=f"{shot.name}_{method}")
        else:
            from engine.export import write_take
            write_take(out, shot.skeleton, clip, name=f"{shot.name}_{method}", limits=rig.limits)
    kept = R.kept_joints(rig, keep_roles)
    return {"source": shot.name, "method": method, "keep": list(keep_roles), "leave_out": leave_out,
            "training": training, "frames": shot.num_frames,
            "rmse_cm": round(float((per_joint ** 2).mean() ** 0.5), JOINT_DECIMALS),
            "kept_rmse_cm": round(float((per_joint[kept] ** 2).mean() ** 0.5), JOINT_DECIMALS),
            "joint_rmse_cm": {shot.skeleton.names[j]: round(float(v), JOINT_DECIMALS)
                              for j, v in enumerate(per_joint)},
            "seconds": round(seconds, 3), "out": None if out is None else str(out)}


def register(cli: typer.Typer) -> None:
    @cli.command("reconstruct")
    @cli_errors
    def reconstruct(
        shot: str = typer.Option(None, "--shot", help="A library shot to rebuild."),
        bvh: Path = typer.Option(None, "--bvh", help="Or any BVH capture (placed by a rig profile)."),
        profile: str = typer.Option("auto", "--profile", help="Rig profile of --bvh: a name, a JSON file or auto."),
        library: Path = typer.Option(None, "--library", help="Shot library for --shot (default: the bundled one)."),
        keep: str = typer.Option("hips,hands,feet", "--keep", help="The joints whose positions are kept."),
        method: str = typer.Option("learnt", "--method", help="learnt | learnt+ccd | ccd (CCD from the rest pose)."),
        leave_out: bool = typer.Option(False, "--leave-out", help="Train without the shot itself (a lone "
                                       "capture: each half by a model of the other half)."),
        out: Path = typer.Option(None, "--out", help="Write the rebuilt motion (.bvh, .csv, .glb, .gltf)."),
    ):
        """Rebuild a motion from the positions of its hips, hands and feet alone
        (learnt IK, Ong & Hilton 2005: one learnt model per limb plus a body model
        for the hips' turn; or the CCD-from-rest baseline) and print the position
        RMSE in cm against the original as JSON: rmse_cm (every joint and frame),
        kept_rmse_cm (the kept joints), joint_rmse_cm (per joint)."""
        print(json.dumps(run_reconstruct(shot, bvh, profile, library, keep, method, leave_out, out)))
