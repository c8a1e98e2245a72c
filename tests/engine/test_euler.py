"""Euler angles in the files we write (BVH, CSV) are continuous over time, equal to
the clip's rotations, and a file read and written back keeps its own numbers
(engine.euler, engine.bvh.file_euler)."""
import numpy as np
import pytest

from tests.conftest import MOCAP, ROOT
from engine import bvh, euler, quat
from engine.skeleton import Clip

ORDERS = ["ZYX", "XYZ", "ZXY", "YXZ", "YZX", "XZY"]
CMU = sorted(MOCAP.glob("*.bvh"))
SHOTS = sorted((ROOT / "assets" / "shots").glob("*.bvh"))
SMOOTH_DEG = 30.0     # a frame-to-frame turn below this is smooth motion at 30-120 fps
MIDPOINT_DEG = 5.0    # channels interpolated halfway stay this close to the slerp midpoint


def motion_values(text: str) -> np.ndarray:
    """The MOTION numbers of BVH text ``(F, channels)``, read independently of engine.bvh."""
    body = text[text.index("Frame Time:"):].split("\n", 1)[1]
    return np.array([[float(x) for x in line.split()] for line in body.strip().splitlines()])


def random_motion(frames=240, joints=5, seed=0, step=0.05):
    """Smooth random rotations ``(F, J, 4)`` that turn through several full turns."""
    rng = np.random.default_rng(seed)
    steps = np.cumsum(rng.normal(0, step, (frames, joints, 3)), axis=0)
    return quat.mul(quat.exp(rng.normal(0, 2, (1, joints, 3))), quat.exp(steps))


def turn_deg(a, b):
    """Angle (deg) between rotations ``a`` and ``b`` ``(...)``."""
    return np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(a * b, -1)), 0, 1)))


def midpoint_error(e, q, orders):
    """``(F-1, J)`` deg: the rotation of the channels' linear midpoint against the slerp
    midpoint of the two frames -- what a resampler or motion blur would get."""
    err = np.zeros((q.shape[0] - 1, q.shape[1]))
    for j, o in enumerate(orders):
        if o:
            mid = quat.from_euler(0.5 * (e[1:, j] + e[:-1, j]), o)
            err[:, j] = turn_deg(mid, quat.slerp(q[:-1, j], q[1:, j], 0.5))
    return err


def assert_continuous(e, q, orders, first=0):
    """Channels equal to the rotations, and smooth wherever the motion is."""
    for j, o in enumerate(orders):
        if o:
            assert turn_deg(quat.from_euler(e[:, j], o), q[:, j]).max() < 1e-5   # arccos near 1: ~1e-6 deg of float noise
    step = turn_deg(q[1:], q[:-1])[first:]
    err = midpoint_error(e, q, orders)[first:]
    assert err[step < SMOOTH_DEG].max(initial=0) < MIDPOINT_DEG


@pytest.mark.parametrize("order", ORDERS)
def test_continuous_in_every_order_matches_a_frame_by_frame_greedy(order):
    q = random_motion(seed=ORDERS.index(order))
    e = euler.continuous_order(q, order)
    assert_continuous(e, q, [order] * q.shape[1])
    principal = quat.to_euler(q, order)
    assert np.abs(np.diff(principal, axis=0)).max() > 300      # the motion does wrap
    # an independent per-frame loop: the branch nearest the previous frame, unwrapped
    branches = np.stack([principal, euler.other_branch(principal)], 2)
    cur, want = branches[0, :, 0], [branches[0, :, 0]]
    for f in range(1, len(q)):
        pick = np.abs(euler.wrap(branches[f] - cur[:, None])).sum(-1).argmin(1)
        cur = cur + euler.wrap(branches[f, np.arange(q.shape[1]), pick] - cur)
        want.append(cur)
    np.testing.assert_allclose(e, np.array(want), atol=1e-9)


def test_the_other_branch_is_the_same_rotation_in_every_order():
    q = quat.normalize(np.random.default_rng(1).normal(size=(500, 4)))
    for order in ORDERS:
        other = euler.other_branch(quat.to_euler(q, order))
        assert turn_deg(quat.from_euler(other, order), q).max() < 1e-5   # arccos near 1: ~1e-6 deg of float noise


def test_limits_pick_the_first_branch_and_the_reference_is_kept_where_unchanged():
    flex = quat.from_euler(np.stack([np.zeros(20), -np.linspace(100, 140, 20), np.zeros(20)], -1))[:, None]
    e = euler.continuous_order(flex, "ZYX", limits=np.array([[[0, 0], [-150, 0], [0, 0]]]))
    np.testing.assert_allclose(e[:, 0], np.stack([np.zeros(20), -np.linspace(100, 140, 20), np.zeros(20)], -1),
                               atol=1e-9)      # a pure flexion, not (180, -80, 180)
    q = random_motion(frames=60, joints=3, seed=7)
    ref = euler.continuous_order(q, "XYZ") + 360.0 * np.random.default_rng(2).integers(-1, 2, (60, 3, 3))
    moved = q.copy()
    moved[20:30] = quat.mul(moved[20:30], quat.exp(np.full((10, 3, 3), 0.02)))
    got = euler.continuous_order(moved, "XYZ", reference=ref)
    kept = np.ones(60, bool)
    kept[20:30] = False
    assert np.array_equal(got[kept], ref[kept])
    assert turn_deg(quat.from_euler(got, "XYZ"), moved).max() < 1e-5   # arccos near 1: ~1e-6 deg of float noise
    assert np.abs(got[20:30] - got[19:29]).max() < SMOOTH_DEG   # moved frames follow frame 19


@pytest.mark.parametrize("order", ["ZYX", "XYZ"])
def test_frames_after_a_kept_reference_hold_the_clip_s_rotations(order):
    """A CMU file's frame 0 is a T-pose and its frame 1 the swing's first pose, a jump the
    branch scan crosses to the other triple. Where a take keeps those frames (the file's
    numbers) and then moves, its later frames must hold its own rotations: before the fix
    the kept frames' scan state stayed on the other triple and every later frame's numbers
    were off by it (a synthesised golf take's hips turned up to 180 deg in 426 frames, its
    planted foot sliding 35 cm in the written file)."""
    F = 40
    pose = quat.from_euler(np.array([-132.3, 85.0, -115.9]), order)          # near the gimbal
    q = np.tile(pose, (F, 1, 1))
    q[0] = quat.identity((1,))                                                 # the T-pose frame
    q[3:] = quat.mul(q[3:], quat.exp(np.linspace(0.0, 0.6, F - 3)[:, None, None] * np.array([0.3, 0.5, 0.2])))
    ref = quat.to_euler(q, order)                   # the file's numbers, kept at frames 0-2
    ref[3:] += 7.0                                  # (the take moved from frame 3 on)
    got = euler.continuous_order(q, order, reference=ref)
    assert np.array_equal(got[:3], ref[:3])
    assert turn_deg(quat.from_euler(got, order), q).max() < 1e-5   # arccos near 1: ~1e-6 deg of float noise


@pytest.mark.parametrize("path", SHOTS + CMU, ids=lambda p: p.stem)
def test_bvh_written_from_rotations_is_continuous(path, tmp_path):
    skel, clip = bvh.read(path)
    fresh = Clip(clip.root_positions, clip.local_rotations, clip.fps, clip.local_positions)  # no file numbers
    out = tmp_path / "out.bvh"
    bvh.write(out, skel, fresh)
    skel2, clip2 = bvh.read(out)
    e = clip2.file_euler
    first = 1 if "golf" in path.stem else 0      # the conversion's added T-pose frame 0
    assert_continuous(e, clip.local_rotations, skel.channel_orders, first)
    old = np.stack([quat.to_euler(clip.local_rotations[:, j], o) if o else np.zeros((clip.num_frames, 3))
                    for j, o in enumerate(skel.channel_orders)], 1)
    step = turn_deg(clip.local_rotations[1:], clip.local_rotations[:-1])[first:]
    old_err = midpoint_error(old, clip.local_rotations, skel.channel_orders)[first:]
    if "walk" not in path.stem:            # the walk never wraps: nothing for the old writer to get wrong
        assert old_err[step < SMOOTH_DEG].max() > 90


@pytest.mark.parametrize("path", SHOTS + CMU, ids=lambda p: p.stem)
def test_a_file_read_and_written_back_keeps_its_numbers(path):
    skel, clip = bvh.read(path)
    np.testing.assert_array_equal(motion_values(bvh.format_bvh(skel, clip)), motion_values(path.read_text()))


def test_adapted_csv_and_bvh_hold_the_same_continuous_triplets(rig, tmp_path):
    from engine.export import write_take
    from engine.library import load_library
    shot = load_library(rig=rig)[0]
    clip = Clip(shot.clip.root_positions, shot.clip.local_rotations, shot.clip.fps)
    for ext in ("bvh", "csv"):
        write_take(tmp_path / f"t.{ext}", shot.skeleton, clip, name="t", limits=rig.limits)
    skel2, clip2 = bvh.read(tmp_path / "t.bvh")
    from_bvh = clip2.file_euler[:, [skel2.names.index(n) for n in shot.skeleton.names]]
    rows = np.loadtxt(tmp_path / "t.csv", delimiter=",", skiprows=1)
    cols = [c for c in (tmp_path / "t.csv").read_text().splitlines()[0].split(",")]
    for j, name in enumerate(shot.skeleton.names):
        for k, axis in enumerate("zyx"):
            hits = [i for i, c in enumerate(cols) if c.startswith(f"{name}_r{axis}") or c == f"{name}_{axis}"]
            if hits:
                np.testing.assert_allclose(rows[:, hits[0]], from_bvh[:, j, k], atol=1e-5)
    assert_continuous(from_bvh, clip.local_rotations, shot.skeleton.channel_orders)
