"""``hitpoint synth``: a path in a shot's PC space in, an animation (BVH) out
(dissertation 3.2, clean-up of 3.3)."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import typer

from app.errors import MAX_FPS, MIN_FPS, UserError, cli_errors, number
from app.jsonfile import read_json
from engine.library import find_shot
from engine.userlib import load_shots

MAX_PATH_FILE_BYTES = 16_000_000   # a path of MAX_PATH_POINTS timed points is ~5 MB of JSON


def register(cli: typer.Typer) -> None:
    @cli.command("synth")
    @cli_errors
    def synth_cmd(
        shot: str = typer.Option(..., "--shot", help="Source shot (its PC space)."),
        path: Path = typer.Option(..., "--path", help="Path JSON: a list of \\[pc1, pc2] points (or \\[pc1, pc2, seconds]), "
                                  "{\"points\": \\[...], \"times\": \\[...], \"fps\": 30}, or "
                                  "{\"preset\": \"exaggerated|toned_down|aborted\", \"amount\": x}."),
        out: Path = typer.Option(..., "--out", help="Output BVH (written atomically)."),
        fix_hand: bool = typer.Option(True, "--fix-hand/--no-fix-hand", help="Re-attach the right hand to the bat."),
        plant_feet: bool = typer.Option(True, "--plant-feet/--no-plant-feet", help="Keep the source's planted feet planted."),
        keep_face: bool = typer.Option(True, "--keep-face/--free-face", help="Turn the bat's face at the hit back to the source's."),
        meet: bool = typer.Option(True, "--meet/--no-meet", help="With the face kept: bring the bat to the "
                                  "shot's hit point at the take's hit frame."),
        detail: bool = typer.Option(True, "--detail/--two-pcs", help="The PCs after the first two from the source "
                                    "shot (at the same time for a preset, along the path for a drawn one); "
                                    "--two-pcs: the first two alone."),
        fps: float = typer.Option(None, "--fps", help="Frame rate when the path has timestamps (default: the shot's)."),
        library: Path = typer.Option(None, "--library", help="A shot library: a folder with library.json, or the manifest (default: the bundled library)."),
    ):
        """Synthesise an animation from a path through the shot's first two PCs (the
        rest from the source shot; --two-pcs: the first two alone).

        Without timestamps the path is stretched over the source's length.
        Presets (Figure 3.7): exaggerated / toned_down scale the path's radius
        about its centre by 1 +/- amount between backlift and follow-through;
        aborted leaves the path at `amount` of the way from backlift to hit (or
        at "abort_frame") and heads straight for the rest pose. The take meets the
        ball where the shot does, with the shot's face, at its hit frame (the
        shot's for a preset, else where the path passes nearest the shot's hit
        scores); an aborted take that leaves the path before the hit leaves the
        ball. Prints a JSON summary (frames, clean-up errors, the take's hit frame,
        the face there against the source's, how far the bat was brought).
        """
        from engine import bvh, synth  # numba (0.25 s): when the command runs

        _check_out(out)
        obj = read_json(path, "path file", MAX_PATH_FILE_BYTES)
        try:
            spec = synth.parse_path_spec(obj)
        except ValueError as e:
            raise UserError(f"{path}: {e}") from None
        if fps is not None:
            fps = number("--fps", fps, MIN_FPS, MAX_FPS)
        rig, shots = load_shots(library)
        src = find_shot(shots, shot)
        take = _synthesise(rig, src, spec, fps or spec.fps or float(src.clip.fps), detail, path)
        summary = take.summary(src, out)
        anim = take.anim
        if fix_hand or plant_feet or (keep_face and not take.leaves):
            anim, summary["cleanup"] = _cleaned(rig, src, take, fix_hand, plant_feet, keep_face, meet)
        synth.check_finite_clip(anim)       # ValueError: one line from cli_errors, nothing written
        if src.capture is not None:     # a user's shot: back on its own skeleton and units
            src.capture.write(out, anim.local_rotations, anim.root_positions, name=f"{src.name}_synth")
        else:
            bvh.write(out, src.skeleton, anim)
        print(json.dumps(summary, indent=1))


def _check_out(out: Path) -> None:
    if out.suffix.lower() != ".bvh":
        raise UserError(f"--out {out}: only .bvh output is supported")
    if not out.parent.exists():
        raise UserError(f"--out {out}: folder {out.parent} does not exist")
    if out.is_dir():
        raise UserError(f"--out {out} is a folder")


@dataclass
class _Take:
    spec: object            # engine.synth.PathSpec
    space: object           # engine.pca.ShotPCA of the shot's body
    sections: object        # engine.synth.Sections
    points: np.ndarray      # (N, 2) the path's scores
    per_frame: np.ndarray   # (F, 2) resampled to the take's frames
    rate: float
    detail: bool
    anim: object            # engine.skeleton.Clip, before the clean-up
    hit_frame: int          # the take's hit frame
    leaves: bool            # an aborted take that leaves the ball

    def summary(self, src, out: Path) -> dict:
        from engine import synth
        spec, space = self.spec, self.space
        out_dict = {"shot": src.name, "out": str(out), "frames": self.anim.num_frames, "fps": round(self.rate, 4),
                    "path": spec.preset or f"{len(self.points)} points" + (" with timestamps" if spec.times is not None
                                                                           else ""),
                    "variance_2pcs": round(float(space.cumulative[min(1, space.num_components - 1)]), 4),
                    "detail": "source" if self.detail else "none"}
        if spec.preset:
            out_dict["amount"] = spec.amount if spec.amount is not None else synth.DEFAULT_AMOUNT[spec.preset]
        if self.leaves:
            out_dict["leaves_ball"] = True
        return out_dict


def _synthesise(rig, src, spec, rate: float, detail: bool, path: Path) -> _Take:
    """The take of ``spec`` on shot ``src``; the path file's bounds that depend on the shot (abort
    frame) or the rate (frames of a timed path) as a UserError naming ``path``."""
    from engine import synth, synth_take
    from engine import pca as pcam
    space = pcam.fit_clip(rig, src.clip, "body")
    sections = synth.shot_sections(src.fk[1][:, rig.bat_joint], src.hit_frame)
    try:
        points = synth.path_from_spec(spec, space, sections)
        made = synth_take.make(space, points, spec.times, rate, None if spec.times is not None else src.num_frames,
                               same_timeline=spec.preset is not None, detail=detail, preset=spec.preset,
                               amount=spec.amount, sections=sections, guide=synth.source_path(space),
                               source_hit_frame=src.hit_frame, abort_frame=spec.abort_frame)
    except ValueError as e:
        raise UserError(f"{path}: {e}") from None
    per_frame, anim, hit, leaves = made
    return _Take(spec, space, sections, points, per_frame, rate, detail, anim, hit, leaves)


def _cleaned(rig, src, take: _Take, fix_hand: bool, plant_feet: bool, keep_face: bool, meet: bool):
    """(the cleaned clip, the clean-up's JSON figures)."""
    from engine import cleanup
    res = cleanup.cleanup(rig, src.skeleton, take.anim, src.clip, fix_hand, plant_feet,
                          source_hit_frame=src.hit_frame if keep_face and not take.leaves else None,
                          hit_frame=take.hit_frame, meet_hit_point=meet)
    return res.clip, {k: round(v, 3) if isinstance(v, float) else v for k, v in res.summary().items()}
