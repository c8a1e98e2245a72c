"""``hitpoint render-strip --bvh FILE --terrain SPEC``: a capture (a ``hitpoint terrain``
result) over its terrain mesh (issue 17 item 4, "show it"). Frames spread over the
capture, each cell seen from the side of the walk (perpendicular to its hips' travel),
a little above: the whole body on top, its feet close up below with the skeleton and
the terrain height under each foot joint marked, so a foot on a bump, sunk into it
or floating above it can be seen."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from app.errors import UserError, shorten

TERRAIN_MARGIN_CM = 80.0      # the mesh reaches this far past the capture's joints
TERRAIN_CELL_CM = 4.0
GROUND_RGBA = (1.0, 0.15, 0.75, 1.0)    # the terrain height under each foot joint (magenta)
FEET_BOX_CM = 25.0            # the close-up of the feet reaches this far around them
BAND_CM = 35.0                # the close-up's ground: this far either side of the hips' path


def load_terrain(spec: str | None, root_positions: np.ndarray | None = None):
    """The terrain of ``spec`` (None: none), stairs placed along the walk of ``root_positions``
    as ``hitpoint terrain`` places them (None: only checked)."""
    if spec is None:
        return None
    from engine import terrain as T
    try:
        ground = T.parse_spec(spec)
        if root_positions is not None:
            T.place_steps(ground, root_positions)
    except ValueError as e:
        raise UserError(f"--terrain: {e}") from None
    return ground


def walk_axes(root_positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the walk's horizontal direction, the horizontal side of it the cameras look from)."""
    d = (root_positions[-1] - root_positions[0]) * np.array([1.0, 0.0, 1.0])
    if np.linalg.norm(d) < 1.0:
        d = np.array([0.0, 0.0, 1.0])
    d = d / np.linalg.norm(d)
    return d, np.cross(d, [0.0, 1.0, 0.0])


def band(vertices: np.ndarray, triangles: np.ndarray, root_positions: np.ndarray, half_width: float) -> np.ndarray:
    """The triangles within ``half_width`` cm of the hips' path, across the walk: the ground
    the feet step on, with nothing in front of it to hide them from a low camera."""
    d, side = walk_axes(root_positions)
    r0 = root_positions[0]
    along, across = (root_positions - r0) @ d, (root_positions - r0) @ side
    order = np.argsort(along)
    c = vertices[triangles].mean(axis=1) - r0
    path = np.interp(c @ d, along[order], across[order])
    return triangles[np.abs(c @ side - path) < half_width]


def foot_joints(rig) -> list[int]:
    """The legs' last joints and the feet's toe joints."""
    joints = [int(rig.chains[f"{s}_leg"].effector) for s in ("left", "right") if f"{s}_leg" in rig.chains]
    return joints + [int(j) for v in rig.feet.values() for j in v]


def terrain_strip(rig, shot, ground, count: int, cell: tuple[int, int]):
    """(the sheet as a PIL image, [{frame, view, proj, feet_view, feet_proj, x}] per cell)."""
    from app.cli.render import LABEL_H, TITLE_H, strip_frames
    from app.render import SceneRenderer, offscreen_context, render_image
    from engine.skeleton import bind_positions, skinning_matrices

    g_rot, g_pos = shot.fk
    frames = strip_frames(shot.num_frames, 0, count)
    props = _terrain_props(ground, g_pos, shot.clip.root_positions)
    skins = skinning_matrices(g_rot[frames], g_pos[frames], bind_positions(rig.skeleton))
    ctx = offscreen_context()
    renderer = SceneRenderer(ctx, rig)       # a walk's hands hold nothing: no implement drawn
    W, H = cell
    sheet = Image.new("RGB", (W * len(frames), TITLE_H + 2 * H + LABEL_H), (24, 28, 36))
    draw = ImageDraw.Draw(sheet)
    draw.text((10, 10), f"{shot.name}  -  {shot.num_frames} frames  -  top: the body over "
              f"{'the terrain' if ground else 'the flat ground'}, bottom: the feet close up, low, on the ground "
              "they step on, the skeleton (yellow) and the ground under each foot joint (magenta)",
              fill=(235, 235, 235))
    cells = []
    for k, f in enumerate(frames):
        top, bottom = _cell_views(rig, ground, props, shot.clip.root_positions, g_pos[f], skins[k], cell)
        x = k * W
        sheet.paste(Image.fromarray(render_image(renderer, top)), (x, TITLE_H))
        sheet.paste(Image.fromarray(render_image(renderer, bottom)), (x, TITLE_H + H))
        draw.text((x + 8, TITLE_H + 2 * H + 7), f"frame {f}", fill=(220, 220, 220))
        if k:
            draw.line([(x, TITLE_H), (x, TITLE_H + 2 * H)], fill=(24, 28, 36), width=2)
        cells.append({"frame": f, "view": top.view, "proj": top.proj, "x": x,
                      "feet_view": bottom.view, "feet_proj": bottom.proj})
    ctx.release()
    return sheet, cells


def _terrain_props(ground, g_pos: np.ndarray, root_positions: np.ndarray):
    """(the whole terrain, its band along the walk) as drawable meshes, or (None, None)."""
    if ground is None:
        return None, None
    from app.render.props import terrain_prop
    from engine.terrain import terrain_mesh
    lo, hi = g_pos.reshape(-1, 3).min(0) - TERRAIN_MARGIN_CM, g_pos.reshape(-1, 3).max(0) + TERRAIN_MARGIN_CM
    verts, tris = terrain_mesh(ground, (lo[0], hi[0]), (lo[2], hi[2]), TERRAIN_CELL_CM)
    return terrain_prop(verts, tris), terrain_prop(verts, band(verts, tris, root_positions, BAND_CM))


def _cell_views(rig, ground, props, root_positions, pos, skin, cell):
    """The SceneViews of one frame: the body over the terrain, and its feet close up."""
    from app.cli.render import SKELETON_RGBA, strip_camera
    from app.render import SceneView
    feet = foot_joints(rig)
    under = pos[feet].copy()
    under[:, 1] = 0.0 if ground is None else ground.height(under[:, 0], under[:, 2])
    _, side = walk_axes(root_positions)
    view, proj = strip_camera(np.concatenate([pos, under, under - [0.0, 20.0, 0.0]]), cell,
                              direction=side + [0.0, 0.35, 0.0])
    box = np.concatenate([pos[feet], under]) + np.array([[-1.0], [1.0]])[:, :, None] * FEET_BOX_CM
    close, close_proj = strip_camera(box.reshape(-1, 3), cell, direction=side + [0.0, 0.08, 0.0])
    flat = ground is None
    top = SceneView(view, proj, cell, skin, show_pitch=flat, terrain=props[0], shadows=False)
    bottom = SceneView(close, close_proj, cell, skin, show_pitch=flat, terrain=props[1], shadows=False,
                       skeleton_lines=[(pos, rig.skeleton.parents, SKELETON_RGBA)],
                       points=[(under.astype(np.float32), GROUND_RGBA, 7.0)], skeleton_width_px=2.0)
    return top, bottom


def run_terrain_strip(bvh: Path, spec: str | None, profile: str, out: Path, count: int, cell) -> str:
    from app.cli.render import save_png_atomic
    from engine.capture import load_capture
    if not Path(bvh).is_file():
        raise UserError(f"--bvh {shorten(bvh)}: no such file")
    cap = load_capture(bvh, profile, hit_frame=0)
    ground = load_terrain(spec, cap.shot.clip.root_positions)
    img, cells = terrain_strip(cap.rig, cap.shot, ground, count, cell)
    save_png_atomic(img, out)
    return f"wrote {out} ({img.width}x{img.height}, frames {', '.join(str(c['frame']) for c in cells)})"
