"""Stick-figure contact sheets of the bundled shots (Pillow, orthographic).

``python -m tools.preview_shots [--shot NAME] [--out DIR] [--step N]`` writes
one PNG per shot: rows are views (from the off side looking +X, from the
bowler looking -Z, from above), columns are frames every ``step`` frames plus
the hit frame (marked red). The bat is a thick line from the handle top to the
toe; the right hand's palm is a dot (it should sit on the handle).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from app.cli.render import bat_segment
from engine import quat
from engine.library import find_shot, load_library
from engine.rig import default_rig

VIEWS = {  # title: (horizontal axis, sign), (vertical axis, sign)
    "side, from the off side (bowler to the right)": ((2, 1.0), (1, 1.0)),
    "front, from the bowler (off side to the left)": ((0, 1.0), (1, 1.0)),
}
LEFT = (40, 90, 220)
RIGHT = (220, 110, 40)
MID = (60, 60, 60)


def draw_sheet(rig, shot, step: int = 4, cell: int = 200, scale: float = 0.8, per_row: int = 6,
               around: int | None = None, first: int | None = None) -> Image.Image:
    """The sheet; with ``around``, only frames within that many of the hit (every ``step``),
    with ``first``, none before that frame."""
    g_rot, g_pos = shot.fk
    F = g_pos.shape[0]
    frames = sorted(set(range(0, F, step)) | {shot.hit_frame, F - 1})
    if around is not None:
        h = shot.hit_frame
        frames = list(range(max(h - around, 0), min(h + around, F - 1) + 1, step))
    if first is not None:
        frames = [f for f in frames if f >= first]
    seg = bat_segment(rig, g_rot, g_pos)
    top, toe = seg[:, 0], seg[:, 1]
    sk = rig.skeleton
    rh = sk.index("RightHand")
    palm = g_pos[:, rh] + quat.rotate(g_rot[:, rh], np.array(rig.bat["left_grip"]) * [-1, 1, 1])
    nv = len(VIEWS)
    rows = (len(frames) + per_row - 1) // per_row
    W, H = cell * nv * per_row, cell * rows + 20
    img = Image.new("RGB", (W, H), (250, 250, 245))
    d = ImageDraw.Draw(img)
    d.text((4, 2), f"{shot.name}  frames {F}  hit {shot.hit_frame}  hit point "
                   f"{np.round(shot.hit_point, 1).tolist()}   views: " + " | ".join(VIEWS), fill=(0, 0, 0))
    centre = np.array([20.0, 0.0, 150.0])
    for k, f in enumerate(frames):
        for r, (title, ((ha, hs), (va, vs))) in enumerate(VIEWS.items()):
            ox, oy = (k % per_row * nv + r) * cell, 20 + (k // per_row) * cell
            base_y = oy + cell - 12 if va == 1 else oy + cell / 2

            def P(p):
                h = (p[ha] - centre[ha]) * hs
                v = (p[va] - (0 if va == 1 else centre[va])) * vs
                return (ox + cell / 2 + h * scale, base_y - v * scale)
            bg = (255, 232, 232) if f == shot.hit_frame else (250, 250, 245)
            d.rectangle([ox, oy, ox + cell - 1, oy + cell - 1], fill=bg, outline=(170, 170, 170) if r == 0 else (225, 225, 225))
            if va == 1:
                d.line([(ox, base_y), (ox + cell, base_y)], fill=(120, 160, 120), width=1)
                if ha == 2:   # stumps and popping crease, edge-on
                    for z, hgt in ((0.0, 71), (122.0, 4)):
                        x0 = P(np.array([0, 0, z]))[0]
                        d.line([(x0, base_y), (x0, base_y - hgt * scale)], fill=(150, 150, 150), width=2)
            for j in range(1, sk.num_joints):
                p = sk.parents[j]
                name = sk.names[j]
                if name == "Bat":
                    continue
                col = LEFT if name.startswith("Left") else RIGHT if name.startswith("Right") else MID
                d.line([P(g_pos[f, p]), P(g_pos[f, j])], fill=col, width=2)
            head = P(g_pos[f, sk.index("Head")] + quat.rotate(g_rot[f, sk.index("Head")], np.array([0, 10.0, 0])))
            d.ellipse([head[0] - 7, head[1] - 7, head[0] + 7, head[1] + 7], outline=MID, width=2)
            nose = P(g_pos[f, sk.index("Head")] + quat.rotate(g_rot[f, sk.index("Head")], np.array([0, 10.0, 12.0])))
            d.line([head, nose], fill=MID, width=2)
            d.line([P(top[f]), P(toe[f])], fill=(150, 100, 30), width=5)
            b = P(g_pos[f, rig.bat_joint])
            d.ellipse([b[0] - 3, b[1] - 3, b[0] + 3, b[1] + 3], fill=(200, 0, 0))
            q = P(palm[f])
            d.ellipse([q[0] - 2, q[1] - 2, q[0] + 2, q[1] + 2], fill=(0, 160, 0))
            if r == 0:
                d.text((ox + 3, oy + 2), f"{f}" + (" HIT" if f == shot.hit_frame else ""), fill=(0, 0, 0))
    return img


def main(argv=None):
    ap = argparse.ArgumentParser(description="stick-figure contact sheets")
    ap.add_argument("--shot")
    ap.add_argument("--out", default="/tmp/shot_previews")
    ap.add_argument("--step", type=int, default=4)
    ap.add_argument("--around", type=int, help="only frames within this many of the hit")
    ap.add_argument("--per-row", type=int, default=6, help="frames per row")
    ap.add_argument("--first", type=int, help="no frame before this one")
    a = ap.parse_args(argv)
    rig = default_rig()
    shots = load_library(rig=rig)
    try:
        shots = [find_shot(shots, a.shot)] if a.shot else shots
    except KeyError as e:
        ap.error(e.args[0])
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for shot in shots:
        path = out / f"{shot.name}.png"
        draw_sheet(rig, shot, a.step, per_row=a.per_row, around=a.around, first=a.first).save(path)
        print(path)


if __name__ == "__main__":
    main()
