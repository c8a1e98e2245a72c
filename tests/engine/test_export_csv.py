"""The CSV export: names that carry unit and order, rotations that rebuild the
clip (Euler in each joint's channel order, or quaternions), no column that is
zero in every frame unless asked (engine.export.write_csv)."""
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from engine import quat
from engine.export import write_take
from engine.skeleton import Clip, Skeleton


def read_csv(path):
    """Header and columns by name, with the csv module (not engine code)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    head, values = rows[0], np.array(rows[1:], float)
    return head, {name: values[:, i] for i, name in enumerate(head)}


def foreign_take(frames=40, seed=0):
    """A small skeleton in mixed channel orders, one joint never turning about x."""
    skel = Skeleton(["Root", "Chest", "Arm"], [-1, 0, 1], [[0, 90, 0], [0, 20, 0], [15, 0, 0]],
                    channel_orders=["YXZ", "ZXY", "ZYX"])
    rng = np.random.default_rng(seed)
    e = np.cumsum(rng.normal(0, 6, (frames, 3, 3)), axis=0)
    e[:, 2, 2] = 0.0                                          # Arm: no x rotation ever
    q = np.stack([quat.from_euler(e[:, j], o) for j, o in enumerate(skel.channel_orders)], 1)
    return skel, Clip(rng.normal(0, 5, (frames, 3)) + [0, 90, 0], q, 30.0)


def rotations_from(cols, skel, rotations):
    """``(F, J, 4)`` rebuilt from the CSV's columns (a left-out column is 0)."""
    F = len(cols["frame"])
    out = []
    for name, order in zip(skel.names, skel.channel_orders):
        if rotations == "euler":
            e = np.stack([cols.get(f"{name}_r{a.lower()}_deg", np.zeros(F)) for a in order], -1)
            out.append(quat.from_euler(e, order))
        else:
            out.append(np.stack([cols.get(f"{name}_q{a}", np.zeros(F)) for a in "wxyz"], -1))
    return np.stack(out, 1)


@pytest.mark.parametrize("rotations", ["euler", "quaternion"])
def test_columns_name_unit_and_order_and_rebuild_the_rotations(tmp_path, rotations):
    skel, clip = foreign_take()
    path = tmp_path / "t.csv"
    write_take(path, skel, clip, name="t", blend=np.linspace(0, 1, clip.num_frames), csv_rotations=rotations)
    head, cols = read_csv(path)
    assert head[:6] == ["frame", "time_s", "blend", "root_x_cm", "root_y_cm", "root_z_cm"]
    if rotations == "euler":
        assert head[6:9] == ["Root_ry_deg", "Root_rx_deg", "Root_rz_deg"]       # the joint's own order
        assert "Arm_rx_deg" not in head and "Arm_rz_deg" in head                # zero in every frame: left out
    else:
        assert head[6:10] == ["Root_qw", "Root_qx", "Root_qy", "Root_qz"]
    np.testing.assert_array_equal(cols["frame"], np.arange(clip.num_frames))
    np.testing.assert_allclose(cols["time_s"], np.arange(clip.num_frames) / 30.0, atol=1e-6)
    np.testing.assert_allclose(np.stack([cols[f"root_{a}_cm"] for a in "xyz"], 1), clip.root_positions, atol=1e-6)
    got = rotations_from(cols, skel, rotations)
    dots = np.abs(np.sum(quat.normalize(got) * clip.local_rotations, -1))
    assert np.degrees(2 * np.arccos(np.clip(dots, 0, 1))).max() < 1e-3             # 6 decimals
    assert all(np.any(v != 0) for n, v in cols.items() if n != "frame")


def test_all_columns_when_asked_and_a_bad_choice_is_refused(tmp_path):
    skel, clip = foreign_take()
    write_take(tmp_path / "all.csv", skel, clip, name="t", csv_all_columns=True)
    head, cols = read_csv(tmp_path / "all.csv")
    assert len(head) == 2 + 3 + 9 and not np.any(cols["Arm_rx_deg"])
    with pytest.raises(ValueError, match="euler, quaternion"):
        write_take(tmp_path / "bad.csv", skel, clip, name="t", csv_rotations="matrix")
    assert not (tmp_path / "bad.csv").exists()


def test_adapt_out_csv_has_the_blend_and_continuous_angles(tmp_path, rig):
    from engine.library import load_library
    shot = load_library(rig=rig)[3]
    hit = shot.hit_point + [4.0, 3.0, -5.0]
    out = tmp_path / "a.csv"
    done = subprocess.run([sys.executable, "-c", "from app.cli import main; main()", "adapt", "--shot", shot.name,
                           "--hit", *map(str, hit), "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    head, cols = read_csv(out)
    np.testing.assert_allclose(cols["blend"], json.loads(done.stdout)["blend"], atol=1e-4)
    assert "Bat_rz_deg" not in head and "LeftForeArm_ry_deg" in head
    angles = np.stack([v for n, v in cols.items() if n.endswith("_deg")], 1)
    assert np.abs(np.diff(angles, axis=0)).max() < 180                                  # never a wrap


def test_adapt_csv_rotations_option(tmp_path):
    """adapt --csv-rotations quaternion writes unit quaternion columns; a bad choice is one line."""
    import subprocess
    import sys
    cli = [sys.executable, "-c", "from app.cli import main; main()", "adapt", "--shot", "cover_drive",
           "--hit", "-70", "45", "215"]
    out = tmp_path / "q.csv"
    r = subprocess.run(cli + ["--out", str(out), "--csv-rotations", "quaternion"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    head = out.read_text().splitlines()[0].split(",")
    q = [i for i, h in enumerate(head) if h.startswith("LeftArm_q")]
    assert [head[i] for i in q] == ["LeftArm_qw", "LeftArm_qx", "LeftArm_qy", "LeftArm_qz"]
    import numpy as np
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    np.testing.assert_allclose(np.linalg.norm(rows[:, q], axis=1), 1.0, atol=1e-5)
    r = subprocess.run(cli + ["--csv-rotations", "nope"], capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
