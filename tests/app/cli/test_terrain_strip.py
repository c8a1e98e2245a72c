"""Showing a terrain result (issue 17 item 4): ``render-strip --bvh RESULT --terrain SPEC``
draws the walk over its terrain mesh, terrain pixels under the feet in every cell;
``view --terrain SPEC`` draws the mesh instead of the pitch; bad input is one line."""
import subprocess
import sys

import numpy as np
import pytest

from app.cli.terrain_strip import foot_joints, load_terrain, terrain_strip
from engine import terrain as T
from engine.capture import load_capture

from tests.conftest import MOCAP
WALK = MOCAP / "cmu_02_01_walk.bvh"
CLI = [sys.executable, "-c", "from app.cli import main; main()"]
SPEC = "sine:amp=8,wavelength=120"
CELL = (240, 300)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """The walk retargeted over SPEC, written and read back as a user would."""
    out = tmp_path_factory.mktemp("terrain") / "walk.bvh"
    r = subprocess.run(CLI + ["terrain", "--bvh", str(WALK), "--terrain", SPEC, "--out", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return out, load_capture(out, "auto", hit_frame=0)


def project(view, proj, points, cell):
    h = np.concatenate([points, np.ones((len(points), 1))], 1) @ (np.asarray(proj) @ np.asarray(view)).T
    ndc = h[:, :2] / h[:, 3:]
    return np.stack([(ndc[:, 0] + 1) / 2 * cell[0], (1 - ndc[:, 1]) / 2 * cell[1]], 1)


def test_terrain_pixels_under_the_feet(result):
    from app.cli.render import TITLE_H
    _, cap = result
    ground = load_terrain(SPEC, cap.shot.clip.root_positions)
    sheet, cells = terrain_strip(cap.rig, cap.shot, ground, 4, CELL)
    img = np.asarray(sheet).astype(int)
    pos = cap.shot.fk[1]
    feet = foot_joints(cap.rig)
    checked = 0
    for c in cells:
        under = pos[c["frame"], feet].copy()
        under[:, 1] = ground.height(under[:, 0], under[:, 2])
        for x, y in project(c["view"], c["proj"], under, CELL):
            # the column below the ground point (the foot may cover its first pixels): brown
            # ground, and no blue sky
            col = img[TITLE_H + int(round(y)) + 1:TITLE_H + int(round(y)) + 15, c["x"] + int(round(x))]
            assert (col[:, 0] > col[:, 2] + 15).sum() >= 5, (c["frame"], col)
            assert not (col[:, 2] > col[:, 0] + 15).any(), (c["frame"], col)
            checked += 1
    assert checked == 4 * len(feet)


def test_render_strip_cli_writes_the_png(result, tmp_path):
    walk, _ = result
    png = tmp_path / "strip.png"
    r = subprocess.run(CLI + ["render-strip", "--bvh", str(walk), "--terrain", SPEC, "--frames", "3",
                              "--size", "200x260", "--out", str(png)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    from PIL import Image
    assert Image.open(png).size[0] == 600


@pytest.mark.parametrize("args", [
    ["render-strip", "--bvh", str(WALK), "--terrain", "sine:amp=oops", "--out", "x.png"],
    ["render-strip", "--shot", "pull", "--terrain", SPEC, "--out", "x.png"],
    ["render-strip", "--shot", "pull", "--bvh", str(WALK), "--out", "x.png"],
    ["render-strip", "--out", "x.png"],
    ["render-strip", "--bvh", "/no/such.bvh", "--out", "x.png"],
    ["view", "--headless", "--frames", "2", "--terrain", "steps:rise=-"],
])
def test_bad_input_one_line_exit_2(args, tmp_path):
    r = subprocess.run(CLI + args, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == "", r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and r.stderr.startswith("error")


def test_viewer_draws_the_terrain_instead_of_the_pitch(result, tmp_path):
    walk, _ = result
    folder = tmp_path / "lib"
    folder.mkdir()
    (folder / "walk.bvh").write_bytes(walk.read_bytes())
    r = subprocess.run(CLI + ["library", "init", str(folder), "--hit-frame", "0"], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    from app.render.submit import build_scene_view
    from app.viewer.loop import App
    from app.viewer.terrain import show_terrain
    app = App((640, 400), headless=True, manifest=folder)
    try:
        show_terrain(app.state, SPEC)
        app.frame(dt=1 / 60)
        mesh = app.state.terrain
        want = T.parse_spec(SPEC).height(mesh.positions[:, 0].astype(float), mesh.positions[:, 2].astype(float))
        np.testing.assert_allclose(mesh.positions[:, 1], want, atol=1e-3)           # the mesh lies on H
        view = build_scene_view(app.state, app.settings, app.camera, (640, 400))
        assert view.terrain is mesh and not view.show_pitch
    finally:
        app.close()
