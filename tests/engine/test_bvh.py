"""BVH reading, writing and validation."""
import numpy as np
import pytest

from engine import bvh, quat
from engine.skeleton import clip_fk

from tests.conftest import MOCAP

GOLF = MOCAP / "cmu_63_02_golf_swing.bvh"

SMALL = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 90 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 20 0
\t\tCHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 1.5e1 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 90 2 10 20 30 0 20 0 -5 4 3
1.5 91 2.5 11 21 31 0.5 20 0 -6 5 2
"""


def rotations_equal(a, b, tol_deg=1e-6):
    return np.all(quat.angle_between(a, b) < tol_deg)


def test_parse_channel_orders_crlf_tabs_exponents_and_joint_translation():
    skel, clip = bvh.parse(SMALL.replace("\n", "\r\n"))
    assert skel.names == ["Hips", "Chest"]
    assert skel.channel_orders == ["ZXY", "YXZ"]
    assert np.allclose(skel.end_sites[1], [0, 15, 0])
    assert clip.num_frames == 2 and abs(clip.fps - 30.0) < 1e-3
    assert np.allclose(clip.root_positions[1], [1.5, 91, 2.5])
    assert np.allclose(clip.local_positions[1, 1], [0.5, 20, 0])
    q = quat.from_euler([10, 20, 30], "ZXY")
    assert rotations_equal(clip.local_rotations[0, 0], q)


def test_round_trip_small_file():
    skel, clip = bvh.parse(SMALL)
    skel2, clip2 = bvh.parse(bvh.format_bvh(skel, clip))
    assert skel2.names == skel.names and skel2.channel_orders == skel.channel_orders
    assert rotations_equal(clip.local_rotations, clip2.local_rotations)
    assert np.allclose(clip.local_positions, clip2.local_positions, atol=1e-8)


def test_round_trip_bundled_rig(tmp_path, rig):
    rng = np.random.default_rng(5)
    from engine.skeleton import Clip
    J = rig.skeleton.num_joints
    e = rng.uniform(-60, 60, size=(12, J, 3))
    rot = quat.from_euler(e)
    rot[:, rig.bat_joint] = quat.identity()
    clip = Clip(rng.normal(size=(12, 3)) * 10 + [0, 97, 0], rot)
    path = tmp_path / "rig.bvh"
    bvh.write(path, rig.skeleton, clip)
    skel2, clip2 = bvh.read(path)
    from engine.library import conform_to_rig
    skel2, clip2 = conform_to_rig(rig, skel2, clip2, str(path))
    assert skel2.names == rig.skeleton.names
    assert np.array_equal(skel2.parents, rig.skeleton.parents)
    assert np.allclose(skel2.offsets, rig.skeleton.offsets)
    assert rotations_equal(clip.local_rotations, clip2.local_rotations)
    assert np.allclose(clip.root_positions, clip2.root_positions, atol=1e-8)
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


def test_round_trip_foreign_cmu_file(tmp_path):
    skel, clip = bvh.read(GOLF)
    assert skel.num_joints == 31 and clip.num_frames == 494
    assert abs(clip.fps - 120) < 0.01
    out = tmp_path / "golf.bvh"
    bvh.write(out, skel, clip)
    skel2, clip2 = bvh.read(out)
    assert skel2.names == skel.names
    assert rotations_equal(clip.local_rotations, clip2.local_rotations)
    _, p1 = clip_fk(skel, clip)
    _, p2 = clip_fk(skel2, clip2)
    assert np.allclose(p1, p2, atol=1e-6)
    # the golfer's hands stay together on the club (about 13 cm, at 5.64 cm/unit)
    lh, rh = skel.index("LeftHand"), skel.index("RightHand")
    gap_cm = np.linalg.norm(p1[1:, lh] - p1[1:, rh], axis=-1) * 5.64
    assert 5 < np.median(gap_cm) < 25


BAD = {
    "empty": ("", "line 1", "HIERARCHY"),
    "no_hierarchy": (SMALL.replace("HIERARCHY", "HIERARCHI"), "line 1", "expected 'HIERARCHY'"),
    "bad_offset": (SMALL.replace("OFFSET 0 20 0", "OFFSET 0 abc 0"), "line 8", "OFFSET y"),
    "bad_channel": (SMALL.replace("Yrotation Xrotation Zrotation", "Yrotation Xrotation Wrotation"), "line 9", "channel name"),
    "two_rotations": (SMALL.replace("CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation",
                                    "CHANNELS 5 Xposition Yposition Zposition Yrotation Xrotation"), "", "0 or 3 rotation"),
    "missing_brace": (SMALL.replace("\t\t\tOFFSET 0 1.5e1 0\n\t\t}", "\t\t\tOFFSET 0 1.5e1 0\n"), "", "expected"),
    "short_row": (SMALL.replace("0.5 20 0 -6 5 2", "0.5 20 0 -6 5"), "line 20", "11 values, expected 12"),
    "missing_frame": (SMALL.replace("Frames: 2", "Frames: 3"), "", "expected 3"),
    "nan_value": (SMALL.replace("-6 5 2", "-6 nan 2"), "line 20", "finite"),
    "bad_frame_time": (SMALL.replace("Frame Time: 0.0333333", "Frame Time: 0"), "line 18", "frame time"),
    "bad_count": (SMALL.replace("Frames: 2", "Frames: two"), "line 17", "frame count"),
    "truncated": (SMALL[:SMALL.index("MOTION")], "", "unexpected end of file"),
    "duplicate_joint": (SMALL.replace("JOINT Chest", "JOINT Hips"), "line 6", "duplicate"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_malformed_files_raise_one_line_error_with_location(case):
    text, where, what = BAD[case]
    with pytest.raises(bvh.BvhError) as err:
        bvh.parse(text, "x.bvh")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("x.bvh")
    assert where in msg and what in msg, msg


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(bvh.BvhError, match="file not found"):
        bvh.read(tmp_path / "nope.bvh")
    p = tmp_path / "bin.bvh"
    p.write_bytes(b"\xff\xfe\x00\x01")
    with pytest.raises(bvh.BvhError, match="cannot read"):
        bvh.read(p)
