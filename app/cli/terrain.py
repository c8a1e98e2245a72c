"""``hitpoint terrain``: a walk retargeted to uneven terrain (learnt IK, reference 002
section 5.4 and appendix B), written in the input's skeleton, a JSON summary."""
from __future__ import annotations

import json
import time
from pathlib import Path

import typer

from app.errors import UserError, cli_errors, number, shorten


def run_terrain(bvh_file: Path, spec: str, out: Path | None, profile: str = "auto", clearance: float = 1.0) -> dict:
    from app.cli.adapt import check_out
    from engine import terrain as T
    from engine.capture import load_capture
    clearance = number("--clearance", clearance, 0.0, 100.0)
    try:
        ground = T.parse_spec(spec)
    except ValueError as e:
        raise UserError(f"--terrain: {e}") from None
    if out is not None:
        check_out(out)
    if not bvh_file.is_file():
        raise UserError(f"--bvh {shorten(bvh_file)}: no such file")
    cap = load_capture(bvh_file, profile, hit_frame=0)    # no hit needed: frame 0 places the implement
    t0 = time.perf_counter()
    res = T.retarget(cap.rig, cap.shot, ground, clearance)
    seconds = time.perf_counter() - t0
    clear = T.clearances(cap.rig, res, ground)
    if out is not None:
        cap.write(out, res.clip.local_rotations, res.clip.root_positions, name=f"{cap.shot.name}_terrain")
    summary = {"source": cap.shot.name, "terrain": spec, "frames": cap.shot.num_frames, **res.summary()}
    for k, side in enumerate(T.SIDES):
        pl = res.planted[k]
        summary[f"{side}_min_clearance_cm"] = round(float(clear[k].min()), 3)
        if pl.any():
            summary[f"{side}_planted_clearance_cm"] = [round(float(clear[k][pl].min()), 3),
                                                       round(float(clear[k][pl].max()), 3)]
    return {**summary, "seconds": round(seconds, 3), "out": None if out is None else str(out)}


def register(cli: typer.Typer) -> None:
    @cli.command("terrain")
    @cli_errors
    def terrain(
        bvh: Path = typer.Option(..., "--bvh", help="A walk (BVH) on a flat floor at y = 0."),
        spec: str = typer.Option(..., "--terrain", help="sine:amp=A,wavelength=L | steps:rise=R,run=D | "
                                 "npy:file=PATH,x0=..,x1=..,z0=..,z1=.. (cm)."),
        out: Path = typer.Option(None, "--out", help="Write the result (.bvh, .csv, .glb, .gltf)."),
        profile: str = typer.Option("auto", "--profile", help="Rig profile of --bvh: a name, a JSON file or auto."),
        clearance: float = typer.Option(1.0, "--clearance", help="e (cm): an off-ground foot's least height above the terrain."),
    ):
        """Walk a capture over uneven terrain (Ong & Hilton 2005, appendix B): the planted
        foot found by height and speed, the skeleton displaced by the terrain under it,
        the off-ground foot lifted where it would sink, the legs solved by the learnt
        model (trained on the walk) with a CCD finish. SINE: H = A sin(2 pi x/L)
        cos(2 pi z/L); STEPS: stairs along the walk, the first frame on step 0; NPY: a
        plain .npy (nz, nx) height map over [x0, x1] x [z0, z1]. Prints a JSON summary:
        the skeleton's rise, planted frames, ankle errors, each foot's lowest contact
        point above the terrain (min_clearance_cm; negative would be sunk)."""
        print(json.dumps(run_terrain(bvh, spec, out, profile, clearance)))
