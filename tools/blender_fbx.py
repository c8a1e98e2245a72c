"""glTF (.glb/.gltf from Hitpoint) -> FBX, the usual route into Maya, Unity and
Unreal, through a headless Blender (no well-kept Python FBX writer exists).

    python -m tools.blender_fbx IN.glb OUT.fbx      # finds blender on PATH, or $BLENDER

runs ``blender -b --factory-startup --python tools/blender_fbx.py -- IN OUT``, which
sets the scene to the file's frame rate (the glTF's ``fps`` extras; Blender turns
glTF seconds into frames at the scene's rate, 24 by default) and its frame range,
imports the glTF and writes a binary FBX with the armature and the skinned body,
every take its own animation stack (the adapted take and the source). The ball
stays in the glTF: Blender's FBX writer would try its track on the armature too.
Without Blender it says so in one line and exits 2. Tested with Blender 3.4.
"""
from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

TIMEOUT_S = 600


def gltf_info(path: str) -> dict:
    """The scene extras (fps, frames, takes) of a .glb or .gltf, {} if none."""
    data = Path(path).read_bytes()
    if data[:4] == b"glTF":                       # binary: 12-byte header, then the JSON chunk
        length = struct.unpack_from("<I", data, 12)[0]
        doc = json.loads(data[20:20 + length])
    else:
        doc = json.loads(data)
    scenes = doc.get("scenes") or [{}]
    return scenes[doc.get("scene", 0)].get("extras") or {}


# ----------------------------------------------------------------- inside Blender
def _shims() -> None:
    """Debian's Blender 3.4 runs on the system NumPy (1.24), which dropped the
    ``numpy.bool`` alias its glTF importer still uses."""
    import numpy
    if not hasattr(numpy, "bool"):
        numpy.bool = bool


def convert_in_blender(src: str, out: str) -> None:
    """Import ``src`` into an empty scene at its own frame rate, write ``out`` (FBX)."""
    import importlib
    bpy = importlib.import_module("bpy")     # Blender's own module, not a pip dependency
    _shims()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    info = gltf_info(src)
    scene = bpy.context.scene
    fps = float(info.get("fps", 30.0))
    scene.render.fps, scene.render.fps_base = round(fps), round(fps) / fps
    scene.frame_start, scene.frame_end = 0, max(int(info.get("frames", 1)) - 1, 0)
    bpy.ops.import_scene.gltf(filepath=src)
    # Blender's FBX writer tries every action on every object: the ball's location
    # track would move the armature. FBX holds the batsman only (the glTF has the ball).
    ball = bpy.data.objects.get("Ball")
    if ball is not None:
        action = ball.animation_data.action if ball.animation_data else None
        stashed = [s.action for t in (ball.animation_data.nla_tracks if ball.animation_data else []) for s in t.strips]
        bpy.data.objects.remove(ball)
        for a in {action, *stashed} - {None}:
            bpy.data.actions.remove(a)
    bpy.ops.export_scene.fbx(filepath=out, use_selection=False, object_types={"ARMATURE", "MESH", "EMPTY"},
                             add_leaf_bones=False, bake_anim=True, bake_anim_use_all_actions=True,
                             bake_anim_use_nla_strips=False, bake_anim_force_startend_keying=True,
                             axis_forward="-Z", axis_up="Y", path_mode="AUTO")


# ----------------------------------------------------------------- outside
def blender_path() -> str | None:
    """The Blender executable: $BLENDER, else ``blender`` on PATH; None if neither."""
    return shutil.which(os.environ.get("BLENDER") or "blender")


def convert(src: str | os.PathLike, out: str | os.PathLike) -> Path:
    """Run Blender headless on this script; the FBX's path. RuntimeError (one line)
    when Blender is missing or fails; nothing is left at ``out`` then."""
    exe = blender_path()
    if exe is None:
        raise RuntimeError("Blender is not installed (no 'blender' on PATH and no $BLENDER): "
                           "install it (Debian: apt-get install blender) to write FBX")
    src, out = Path(src).resolve(), Path(out).resolve()
    if not src.is_file():
        raise RuntimeError(f"{src}: no such glTF file")
    if src.suffix.lower() not in (".glb", ".gltf"):
        raise RuntimeError(f"{src}: expected a .glb or .gltf file")
    if not out.parent.is_dir():
        raise RuntimeError(f"{out}: folder {out.parent} does not exist")
    tmp = out.with_name(f".{out.name}.tmp.fbx")
    done = subprocess.run([exe, "-b", "--factory-startup", "--python", str(Path(__file__).resolve()), "--",
                           str(src), str(tmp)], capture_output=True, text=True, timeout=TIMEOUT_S)
    if done.returncode != 0 or not tmp.is_file():
        tmp.unlink(missing_ok=True)
        last = [line for line in (done.stderr + done.stdout).splitlines() if line.strip()][-1:] or ["no output"]
        raise RuntimeError(f"Blender could not convert {src.name}: {last[0][:200]}")
    os.replace(tmp, out)
    return out


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m tools.blender_fbx IN.glb OUT.fbx", file=sys.stderr)
        return 2
    try:
        out = convert(*args)
    except RuntimeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {out}")
    return 0


def _blender_main() -> None:
    args = sys.argv[sys.argv.index("--") + 1:]
    try:
        convert_in_blender(*args)
    except Exception as e:     # Blender would print a traceback and still exit 0
        print(f"error: {e.__class__.__name__}: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    import importlib.util
    if importlib.util.find_spec("bpy") is None:      # bpy exists only inside Blender
        sys.exit(main())
    _blender_main()
