"""tools/blender_fbx.py: an adapted shot's .glb -> FBX through headless Blender,
read back by Blender's own FBX importer; without Blender, one clear line and exit 2."""
import json
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import ROOT

from tools import blender_fbx

CHECK = r'''
import numpy, sys, json
if not hasattr(numpy, "bool"):
    numpy.bool = bool
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
path, fps, hit, take = sys.argv[sys.argv.index("--") + 1:]
bpy.context.scene.render.fps = int(fps)
bpy.ops.import_scene.fbx(filepath=path, anim_offset=0.0)   # the importer shifts by +1 frame by default
arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][0]
body = [o for o in bpy.data.objects if o.type == "MESH" and o.name.startswith("Batsman")][0]
ws = arm.matrix_world.to_scale()
arm.animation_data.action = next(a for a in bpy.data.actions if take in a.name)
bpy.context.scene.frame_set(int(hit))
bat = list(arm.matrix_world @ arm.pose.bones["Bat"].head)
print("HITPOINT_CHECK" + json.dumps({"bones": len(arm.data.bones), "actions": sorted(a.name for a in bpy.data.actions),
      "height_m": body.dimensions.z * body.matrix_world.to_scale().z, "arm_scale": list(ws),
      "objects": sorted(o.name for o in bpy.data.objects), "bat_at_hit": bat}))
'''


def adapt_glb(tmp_path, rig):
    from engine.library import load_library
    shot = load_library(rig=rig)[0]
    out = tmp_path / "a.glb"
    done = subprocess.run([sys.executable, "-c", "from app.cli import main; main()", "adapt", "--shot", shot.name,
                           "--hit", *map(str, shot.hit_point + 4.0), "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return shot, out


def test_without_blender_one_line_and_exit_2(tmp_path, monkeypatch):
    monkeypatch.setenv("BLENDER", str(tmp_path / "no-blender-here"))
    monkeypatch.setenv("PATH", str(tmp_path))
    (tmp_path / "a.glb").write_bytes(b"glTF")
    done = subprocess.run([sys.executable, "-m", "tools.blender_fbx", str(tmp_path / "a.glb"), str(tmp_path / "a.fbx")],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.startswith("error: Blender is not installed") and done.stderr.count("\n") == 1
    assert not (tmp_path / "a.fbx").exists()


@pytest.mark.skipif(blender_fbx.blender_path() is None, reason="Blender is not installed (apt-get install blender)")
def test_glb_to_fbx_holds_the_armature_body_and_both_takes(tmp_path, rig):
    shot, glb = adapt_glb(tmp_path, rig)
    fbx = blender_fbx.convert(glb, tmp_path / "a.fbx")
    assert fbx.read_bytes()[:18] == b"Kaydara FBX Binary"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []      # no temporary left
    script = tmp_path / "check.py"
    script.write_text(CHECK)
    done = subprocess.run([blender_fbx.blender_path(), "-b", "--factory-startup", "--python", str(script), "--",
                           str(fbx), "30", str(shot.hit_frame), takes_of(glb)[0]], capture_output=True, text=True,
                          timeout=600)
    line = next(x for x in done.stdout.splitlines() if x.startswith("HITPOINT_CHECK"))
    got = json.loads(line[len("HITPOINT_CHECK"):])
    assert got["bones"] == rig.skeleton.num_joints
    takes = takes_of(glb)
    assert len(takes) == 2 and sorted(got["actions"]) == sorted(f"Batsman|Batsman|{t}_Batsman" for t in takes)
    assert got["objects"] == ["Batsman", "Batsman_body"] and got["arm_scale"] == [1.0, 1.0, 1.0]
    assert 1.2 < got["height_m"] < 2.0                                # metres, not cm (1.4 m crouched at the hit)
    x, y, z = (shot.hit_point + 4.0) * 0.01                                              # Blender: Z up, -Y ahead
    np.testing.assert_allclose(got["bat_at_hit"], [x, -z, y], atol=1e-3)               # the hit, at the hit frame


def takes_of(glb):
    return blender_fbx.gltf_info(str(glb))["takes"]
