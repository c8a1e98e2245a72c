"""Close-ups of a bundled shot's hands and bat, skinned, from three sides (offscreen GL).

``python -m tools.closeup_shots SHOT OUT.png [FRAME ...] [--arms]`` writes one column per
frame (default: the hit frame and 3 either side) and one row per view: from the off side,
from the bowler, from above. Each cell frames the hands and the bat's handle (``--arms``:
the shoulders, elbows and hands), so a grip, a wrist or an elbow that turns the wrong way
between frames shows. The tool the shots' keys are authored against (tools/shots_defs).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from app.cli.render import bat_segment, strip_camera
from app.render import SceneRenderer, SceneView, offscreen_context, render_image
from engine.atomic import atomic_output
from engine.library import find_shot, load_library
from engine.rig import default_rig
from engine.skeleton import bind_positions, skinning_matrices

VIEWS = {"off side": (-1.0, 0.3, 0.2), "bowler": (0.2, 0.3, 1.0), "above": (0.3, 1.0, -0.2)}
HANDS = ("LeftForeArmRoll", "LeftHand", "RightForeArmRoll", "RightHand")
ARMS = ("LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm", "RightHand", "Spine")


def closeup_sheet(rig, shot, frames, arms: bool = False, cell: tuple[int, int] = (300, 300)) -> Image.Image:
    """The sheet: ``len(VIEWS)`` rows by ``len(frames)`` columns of ``cell`` pixels, a caption row."""
    g_rot, g_pos = shot.fk
    joints = [rig.skeleton.index(n) for n in (ARMS if arms else HANDS)]
    ctx = offscreen_context()
    renderer = SceneRenderer(ctx, rig)
    bind = bind_positions(rig.skeleton)
    W, H = cell
    sheet = Image.new("RGB", (W * len(frames), H * len(VIEWS) + 20), (20, 20, 20))
    draw = ImageDraw.Draw(sheet)
    for k, f in enumerate(frames):
        top, toe = bat_segment(rig, g_rot[f], g_pos[f])
        # the handle and the top of the blade, not the toe: the hands stay large in the frame
        points = np.concatenate([g_pos[f, joints], [top, 0.7 * top + 0.3 * toe]])
        skins = skinning_matrices(g_rot[f:f + 1], g_pos[f:f + 1], bind)[0]
        for r, direction in enumerate(VIEWS.values()):
            view, proj = strip_camera(points, cell, direction=direction, margin=0.9)
            image = render_image(renderer, SceneView(view, proj, cell, skins))
            sheet.paste(Image.fromarray(image), (k * W, r * H))
        hit = " (hit)" if f == shot.hit_frame else ""
        draw.text((k * W + 5, H * len(VIEWS) + 4), f"{shot.name} frame {f}{hit}", fill=(230, 230, 230))
    ctx.release()
    return sheet


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("shot")
    ap.add_argument("out")
    ap.add_argument("frames", nargs="*", type=int)
    ap.add_argument("--arms", action="store_true", help="frame the shoulders and elbows too")
    a = ap.parse_args(argv)
    rig = default_rig()
    try:
        shot = find_shot(load_library(rig=rig), a.shot)
    except KeyError as e:
        ap.error(e.args[0])
    frames = a.frames or [f for f in range(shot.hit_frame - 3, shot.hit_frame + 4) if 0 <= f < shot.num_frames]
    bad = [f for f in frames if not 0 <= f < shot.num_frames]
    if bad:
        ap.error(f"frames {bad} outside {shot.name}'s 0..{shot.num_frames - 1}")
    if not Path(a.out).parent.is_dir():
        ap.error(f"folder {Path(a.out).parent} does not exist")
    sheet = closeup_sheet(rig, shot, frames, a.arms)
    with atomic_output(a.out) as tmp:         # never a half-written PNG
        sheet.save(tmp, format="PNG")
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
