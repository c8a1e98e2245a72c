"""The four solvers side by side (engine/solver_compare.py, ``hitpoint analyse
--solvers``, ``hitpoint bench``; issue 17 item 5): every figure finite for every
solver, nothing measured when nothing moves, limit hits counted where a pose sits
on a limit."""
import json
import subprocess
import sys

import numpy as np
import pytest

from engine import pca as pcam, quat
from engine.adapt import Adapter, AdaptSettings
from engine.learnt_solver import LearntSolver, SOLVERS
from engine.library import load_library
from engine.solver_compare import METRICS, measure, offset_grid, on_limits

CLI = [sys.executable, "-c", "from app.cli import main; main()", "analyse"]


@pytest.fixture(scope="module")
def shots(rig):
    return load_library(rig=rig)


def test_grid_is_each_distance_along_each_axis():
    g = offset_grid((15.0, 30.0))
    assert g.shape == (12, 3)
    assert sorted(np.abs(g).sum(1)) == [15.0] * 6 + [30.0] * 6
    assert (np.count_nonzero(g, axis=1) == 1).all() and len(np.unique(g, axis=0)) == 12


def test_limit_hits_see_a_joint_put_on_its_limit(rig, shots):
    local = shots[0].clip.local_rotations[:1].copy()
    elbow = rig.skeleton.names.index("LeftForeArm")
    free = np.flatnonzero(rig.dof_mask(0)[elbow])[0]
    lo, hi = rig.limits[elbow, free]
    angles = np.zeros(3)
    angles[free] = hi + 5.0                              # past its limit, on one free axis
    local[0, elbow] = quat.from_euler(angles, "ZYX")
    assert on_limits(rig, local)[0, elbow]
    angles[free] = 0.5 * (lo + hi)
    local[0, elbow] = quat.from_euler(angles, "ZYX")
    assert not on_limits(rig, local)[0, elbow]


@pytest.mark.parametrize("solver_name", SOLVERS)
def test_the_source_hit_point_measures_nothing(rig, shots, solver_name):
    shot = shots[2]
    adapter = Adapter(rig, shot)
    learnt = LearntSolver(rig, shots)
    space = pcam.fit_clip(rig, shot.clip, "upper")
    src = on_limits(rig, shot.clip.local_rotations)
    m = measure(rig, shot, adapter, learnt, shot.hit_point, AdaptSettings(solver=solver_name), False, space, src)
    assert set(m) == set(METRICS) and all(np.isfinite(v) for v in m.values())
    if solver_name in ("ccd", "dls"):     # the bat is already there: nothing moves
        assert m["bat_error_cm"] < 1e-3 and m["limit_hits"] == 0 and m["style_rmse"] < 1e-3
        assert m["face_angle_deg"] < 0.1
    if solver_name == "learnt+ccd":       # starts from the data's arm, the bat ends where it was
        assert m["bat_error_cm"] < 1e-3


def test_analyse_solvers_prints_all_four_finite():
    r = subprocess.run(CLI + ["--solvers", "--json", "--shot", "pull", "--shot", "cover_drive", "--offsets", "20",
                              "--leave-out"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert rep["solvers"] == list(SOLVERS) and len(rep["offsets_cm"]) == 6 and rep["leave_out"]
    for row in rep["shots"] + [{"solvers": rep["overall"]}]:
        for s in SOLVERS:
            figures = row["solvers"][s]
            assert all(isinstance(figures[m], (int, float)) and np.isfinite(figures[m]) for m in METRICS)
    assert rep["overall"]["learnt+ccd"]["bat_error_cm"] < 0.1 and rep["overall"]["ccd"]["bat_error_cm"] < 0.1
    assert rep["overall"]["learnt"]["bat_error_cm"] > 0.1        # the pure lookup: what the data gives
    t = subprocess.run(CLI + ["--solvers", "--shot", "pull", "--offsets", "20"], capture_output=True, text=True,
                       timeout=600)
    assert t.returncode == 0 and all(s in t.stdout for s in SOLVERS)


def test_analyse_solvers_leave_out_needs_two_shots():
    r = subprocess.run(CLI + ["--solvers", "--shot", "pull", "--leave-out", "--offsets", "20"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and r.stderr.startswith("error")


def test_bench_reports_the_four_solvers(rig):
    from app.cli.bench import solver_figures
    fig = solver_figures(rig)["median_over_shots"]
    assert list(fig) == list(SOLVERS)
    for s in SOLVERS:
        assert all(isinstance(fig[s][m], (int, float)) and np.isfinite(fig[s][m]) for m in METRICS)
        assert fig[s]["us_per_frame"] > 0
