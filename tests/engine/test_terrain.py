"""Terrain retargeting (engine/terrain.py, ``hitpoint terrain``; reference 002 section
5.4 and appendix B) on the real CMU walk: the written file, read back and put
through an FK written here, keeps its planted feet on H (within a couple of cm of
their captured clearance) and never sinks a foot into it; the upper body is as
captured; bad terrain specs get one line and exit 2."""
import json
import subprocess
import sys

import numpy as np
import pytest

from engine import bvh, terrain as T
from engine.cleanup import planted_runs

from tests.conftest import MOCAP
WALK = MOCAP / "cmu_02_01_walk.bvh"
CLI = [sys.executable, "-c", "from app.cli import main; main()", "terrain"]
FEET = {"left": ("LeftFoot", "LeftToeBase"), "right": ("RightFoot", "RightToeBase")}
LEGS = {"LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
        "RHipJoint", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase"}


def rotation_matrices(q):
    """(..., 4) unit quaternions (w, x, y, z) -> (..., 3, 3), written out here."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def world_positions(skel, clip):
    """(F, J, 3) joint positions by matrices: p_j = p_parent + R_parent offset_j."""
    R = rotation_matrices(clip.local_rotations)
    F, J = R.shape[:2]
    G, P = np.empty_like(R), np.empty((F, J, 3))
    for j, p in enumerate(skel.parents):
        if p < 0:
            G[:, j], P[:, j] = R[:, j], clip.root_positions
        else:
            G[:, j] = G[:, p] @ R[:, j]
            P[:, j] = P[:, p] + G[:, p] @ skel.offsets[j]
    return P


def contact_points(skel, pos, side, rest):
    """(F, 2, 3): the heel (rest below the ankle) and the toe joint."""
    ankle, toe = (skel.names.index(n) for n in FEET[side])
    return np.stack([pos[:, ankle] - [0, rest, 0], pos[:, toe]], axis=1)


@pytest.fixture(scope="module")
def source():
    from engine.capture import load_capture
    skel, clip = bvh.read(WALK)
    scale = load_capture(WALK, "auto", hit_frame=0).scale
    return skel, clip, scale, world_positions(skel, clip) * scale


def run_cli(*args):
    return subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=300)


def check_feet(tmp_path, source, spec):
    """Write the walk over ``spec``, read it back, FK here: never sunk; in planted frames
    a contact point within 2 cm of its captured height
    above the floor, now above H, and none lower than its captured height."""
    skel, clip, scale, src = source
    out = tmp_path / "over.bvh"
    r = run_cli("--bvh", str(WALK), "--terrain", spec, "--out", str(out))
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    got_skel, got_clip = bvh.read(out)
    assert got_skel.names == skel.names and got_clip.num_frames == clip.num_frames
    pos = world_positions(got_skel, got_clip) * scale
    ground = T.parse_spec(spec)
    T.place_steps(ground, src[:, 0])
    for side, (ankle_name, _) in FEET.items():
        ankle = skel.names.index(ankle_name)
        planted = np.zeros(clip.num_frames, bool)
        for a, b in planted_runs(src[:, ankle], clip.fps, speed_tol=T.WALK_PLANT_SPEED, min_frames=12):
            planted[a:b] = True
        assert planted.sum() > 50, side
        rest = src[planted, ankle, 1].min()
        new = contact_points(skel, pos, side, rest)
        clear = new[..., 1] - ground.height(new[..., 0], new[..., 2])
        assert clear.min() > -0.1, (side, clear.min())                    # never sinks
        captured = contact_points(skel, src, side, rest)[..., 1]           # clearance over the flat floor
        gap = (clear - captured).min(axis=1)[planted]      # the foot's point nearest its captured height
        assert gap.min() > -0.1 and gap.max() < 2.0, (side, np.sort(gap)[-5:])
        assert summary[f"{side}_min_clearance_cm"] > -0.1
    return summary, got_skel, got_clip


def test_sine_bumps_planted_feet_on_h_never_sinking(tmp_path, source):
    summary, skel, got = check_feet(tmp_path, source, "sine:amp=12,wavelength=180")
    _, clip, _, _ = source
    assert summary["rise_cm"][1] - summary["rise_cm"][0] > 5          # the skeleton does follow the bumps
    upper = [j for j, n in enumerate(skel.names) if n not in LEGS and j > 0]
    assert np.allclose(np.abs(np.sum(got.local_rotations[:, upper] * clip.local_rotations[:, upper], -1)), 1,
                       atol=1e-5)                                     # the upper body as captured


def test_stairs_planted_on_their_step_never_sinking(tmp_path, source):
    summary, _, _ = check_feet(tmp_path, source, "steps:rise=15,run=60")
    assert summary["rise_cm"][1] >= 60                                # up several steps


def test_height_map_npy(tmp_path, source):
    grid = np.zeros((3, 3))
    grid[1:, :] = 8.0                       # a ledge over the far two-thirds in z
    f = tmp_path / "ground.npy"
    np.save(f, grid)
    check_feet(tmp_path, source, f"npy:file={f},x0=-200,x1=300,z0=-300,z1=300")


def test_terrain_functions():
    s = T.parse_spec("sine:amp=10,wavelength=200")
    assert np.isclose(s.height(50.0, 0.0), 10.0) and np.isclose(s.height(50.0, 100.0), -10.0)
    st = T.parse_spec("steps:rise=15,run=60")
    T.place_steps(st, np.array([[0.0, 90.0, 0.0], [0.0, 90.0, 500.0]]))
    assert np.allclose(st.height(0.0, [0.0, 29.0, 31.0, 91.0, -31.0]), [0, 0, 15, 30, -15])


@pytest.mark.parametrize("spec", ["bumps:amp=1", "sine:amp=10", "sine:amp=x,wavelength=10",
                                  "sine:amp=10,wavelength=0", "steps:rise=1,run=2,run=3",
                                  "npy:file=/no/such.npy,x0=0,x1=1,z0=0,z1=1", "sine:amp=nan,wavelength=5"])
def test_bad_terrain_one_line_exit_2(spec, tmp_path):
    out = tmp_path / "x.bvh"
    r = run_cli("--bvh", str(WALK), "--terrain", spec, "--out", str(out))
    assert r.returncode == 2 and r.stdout == "" and not out.exists()
    assert len(r.stderr.strip().splitlines()) == 1 and r.stderr.startswith("error")


def test_pickled_height_map_is_refused(tmp_path):
    f = tmp_path / "evil.npy"
    np.save(f, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    r = run_cli("--bvh", str(WALK), "--terrain", f"npy:file={f},x0=0,x1=1,z0=0,z1=1")
    assert r.returncode == 2 and "plain .npy" in r.stderr


def test_missing_walk_one_line(tmp_path):
    r = run_cli("--bvh", str(tmp_path / "none.bvh"), "--terrain", "sine:amp=1,wavelength=100")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_terrain_mesh_lies_on_h_and_faces_up():
    ground = T.parse_spec("sine:amp=10,wavelength=200")
    verts, tris = T.terrain_mesh(ground, (-100, 100), (0, 300), cell=25)
    assert np.allclose(verts[:, 1], ground.height(verts[:, 0], verts[:, 2]))
    a, b, c = (verts[tris[:, k]] for k in range(3))
    assert np.all(np.cross(b - a, c - a)[:, 1] > 0) and tris.max() == len(verts) - 1
