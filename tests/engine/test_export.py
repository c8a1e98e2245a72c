"""Exporting what the user made: glTF (engine.gltf_export) read back with
pygltflib and animated by an independent sampler + FK over the file's node
tree, ``hitpoint adapt --out .glb/.gltf``, and the viewer's export folder
(mp4, BVH, GLB; atomic)."""
import json

import numpy as np
import pygltflib
import pytest
from typer.testing import CliRunner

from app.cli import cli
from tests.conftest import ROOT
from app.render.mesh import _accessor, load_glb
from engine import bvh, quat
from engine.gltf_export import METRES_PER_CM, write_gltf
from engine.library import conform_to_rig, load_library
from engine.skeleton import Clip, bind_positions, clip_fk, skinning_matrices

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

TOL_M = 1e-3 * METRES_PER_CM        # 1e-3 cm, in the file's metres


# ----------------------------------------------------------------- reading a glTF back
class GltfFile:
    """A written .glb/.gltf: accessors as arrays, the animation sampled, FK over nodes."""

    def __init__(self, path):
        self.gltf = pygltflib.GLTF2().load(str(path))
        if self.gltf.buffers[0].uri:          # .gltf: buffer embedded as a data URI
            self.gltf.convert_buffers(pygltflib.BufferFormat.BINARYBLOB)
        self.blob = self.gltf.binary_blob()
        n = len(self.gltf.nodes)
        self.parent = np.full(n, -1)
        for i, node in enumerate(self.gltf.nodes):
            for c in node.children or ():
                self.parent[c] = i

    def array(self, index):
        return _accessor(self.gltf, self.blob, index)

    def rest_trs(self):
        """Per node (n,3) translation, (n,4) (w,x,y,z) rotation, (n,3) scale."""
        nodes = self.gltf.nodes
        t = np.array([node.translation or [0, 0, 0] for node in nodes], float)
        r = np.array([node.rotation or [0, 0, 0, 1] for node in nodes], float)[:, [3, 0, 1, 2]]
        s = np.array([node.scale or [1, 1, 1] for node in nodes], float)
        return t, r, s

    def sample(self, times, animation=0):
        """Node TRS ``(T, n, ...)`` at ``times`` (s): LINEAR channels, lerp / slerp."""
        t, r, s = (np.repeat(a[None], len(times), 0) for a in self.rest_trs())
        anim = self.gltf.animations[animation]
        for ch in anim.channels:
            smp = anim.samplers[ch.sampler]
            assert smp.interpolation == "LINEAR"
            keys, vals = self.array(smp.input)[:, 0].astype(float), self.array(smp.output).astype(float)
            k = np.clip(np.searchsorted(keys, times, side="right") - 1, 0, len(keys) - 1)
            k1 = np.minimum(k + 1, len(keys) - 1)
            a = np.clip((times - keys[k]) / np.maximum(keys[k1] - keys[k], 1e-12), 0, 1)
            if ch.target.path == "rotation":
                q0, q1 = vals[k][:, [3, 0, 1, 2]], vals[k1][:, [3, 0, 1, 2]]
                r[:, ch.target.node] = quat.slerp(q0, q1, a)
            else:
                assert ch.target.path == "translation"
                t[:, ch.target.node] = vals[k] + a[:, None] * (vals[k1] - vals[k])
        return t, r, s

    def world_matrices(self, t, r, s):
        """``(T, n, 4, 4)`` node world matrices from TRS."""
        local = np.zeros(t.shape[:-1] + (4, 4))
        local[..., :3, :3] = quat.to_matrix(quat.normalize(r)) * s[..., None, :]
        local[..., :3, 3] = t
        local[..., 3, 3] = 1
        world = np.empty_like(local)
        for i in self.order():
            p = self.parent[i]
            world[:, i] = local[:, i] if p < 0 else world[:, p] @ local[:, i]
        return world

    def order(self):
        """Node indices, parents before children."""
        done, out = set(), []

        def visit(i):
            if i in done:
                return
            if self.parent[i] >= 0:
                visit(self.parent[i])
            done.add(i)
            out.append(i)
        for i in range(len(self.parent)):
            visit(i)
        return out

    def skin_joint_names(self):
        return [self.gltf.nodes[j].name for j in self.gltf.skins[0].joints]

    def joint_world_positions(self, times, names, animation=0):
        """``(T, J, 3)`` world positions (m) of the (joint) nodes ``names``."""
        world = self.world_matrices(*self.sample(times, animation))
        index = {n.name: i for i, n in enumerate(self.gltf.nodes)}
        return world[:, [index[n] for n in names]][..., :3, 3]

    def frame_times(self, animation=0):
        return self.array(self.gltf.animations[animation].samplers[0].input)[:, 0].astype(float)


# ----------------------------------------------------------------- clips
def random_clip(rig, frames=24, seed=0, fps=30.0):
    """A smooth random motion on the rig: each joint turns a little every frame."""
    rng = np.random.default_rng(seed)
    J = rig.skeleton.num_joints
    start = quat.exp(rng.normal(0, 0.8, (1, J, 3)))
    steps = np.cumsum(rng.normal(0, 0.08, (frames, J, 3)), axis=0)
    local = quat.mul(start, quat.exp(steps))
    root = rig.skeleton.offsets[0] + np.cumsum(rng.normal(0, 2.0, (frames, 3)), axis=0)
    return Clip(root, local, fps)


def turned_about_y(clip, degrees=90.0):
    """The same clip with the whole body turned about the world Y axis."""
    q = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(degrees))
    local = clip.local_rotations.copy()
    local[:, 0] = quat.mul(q, local[:, 0])
    return Clip(quat.rotate(q, clip.root_positions), local, clip.fps)


@pytest.fixture(scope="module")
def shots(rig):
    return load_library(rig=rig)


def assert_fk_round_trip(path, skeleton, clip):
    f = GltfFile(path)
    times = f.frame_times()
    assert len(times) == clip.num_frames
    np.testing.assert_allclose(times, np.arange(clip.num_frames) / clip.fps, atol=1e-6)
    names = f.skin_joint_names()
    assert sorted(names) == sorted(skeleton.names)
    got = f.joint_world_positions(times, names)
    want = clip_fk(skeleton, clip)[1][:, [skeleton.names.index(n) for n in names]] * METRES_PER_CM
    assert np.abs(got - want).max() < TOL_M
    return f


# ----------------------------------------------------------------- engine export
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_glb_round_trip_fk_matches_clip_fk(rig, tmp_path, seed):
    clip = random_clip(rig, seed=seed, fps=[24.0, 30.0, 120.0][seed])
    path = write_gltf(tmp_path / "shot.glb", rig.skeleton, clip)
    assert_fk_round_trip(path, rig.skeleton, clip)


def test_glb_round_trip_of_a_library_shot_and_turned_90_about_y(rig, tmp_path, shots):
    shot = shots[0]
    a = assert_fk_round_trip(write_gltf(tmp_path / "a.glb", shot.skeleton, shot.clip), shot.skeleton, shot.clip)
    turned = turned_about_y(shot.clip)
    b = assert_fk_round_trip(write_gltf(tmp_path / "b.glb", shot.skeleton, turned), shot.skeleton, turned)
    # the file's own joints turned 90 deg about Y: (x, y, z) -> (z, y, -x)
    names, times = a.skin_joint_names(), a.frame_times()
    pa, pb = a.joint_world_positions(times, names), b.joint_world_positions(times, names)
    np.testing.assert_allclose(pb, np.stack([pa[..., 2], pa[..., 1], -pa[..., 0]], -1), atol=TOL_M)


def test_between_keys_the_file_slerps_like_the_engine(rig, tmp_path):
    clip = random_clip(rig, frames=12, seed=5)
    f = GltfFile(write_gltf(tmp_path / "s.glb", rig.skeleton, clip))
    mid = (np.arange(clip.num_frames - 1) + 0.5) / clip.fps
    got = f.joint_world_positions(mid, rig.skeleton.names)
    half = Clip(0.5 * (clip.root_positions[:-1] + clip.root_positions[1:]),
                quat.slerp(clip.local_rotations[:-1], clip.local_rotations[1:], 0.5), clip.fps)
    want = clip_fk(rig.skeleton, half)[1] * METRES_PER_CM
    assert np.abs(got - want).max() < TOL_M


def test_inverse_binds_match_the_rest_pose_and_skin_the_mesh_like_the_engine(rig, tmp_path):
    clip = random_clip(rig, frames=4, seed=3)
    f = GltfFile(write_gltf(tmp_path / "s.glb", rig.skeleton, clip))
    names = f.skin_joint_names()
    ibm = f.array(f.gltf.skins[0].inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)  # column-major
    index = {n.name: i for i, n in enumerate(f.gltf.nodes)}
    joints = [index[n] for n in names]
    # rest pose: each joint's world matrix times its inverse bind is the identity (no scale anywhere)
    rest = f.world_matrices(*(a[None] for a in f.rest_trs()))[0, joints]
    np.testing.assert_allclose(rest @ ibm, np.broadcast_to(np.eye(4), rest.shape), atol=1e-7)
    rig_index = [rig.skeleton.names.index(n) for n in names]
    np.testing.assert_allclose(-ibm[:, :3, 3], bind_positions(rig.skeleton)[rig_index] * METRES_PER_CM, atol=1e-6)
    # skin the bundled mesh from the file's joints and from the engine's skinning matrices
    mesh = load_glb(rig=rig)["Batsman"]
    prim = f.gltf.meshes[f.gltf.nodes[index["Batsman_body"]].mesh].primitives[0]
    np.testing.assert_allclose(f.array(prim.attributes.POSITION), mesh.positions * METRES_PER_CM, rtol=1e-6)
    skin_joint = f.array(prim.attributes.JOINTS_0).astype(int)         # indices into skin.joints
    weights = f.array(prim.attributes.WEIGHTS_0).astype(float)
    world = f.world_matrices(*f.sample(f.frame_times()))[:, joints]    # (F, Js, 4, 4)
    g_rot, g_pos = clip_fk(rig.skeleton, clip)
    engine_m = skinning_matrices(g_rot, g_pos, bind_positions(rig.skeleton)).astype(float)  # (F, J, 4, 4)
    v = np.concatenate([mesh.positions, np.ones((len(mesh.positions), 1))], 1).astype(float)
    v_file = np.concatenate([f.array(prim.attributes.POSITION), np.ones((len(mesh.positions), 1))], 1)
    for fr in (0, clip.num_frames - 1):
        file_m = np.einsum("vk,vkij->vij", weights, (world[fr] @ ibm)[skin_joint])
        eng_m = np.einsum("vk,vkij->vij", mesh.weights.astype(float), engine_m[fr][mesh.joints])
        got = np.einsum("vij,vj->vi", file_m, v_file)[:, :3]
        want = np.einsum("vij,vj->vi", eng_m, v)[:, :3] * METRES_PER_CM
        assert np.abs(got - want).max() < 2e-3 * METRES_PER_CM    # float32 matrices on ~200 cm


def test_gltf_with_embedded_buffer_holds_the_same_animation(rig, tmp_path):
    clip = random_clip(rig, frames=6, seed=4)
    a = GltfFile(write_gltf(tmp_path / "s.glb", rig.skeleton, clip))
    b_path = write_gltf(tmp_path / "s.gltf", rig.skeleton, clip)
    assert json.loads(b_path.read_text())["buffers"][0]["uri"].startswith("data:application/")
    b = GltfFile(b_path)
    times = a.frame_times()
    np.testing.assert_array_equal(a.joint_world_positions(times, rig.skeleton.names),
                                  b.joint_world_positions(times, rig.skeleton.names))


def test_rotations_are_unit_xyzw_and_continuous(rig, tmp_path):
    clip = random_clip(rig, frames=10, seed=6)
    flipped = clip.copy()
    flipped.local_rotations[1::2] *= -1          # same motion, alternating signs
    f = GltfFile(write_gltf(tmp_path / "s.glb", rig.skeleton, flipped))
    anim = f.gltf.animations[0]
    rot = [f.array(anim.samplers[c.sampler].output) for c in anim.channels if c.target.path == "rotation"]
    assert len(rot) == rig.skeleton.num_joints
    for q in rot:
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1, atol=1e-6)
        assert (np.sum(q[1:] * q[:-1], axis=1) >= 0).all()
    # the first key of each joint is the engine's (w,x,y,z) reordered to (x,y,z,w), up to sign
    want = quat.normalize(clip.local_rotations[0])[:, [1, 2, 3, 0]]
    got = np.array([q[0] for q in rot])
    np.testing.assert_allclose(np.abs(np.sum(got * want, axis=1)), 1, atol=1e-6)


@pytest.mark.parametrize("name", ["s.fbx", "s", "missing/s.glb"])
def test_bad_path_raises_and_writes_nothing(rig, tmp_path, name):
    with pytest.raises((ValueError, FileNotFoundError)):
        write_gltf(tmp_path / name, rig.skeleton, random_clip(rig, frames=2))
    assert list(tmp_path.rglob("*")) == []


def test_a_skeleton_the_mesh_was_not_bound_to_exports_without_the_mesh(rig, tmp_path):
    import copy
    skel = copy.deepcopy(rig.skeleton)
    skel.offsets[skel.index("LeftForeArm")] *= 1.2          # a longer upper arm
    clip = random_clip(rig, frames=5, seed=7)
    with pytest.raises(ValueError, match="LeftForeArm"):
        write_gltf(tmp_path / "s.glb", skel, clip)
    assert list(tmp_path.iterdir()) == []
    f = GltfFile(write_gltf(tmp_path / "s.glb", skel, clip, with_mesh=False))
    assert not f.gltf.meshes and not f.gltf.skins
    got = f.joint_world_positions(f.frame_times(), skel.names)
    assert np.abs(got - clip_fk(skel, clip)[1] * METRES_PER_CM).max() < TOL_M


def test_nan_clip_raises_and_writes_nothing(rig, tmp_path):
    clip = random_clip(rig, frames=3)
    clip.root_positions[1, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        write_gltf(tmp_path / "s.glb", rig.skeleton, clip)
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------- hitpoint adapt --out
runner = CliRunner()


def adapt(*args):
    r = runner.invoke(cli, ["adapt", *map(str, args)])
    return r.exit_code, r.stdout, r.stderr


@pytest.mark.parametrize("args", [
    ["--out", "{d}/a.fbx"],
    ["--out", "{d}/missing/a.glb"],
    ["--target", "nan", "100", "300", "--out", "{d}/a.glb"],
    ["--hit", "10", "100", "inf", "--out", "{d}/a.gltf"],
])
def test_adapt_bad_input_exit_2_one_line_no_file(shots, tmp_path, args):
    args = [a.format(d=tmp_path) for a in args]
    if "--target" not in args:
        args = ["--shot", shots[0].name] + (["--hit", "10", "100", "250"] if "--hit" not in args else []) + args
    code, out, err = adapt(*args)
    assert code == 2 and out == ""
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert list(tmp_path.rglob("*")) == []


def test_adapt_out_glb_and_gltf(shots, tmp_path):
    shot = shots[0]
    hit = shot.hit_point + np.array([0.0, 5.0, 10.0])
    files = {}
    for ext in ("glb", "gltf", "bvh"):
        code, out, err = adapt("--shot", shot.name, "--hit", *hit, "--out", tmp_path / f"a.{ext}")
        assert code == 0, err
        assert json.loads(out)["out"] == str(tmp_path / f"a.{ext}")
        files[ext] = tmp_path / f"a.{ext}"
    skel, clip = bvh.read(files["bvh"])
    rig_skel, clip = conform_to_rig_of(shot, skel, clip)
    for ext in ("glb", "gltf"):
        f = GltfFile(files[ext])
        assert f.gltf.animations[0].name == f"{shot.name}_hit_{'_'.join(f'{v:.0f}' for v in hit)}cm"
        assert f.gltf.animations[1].name == f"{shot.name}_source"
        got = f.joint_world_positions(f.frame_times(), rig_skel.names)
        # the BVH keeps 9 decimals of Euler degrees: the same motion to ~1e-5 cm
        assert np.abs(got - clip_fk(rig_skel, clip)[1] * METRES_PER_CM).max() < TOL_M


def test_adapted_glb_holds_both_takes_with_the_ball_at_the_hit(rig, shots, tmp_path):
    from engine import choice
    from engine.skeleton import clip_fk
    shot = shots[1]
    hit = shot.hit_point + np.array([6.0, -4.0, 8.0])
    code, out, err = adapt("--shot", shot.name, "--hit", *hit, "--out", tmp_path / "a.glb")
    assert code == 0, err
    skel, adapted = conform_to_rig_of(shot, *bvh_of(shot, hit, tmp_path))
    f = GltfFile(tmp_path / "a.glb")
    g = f.gltf
    assert [n.name for n in g.nodes if n.mesh is not None] == ["Batsman_body", "Ball"]   # the visible body only
    assert all((n.scale or [1, 1, 1]) == [1, 1, 1] for n in g.nodes)                    # no stray scale
    root = g.nodes[g.scenes[g.scene].nodes[0]]
    assert root.name == "Batsman" and root.translation is None and root.rotation is None
    h = shot.hit_frame
    for i, (take, clip, point) in enumerate([("adapted", adapted, hit), ("source", shot.clip, shot.hit_point)]):
        ex = g.animations[i].extras
        assert ex["take"] == take and ex["shot"] == shot.name and ex["hit_frame"] == h
        assert ex["fps"] == round(clip.fps, 3) and ex["frames"] == clip.num_frames and "metres" in ex["units"]
        np.testing.assert_allclose(ex["hit_point_cm"], point, atol=0.01)
        np.testing.assert_allclose(ex["hit_time_s"], h / clip.fps, atol=1e-6)
        t = np.array([h - 1, h, h + 1]) / clip.fps
        ball, bat = (f.joint_world_positions(t, [n], i)[:, 0] for n in ("Ball", "Bat"))
        np.testing.assert_allclose(ball[1], point * METRES_PER_CM, atol=1e-5)            # meets the bat ...
        np.testing.assert_allclose(bat[1], clip_fk(skel, clip)[1][h, skel.index("Bat")] * METRES_PER_CM,
                                   atol=1e-5)
        assert np.linalg.norm(ball[1] - bat[1]) < 1e-4
        incoming = choice.BALL_START * METRES_PER_CM - ball[1]
        assert np.dot(ball[0] - ball[1], incoming) > 0                                  # ... coming in ...
        assert np.linalg.norm(ball[2] - bat[2]) > 0.05                                  # ... and flies off
    got = f.joint_world_positions(f.frame_times(1), skel.names, 1)
    assert np.abs(got - shot.fk[1] * METRES_PER_CM).max() < TOL_M                       # the source take


def bvh_of(shot, hit, tmp_path):
    code, out, err = adapt("--shot", shot.name, "--hit", *hit, "--out", tmp_path / "a.bvh")
    assert code == 0, err
    return bvh.read(tmp_path / "a.bvh")


VALIDATOR = ROOT / ".venv" / "gltf-validator" / "node_modules" / "gltf-validator"


def validate(path):
    """The Khronos glTF validator's report of ``path`` (npm gltf-validator, run by node)."""
    import shutil
    import subprocess
    if shutil.which("node") is None or not VALIDATOR.exists():
        pytest.skip("the Khronos glTF validator needs node and npm gltf-validator in .venv/gltf-validator "
                    "(.ci/run installs both)")
    script = ("const v=require(process.argv[1]);const fs=require('fs');"
              "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2])))"
              ".then(r=>console.log(JSON.stringify(r.issues)))")
    done = subprocess.run(["node", "-e", script, str(VALIDATOR), str(path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("ext", ["glb", "gltf"])
def test_khronos_validator_finds_no_error_and_no_warning(shots, tmp_path, ext):
    shot = shots[2]
    code, _, err = adapt("--shot", shot.name, "--hit", *(shot.hit_point + 5), "--out", tmp_path / f"a.{ext}")
    assert code == 0, err
    issues = validate(tmp_path / f"a.{ext}")
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"][:5]


def test_khronos_validator_on_a_capture_s_gltf(tmp_path):
    """A user's capture (the CMU golf swing) as glTF on its own skeleton, at its real size."""
    from tests.capture_kit import GOLF
    code, _, err = adapt("--bvh", GOLF, "--offset", 5, 0, 0, "--out", tmp_path / "golf.glb")
    assert code == 0, err
    issues = validate(tmp_path / "golf.glb")
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"][:5]


def test_khronos_validator_on_the_bundled_mesh():
    issues = validate(ROOT / "assets" / "batsman.glb")
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"][:5]


def conform_to_rig_of(shot, skel, clip):
    from engine.rig import default_rig
    return conform_to_rig(default_rig(), skel, clip, "test")


# ----------------------------------------------------------------- viewer export
@pytest.fixture(scope="module")
def app():
    from app.viewer.loop import App
    a = App((640, 360), headless=True)
    for _ in range(3):
        a.frame(dt=1 / 60)
    yield a
    a.close()


def test_viewer_export_writes_mp4_bvh_glb(app, rig, tmp_path):
    import imageio.v2 as iio2
    out = tmp_path / "export"
    frame, errors = app.settings.frame, app.state.errors
    app.state.last_export = None
    app.request_export(out)
    progress = []
    for _ in range(2000):            # the export runs a few frames at a time, the window stays live
        app.frame(dt=1 / 60)
        if app.state.last_export is not None and app.state.export_progress is None:
            break
        progress.append(app.state.export_progress)
    assert app.state.errors == errors, app.state.messages
    assert len(progress) > 1 and progress == sorted(progress) and 0.0 <= progress[0] < 1.0
    ok, line = app.state.last_export.ok, app.state.last_export.line
    assert ok and line.startswith(str(out)) and app.state.last_capture == str(out)
    assert app.settings.frame == frame
    assert [p.name for p in tmp_path.iterdir()] == ["export"]        # no temporary folder left
    F, stem = app.state.num_frames, f"{app.state.shot.name}_adapted"
    assert len(list(out.glob("frame_*.png"))) == F
    with iio2.get_reader(out / f"{stem}.mp4") as video:
        assert video.count_frames() == F
        w, h = app.compositor.viewport_px[2:]
        assert video.get_data(0).shape == (h + h % 2, w + w % 2, 3)
    adapted = app.state.adaptation.global_positions                     # (F, J, 3) what was on screen
    skel, clip = conform_to_rig(rig, *bvh.read(out / f"{stem}.bvh"), "export")
    assert clip.num_frames == F
    assert np.abs(clip_fk(skel, clip)[1] - adapted).max() < 1e-3
    f = GltfFile(out / f"{stem}.glb")
    got = f.joint_world_positions(f.frame_times(), rig.skeleton.names)
    assert np.abs(got - adapted * METRES_PER_CM).max() < TOL_M


def _export_now(app, out):
    app.state.last_export = None
    app.request_export(out)
    for _ in range(2000):
        app.frame(dt=1 / 60)
        if app.state.last_export is not None and app.state.export_progress is None:
            break
    assert app.state.last_export.ok, app.state.last_export.line


def test_viewer_export_writes_the_take_shown(app, rig, tmp_path):
    """With a PC-pad take in the viewport the export is that take (what the user made and sees):
    its frames in the BVH, the glTF's first animation the take (its hit frame in the extras, the
    ball at the take's bat there) beside the source, the video as long as the take; back to
    the shot, the adapted shot again."""
    import imageio.v2 as iio2
    from app.viewer import padrequests, pcpad
    app.requests.pad.append(padrequests.check_request("preset", "toned_down"))
    app.frame(dt=1 / 60)
    take = pcpad.shown_take(app.state)
    assert take is not None
    out = tmp_path / "take"
    _export_now(app, out)
    stem = f"{app.state.shot.name}_toned_down_take"
    F = take.anim.num_frames
    skel, clip = conform_to_rig(rig, *bvh.read(out / f"{stem}.bvh"), "export")
    assert np.abs(clip_fk(skel, clip)[1] - take.anim_global[1]).max() < 1e-3
    with iio2.get_reader(out / f"{stem}.mp4") as video:
        assert video.count_frames() == F
    f = GltfFile(out / f"{stem}.glb")
    extras = [a.extras for a in f.gltf.animations]
    assert [e["take"] for e in extras] == ["synthesised", "source"]
    h = take.impact.hit_frame
    assert extras[0]["hit_frame"] == h
    got = f.joint_world_positions(np.array([h / clip.fps]), ["Bat", "Ball"])[0]
    assert np.linalg.norm(got[0] - got[1]) * 100 < 0.5          # the ball at the take's bat at its hit
    app.requests.pad.append(padrequests.check_request("back"))
    app.frame(dt=1 / 60)
    assert pcpad.shown_take(app.state) is None


def test_viewer_export_that_fails_leaves_nothing(app, tmp_path, monkeypatch):
    calls = []
    render = app.outputs._render_scene

    def failing(*args):               # the export's renders only: however many a viewer frame
        calls.append(1)               # fits in its budget, the third one fails
        if len(calls) == 3:
            raise RuntimeError("GPU lost")
        return render(*args)
    monkeypatch.setattr(app.outputs, "_render_scene", failing)
    frame, errors = app.settings.frame, app.state.errors
    app.request_export(tmp_path / "export")
    for _ in range(200):
        app.frame(dt=1 / 60)
        if app.state.export_progress is None:
            break
    assert len(calls) == 3
    assert list(tmp_path.iterdir()) == []
    ok, line = app.state.last_export.ok, app.state.last_export.line
    assert not ok and "GPU lost" in line
    assert app.state.errors == errors + 1 and app.settings.frame == frame


def test_viewer_export_never_writes_into_an_existing_folder(app, tmp_path):
    keep = tmp_path / "export" / "mine.txt"
    keep.parent.mkdir()
    keep.write_text("the user's")
    app.request_export(keep.parent)
    app.frame(dt=1 / 60)
    assert not app.state.last_export.ok
    assert [p.name for p in keep.parent.iterdir()] == ["mine.txt"] and keep.read_text() == "the user's"
    assert [p.name for p in tmp_path.iterdir()] == ["export"]


def test_scripted_export_with_formats(app, tmp_path):
    from app.errors import UserError
    from app.viewer.script import ScriptPlayer
    out = tmp_path / "only_motion"
    player = ScriptPlayer([{"type": "export", "frame": 0, "dir": str(out), "formats": ["bvh", "gltf"]}])
    player.apply(app, 0)
    app.frame(dt=1 / 60)
    stem = f"{app.state.shot.name}_adapted"
    assert sorted(p.name for p in out.iterdir()) == [f"{stem}.bvh", f"{stem}.gltf"]
    with pytest.raises(UserError, match="avi"):
        ScriptPlayer([{"type": "export", "frame": 0, "dir": str(out), "formats": ["avi"]}])
