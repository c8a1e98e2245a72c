"""The learnt solvers of the shot adapter (engine/learnt_solver.py, ``adapt --solver
learnt|learnt+ccd``; issue 17 item 2): learnt+ccd reaches reachable points with the
grip kept, pure learnt gives a finite pose whose reported bat error is the FK's,
frames of blend 0 are the source's bit for bit, the CLI's bad inputs are one line."""
import json
import subprocess
import sys

import numpy as np
import pytest

from engine import quat
from engine.adapt import Adapter, AdaptSettings
from engine.learnt_solver import LearntSolver, handles, learnt_start
from engine.library import load_library
from engine.skeleton import clip_fk, Clip

from tests.conftest import MOCAP
CLI = [sys.executable, "-c", "from app.cli import main; main()", "adapt"]
OFFSETS = [(15, 0, 0), (-15, 0, 0), (0, 15, 0), (0, -15, 0), (0, 0, 15), (0, 0, -15)]


@pytest.fixture(scope="module")
def shots(rig):
    return load_library(rig=rig)


@pytest.fixture(scope="module")
def solver(rig, shots):
    return LearntSolver(rig, shots)


def _fk(shot, a):
    """An independent FK of the adaptation's local rotations on the shot's skeleton."""
    return clip_fk(shot.skeleton, Clip(a.root_positions, a.local_rotations, shot.clip.fps))


@pytest.mark.parametrize("leave_out", [False, True])
def test_learnt_ccd_reaches_reachable_points_grip_kept(rig, shots, solver, leave_out):
    for shot in shots:
        adapter = Adapter(rig, shot)
        for off in OFFSETS:
            desired = shot.hit_point + np.array(off, float)
            ccd = adapter.adapt(desired, AdaptSettings())
            if ccd.bat_error_cm > 0.1:          # not reachable by CCD from the source either
                continue
            a = solver.adapt(adapter, desired, AdaptSettings(solver="learnt+ccd"), leave_out)
            grot, gpos = _fk(shot, a)
            assert np.linalg.norm(gpos[shot.hit_frame, rig.bat_joint] - desired) < 0.1, (shot.name, off)
            assert a.grip_error_cm.max() < 0.1 and a.grip_error_deg.max() < 1.0, (shot.name, off)
            # the grip measured independently: the trail hand in the lead hand's frame as in the source
            lh, rh = adapter.lhand, adapter.rhand
            rel = quat.rotate(quat.conjugate(grot[:, lh]), gpos[:, rh] - gpos[:, lh])
            assert np.abs(rel - adapter.rel_pos).max() < 0.1


def test_learnt_start_differs_from_source_and_ccd(rig, shots, solver):
    """learnt+ccd starts from the lookup, not from the source: its pose is not CCD's."""
    shot = shots[0]
    adapter = Adapter(rig, shot)
    desired = shot.hit_point + np.array([0.0, -15.0, 15.0])
    blend = adapter.blend(90.0)
    start = learnt_start(adapter, solver.model(), desired, blend)
    h = shot.hit_frame
    assert quat.angle_between(start[h], shot.clip.local_rotations[h]).max() > 1.0
    a = solver.adapt(adapter, desired, AdaptSettings(solver="learnt+ccd"))
    b = adapter.adapt(desired, AdaptSettings())
    assert quat.angle_between(a.local_rotations[h], b.local_rotations[h]).max() > 0.5


def test_pure_learnt_is_finite_and_reports_its_bat_error(rig, shots, solver):
    errors = []
    for shot in shots:
        adapter = Adapter(rig, shot)
        desired = shot.hit_point + np.array([0.0, 0.0, 30.0])
        a = solver.adapt(adapter, desired, AdaptSettings(solver="learnt"), leave_out=True)
        for name in ("local_rotations", "global_rotations", "global_positions", "grip_error_cm", "grip_error_deg"):
            assert np.isfinite(getattr(a, name)).all()
        _, gpos = _fk(shot, a)
        assert np.abs(gpos - a.global_positions).max() < 1e-6
        fk_err = np.linalg.norm(gpos[shot.hit_frame, rig.bat_joint] - desired)
        assert a.bat_error_cm == pytest.approx(fk_err, abs=1e-6)
        # the pose at the hit frame is the lookup's (blend 1): the bat near, not on, the ball
        np.testing.assert_allclose(a.handles[shot.hit_frame], desired, atol=1e-6)
        # the grip error as measured here; the trail hand is on its grip wherever its arm reaches
        grot = _fk(shot, a)[0]
        lh, rh = adapter.lhand, adapter.rhand
        want = gpos[:, lh] + quat.rotate(grot[:, lh], adapter.rel_pos)
        np.testing.assert_allclose(a.grip_error_cm, np.linalg.norm(gpos[:, rh] - want, axis=-1), atol=1e-6)
        assert np.median(a.grip_error_cm) < 0.01
        errors.append(fk_err)
    assert 0.0 < np.median(errors) < 60.0


@pytest.mark.parametrize("solver_name", ["learnt", "learnt+ccd"])
def test_blend_zero_frames_are_the_source(rig, shots, solver, solver_name):
    for shot in shots[:4]:
        adapter = Adapter(rig, shot)
        a = solver.adapt(adapter, shot.hit_point + np.array([0.0, -30.0, 0.0]),
                         AdaptSettings(solver=solver_name, falloff=60.0))
        zero = a.blend == 0.0
        assert zero.any() and not zero.all()
        assert np.array_equal(a.local_rotations[zero], shot.clip.local_rotations[zero])
        assert np.array_equal(a.global_positions[zero], shot.fk[1][zero])


def test_handles_are_the_kernels(rig, shots):
    """The handles the lookup is given are the ones CCD solves for."""
    shot = shots[3]
    adapter = Adapter(rig, shot)
    desired = shot.hit_point + np.array([10.0, -5.0, 20.0])
    a = adapter.adapt(desired, AdaptSettings())
    np.testing.assert_allclose(handles(adapter, desired, a.blend), a.handles, atol=1e-9)


def test_source_start_is_the_plain_adapter(rig, shots):
    shot = shots[1]
    adapter = Adapter(rig, shot)
    desired = shot.hit_point + np.array([0.0, 15.0, 0.0])
    a = adapter.adapt(desired, AdaptSettings())
    b = adapter.adapt(desired, AdaptSettings(), start=shot.clip.local_rotations)
    assert np.array_equal(a.local_rotations, b.local_rotations)
    with pytest.raises(ValueError):
        adapter.adapt(desired, AdaptSettings(), start=shot.clip.local_rotations[:-1])


def run_cli(*args):
    return subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=300)


def test_cli_learnt_solvers(tmp_path):
    out = {}
    for s in ("learnt", "learnt+ccd"):
        r = run_cli("--shot", "cover_drive", "--hit", "20", "95", "40", "--solver", s, "--leave-out")
        assert r.returncode == 0, r.stderr
        out[s] = json.loads(r.stdout)
        assert out[s]["solver"] == s and out[s]["leave_out"] and out[s]["learnt_training_shots"] == 8
    assert np.isfinite(out["learnt"]["bat_error_cm"]) and out["learnt"]["bat_error_cm"] > 0.1
    assert out["learnt+ccd"]["bat_error_cm"] < 0.1


@pytest.mark.parametrize("args", [
    ["--bvh", str(MOCAP / "cmu_63_02_golf_swing.bvh"), "--offset", "10", "0", "5", "--solver", "learnt",
     "--leave-out"],
    ["--shot", "pull", "--hit", "1", "2", "3", "--leave-out"],
    ["--shot", "pull", "--hit", "1", "2", "3", "--solver", "learnt", "--leave-out=yes"],
    ["--shot", "pull", "--hit", "1", "2", "3", "--solver", "learnt", "--direction", "10"],
    ["--shot", "pull", "--hit", "1", "2", "3", "--solver", "learnt+dls"],
])
def test_bad_input_one_line_exit_2(args):
    r = run_cli(*args)
    assert r.returncode == 2 and r.stdout == "", r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and r.stderr.startswith("error")


def test_cli_capture_learns_from_itself(tmp_path):
    out = tmp_path / "golf.bvh"
    r = run_cli("--bvh", str(MOCAP / "cmu_63_02_golf_swing.bvh"), "--offset", "10", "0", "5", "--solver",
                "learnt+ccd", "--out", str(out))
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["bat_error_cm"] < 0.1 and d["learnt_training_shots"] == 1 and out.stat().st_size > 0


def test_single_shot_library_with_leave_out_is_refused(tmp_path):
    """A library of one capture: learnt trains on it; with --leave-out nothing is left to learn from."""
    folder = tmp_path / "lib"
    folder.mkdir()
    (folder / "golf.bvh").write_bytes((MOCAP / "cmu_63_02_golf_swing.bvh").read_bytes())
    init = subprocess.run([sys.executable, "-c", "from app.cli import main; main()", "library", "init", str(folder)],
                          capture_output=True, text=True, timeout=300)
    assert init.returncode == 0, init.stderr
    base = ["--library", str(folder), "--shot", "golf", "--hit", "-10", "92", "0", "--solver", "learnt"]
    r = run_cli(*base, "--leave-out")
    assert r.returncode == 2 and r.stdout == "" and len(r.stderr.strip().splitlines()) == 1
    assert r.stderr.startswith("error") and "leave-out" in r.stderr
    r = run_cli(*base)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["learnt_training_shots"] == 1 and np.isfinite(d["bat_error_cm"])
