"""``hitpoint render-strip``: a contact sheet of one shot of the library.

Frames side by side (evenly spread, always including the hit frame), the
skinned batsman on top and the source skeleton as a stick figure below, seen
from the off side with one fixed camera per shot so the motion reads across
the sheet.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
from PIL import Image, ImageDraw
import typer

from app.cli.adapt import WRIST_DOFS
from app.errors import UserError, cli_errors, number, position
from app.errors import falloff as falloff_cm
from engine import quat
from engine.atomic import atomic_output
from engine.library import find_shot
from engine.userlib import load_shots
from engine.skeleton import bind_positions, skinning_matrices

MAX_STRIP_FRAMES = 64
MAX_SHEET_PIXELS = 64_000_000   # the whole contact sheet (about 190 MB of RGB)

LABEL_H = 26
TITLE_H = 34
SKELETON_RGBA = (1.0, 0.85, 0.15, 1.0)
BAT_RGBA = (0.85, 0.62, 0.30, 1.0)
HIT_OUTLINE = (220, 40, 40)


def strip_frames(num_frames: int, hit_frame: int, count: int) -> list[int]:
    """``count`` frames spread evenly over ``0..num_frames-1``; the nearest one is moved to the hit frame."""
    count = max(1, min(count, num_frames))
    frames = np.unique(np.round(np.linspace(0, num_frames - 1, count)).astype(int))
    frames[np.argmin(np.abs(frames - hit_frame))] = hit_frame
    return sorted(set(int(f) for f in frames))


def parse_size(text: str) -> tuple[int, int]:
    """Cell size ``"WxH"`` (or one number for square cells) in pixels."""
    try:
        parts = [int(p) for p in text.lower().replace(",", "x").split("x")]
    except ValueError:
        raise UserError(f"--size {text!r}: expected WIDTHxHEIGHT in pixels, e.g. 240x320") from None
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2 or not all(16 <= p <= 4096 for p in parts):
        raise UserError(f"--size {text!r}: expected WIDTHxHEIGHT, each 16..4096 pixels")
    return parts[0], parts[1]


def bat_segment(rig, global_rotations: np.ndarray, global_positions: np.ndarray) -> np.ndarray:
    """Handle top and toe of the bat ``(..., 2, 3)`` from the lead hand's transform (``rig.bat``;
    a user's skeleton: the bat its body is drawn with, app.render.bonebody)."""
    from app.render.bonebody import BAT_BLADE_CM, BAT_HANDLE_CM, BAT_TOP_CM
    b = rig.bat
    hand = int(rig.skeleton.parents[rig.bat_joint])
    grip = np.asarray(b.get("left_grip", (0.0, 0.0, 0.0)), float)
    axis = np.asarray(b["axis"], float)
    top, length = b.get("grip_to_top", BAT_TOP_CM), b.get("length", BAT_HANDLE_CM + BAT_BLADE_CM[0])
    local = np.stack([grip - axis * top, grip + axis * (length - top)])
    r = global_rotations[..., hand, None, :]
    return global_positions[..., hand, None, :] + quat.rotate(np.broadcast_to(r, r.shape[:-2] + (2, 4)), local)


def strip_camera(points: np.ndarray, cell: tuple[int, int], fovy: float = 30.0, margin: float = 0.86,
                 direction=(-1.0, 0.18, 0.22)):
    """Off-side camera (from -X, a little toward the bowler; or from ``direction``) framing
    ``points (N,3)``; (view, proj). Starts close and backs off until every point projects
    inside ``margin`` of the frame.
    """
    from app.render import look_at, perspective  # moderngl: when it renders
    centre = 0.5 * (points.min(0) + points.max(0))
    direction = np.asarray(direction, float)
    direction = direction / np.linalg.norm(direction)
    proj = perspective(fovy, cell[0] / cell[1], 10.0, 20000.0)
    homo = np.concatenate([points, np.ones((len(points), 1))], 1)
    dist = 150.0
    for _ in range(60):
        view = look_at(centre + direction * dist, centre)
        clip = homo @ (proj @ view).T
        ndc = clip[:, :2] / np.maximum(clip[:, 3:], 1e-6)
        if np.all(clip[:, 3] > 0) and np.abs(ndc).max() <= margin:
            break
        dist *= 1.06
    return view, proj


ADAPTED_RGBA = (0.2, 0.85, 1.0, 1.0)


def render_strip(shot, rig, count: int, cell: tuple[int, int], adapted=None):
    """The contact sheet as a PIL image; with ``adapted`` (an engine.adapt.Adaptation)
    the top row shows the adapted shot over a ghost of the source, and the
    bottom row both skeletons (source yellow, adapted blue)."""
    from app.render import SceneRenderer, SceneView, offscreen_context, render_image  # moderngl: when it renders

    frames = strip_frames(shot.num_frames, shot.hit_frame, count)
    g_rot, g_pos = shot.fk
    bats = bat_segment(rig, g_rot[frames], g_pos[frames])
    head = rig.roles.get("head", rig.skeleton.index("Head") if "Head" in rig.skeleton.names else
                         int(np.argmax(g_pos[frames[0], :, 1])))   # else the highest joint
    head_top = g_pos[frames, head] + quat.rotate(g_rot[frames, head], rig.skeleton.end_sites.get(head, np.zeros(3)) * 1.2)
    pts = np.concatenate([g_pos[frames].reshape(-1, 3), bats.reshape(-1, 3), head_top,
                          [[g_pos[frames, 0, 0].mean(), 0.0, g_pos[frames, 0, 2].mean()]]])
    view, proj = strip_camera(pts, cell)
    bind = bind_positions(rig.skeleton)
    skins = skinning_matrices(g_rot[frames], g_pos[frames], bind)
    ghosts = [None] * len(frames)
    if adapted is not None:
        a_rot, a_pos = adapted.global_rotations[frames], adapted.global_positions[frames]
        ghosts = skins
        skins = skinning_matrices(a_rot, a_pos, bind)
        a_bats = bat_segment(rig, a_rot, a_pos)

    ctx = offscreen_context()
    renderer = SceneRenderer(ctx, rig)
    W, H = cell
    sheet = Image.new("RGB", (W * len(frames), TITLE_H + 2 * H + LABEL_H), (24, 28, 36))
    draw = ImageDraw.Draw(sheet)
    if adapted is None:
        caption = "top: skinned mesh, bottom: source skeleton"
    else:
        p = adapted.desired_hit_point
        caption = (f"adapted to ({p[0]:.0f}, {p[1]:.0f}, {p[2]:.0f}) cm, bat error "
                   f"{adapted.bat_error_cm:.3f} cm  -  top: adapted mesh over the source's ghost, "
                   f"bottom: source (yellow) and adapted (blue) skeletons")
    draw.text((10, 10), f"{shot.name}  -  {shot.num_frames} frames, hit frame {shot.hit_frame}  -  {caption}",
              fill=(235, 235, 235))
    hit_ball = shot.hit_point if adapted is None else adapted.desired_hit_point
    for k, f in enumerate(frames):
        ball = hit_ball if f == shot.hit_frame else None
        top = SceneView(view, proj, cell, skins[k], ghost_skin_matrices=ghosts[k], ball_position=ball)
        lines = [(g_pos[f], rig.skeleton.parents, SKELETON_RGBA)]
        bat_lines = [(bats[k], BAT_RGBA, 6.0)]
        if adapted is not None:
            lines.append((adapted.global_positions[f], rig.skeleton.parents, ADAPTED_RGBA))
            bat_lines.append((a_bats[k], ADAPTED_RGBA, 6.0))
        bottom = SceneView(view, proj, cell, None, skeleton_lines=lines,
                           polylines=bat_lines, ball_position=ball, skeleton_width_px=3.0)
        x = k * W
        sheet.paste(Image.fromarray(render_image(renderer, top)), (x, TITLE_H))
        sheet.paste(Image.fromarray(render_image(renderer, bottom)), (x, TITLE_H + H))
        hit = f == shot.hit_frame
        label = f"frame {f}" + ("  (hit)" if hit else "")
        draw.text((x + 8, TITLE_H + 2 * H + 7), label, fill=(255, 120, 110) if hit else (220, 220, 220))
        if hit:
            draw.rectangle([x + 1, TITLE_H + 1, x + W - 2, TITLE_H + 2 * H - 2], outline=HIT_OUTLINE, width=3)
        if k:
            draw.line([(x, TITLE_H), (x, TITLE_H + 2 * H)], fill=(24, 28, 36), width=2)
    ctx.release()
    return sheet


def check_png_out(out: Path, option: str = "--out") -> None:
    """UserError before any work for a PNG output the command cannot write."""
    out = Path(out)
    if out.suffix.lower() != ".png":
        raise UserError(f"{option} {out}: expected a .png file")
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise UserError(f"{option} {out}: folder {folder} does not exist")
    if out.is_dir():
        raise UserError(f"{option} {out} is a folder")


def save_png_atomic(img, out: Path) -> None:
    """A PIL image as PNG, atomically (see engine.atomic)."""
    check_png_out(out)
    with atomic_output(out) as tmp:
        img.save(tmp, format="PNG")


def register(cli: typer.Typer) -> None:
    @cli.command("render-strip")
    @cli_errors
    def render_strip_cmd(
        shot: str = typer.Option(None, "--shot", help="Shot name from the library (see `hitpoint shots`)."),
        bvh: Path = typer.Option(None, "--bvh", help="A capture instead of a shot, e.g. a `hitpoint terrain` result; "
                                 "frames spread over it, each seen from the side of its walk."),
        terrain: str = typer.Option(None, "--terrain", help="With --bvh: draw it over this terrain (the SPEC given "
                                    "to `hitpoint terrain`), the pitch hidden."),
        profile: str = typer.Option("auto", "--profile", help="Rig profile of --bvh: a name, a JSON file or auto."),
        out: Path = typer.Option(..., "--out", help="PNG file to write."),
        frames: int = typer.Option(9, "--frames", help="Number of frames on the sheet (the hit frame is always one)."),
        size: str = typer.Option("260x340", "--size", help="Size of one cell, WIDTHxHEIGHT pixels."),
        hit: Optional[tuple[float, float, float]] = typer.Option(None, "--hit",
                                                                 help="Adapt the shot to this hit point X Y Z (cm) first.",
                                                                 show_default=False),
        falloff: float = typer.Option(90.0, "--falloff", help="IK falloff in cm (with --hit)."),
        wrist_dof: int = typer.Option(0, "--wrist-dof", help="Left wrist DOF, 0 or 2 (with --hit)."),
        library: Path = typer.Option(None, "--library", help="A shot library: a folder with library.json, "
                                     "or the manifest (default: the bundled library)."),
    ):
        """Contact sheet of a shot: skinned mesh (top) and source skeleton (bottom), frames side by side.
        With --bvh FILE [--terrain SPEC]: a capture (a `hitpoint terrain` result) over its terrain
        mesh, the feet's terrain heights marked (yellow) in the skeleton row."""

        number("--frames", frames, 1, MAX_STRIP_FRAMES, integer=True)
        check_png_out(out)
        cell = parse_size(size)
        sheet_px = cell[0] * frames * (2 * cell[1] + TITLE_H + LABEL_H)
        if sheet_px > MAX_SHEET_PIXELS:
            raise UserError(f"--frames {frames} of --size {size}: the sheet would be {sheet_px / 1e6:.0f} "
                            f"megapixels, more than the limit of {MAX_SHEET_PIXELS / 1e6:.0f}")
        if (shot is None) == (bvh is None):
            raise UserError("give --shot NAME or --bvh FILE, one of them")
        if bvh is not None:
            if hit is not None or library is not None:
                raise UserError("--bvh draws the capture as it is: no --hit or --library")
            from app.cli.terrain_strip import run_terrain_strip
            print(run_terrain_strip(bvh, terrain, profile, out, frames, cell))
            return
        if terrain is not None:
            raise UserError("--terrain goes with --bvh FILE (a `hitpoint terrain` result)")
        hit = None if hit is None else position("--hit", hit)
        settings = dict(falloff=falloff_cm("--falloff", falloff),
                        wrist_dof=number("--wrist-dof", wrist_dof, choices=WRIST_DOFS))
        rig, shots = load_shots(library)
        s = find_shot(shots, shot)
        adapted = None
        if hit is not None:
            from engine.adapt import Adapter, AdaptSettings  # numba (0.25 s): when the command runs
            adapted = Adapter(rig, s).adapt(np.array(hit, float), AdaptSettings(**settings))
        img = render_strip(s, rig, frames, cell, adapted)
        save_png_atomic(img, out)
        print(f"wrote {out} ({img.width}x{img.height}, frames {', '.join(map(str, strip_frames(s.num_frames, s.hit_frame, frames)))})")
