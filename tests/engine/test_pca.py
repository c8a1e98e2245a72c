"""PCA of a shot: reconstruction, projection, standardisation, style error."""
import numpy as np
import pytest

from engine import pca as pcam
from engine import quat
from engine.skeleton import Clip
from tests.motion_kit import smooth_random_clip


@pytest.fixture(scope="module")
def clip(rig):
    return smooth_random_clip(rig)


@pytest.fixture(scope="module")
def body(rig, clip):
    return pcam.fit_clip(rig, clip, "body")


def _same_rotation(a, b, tol):
    return np.all(np.abs(np.abs(np.sum(a * b, axis=-1)) - 1) < tol)


def test_parameter_count_and_explained(rig, body):
    assert body.num_params == 3 + 4 * rig.animated_joints == 107
    assert body.loadings.shape == (107, body.num_components)
    assert np.isclose(body.explained.sum(), 1.0)
    assert np.all(np.diff(body.explained) <= 1e-12)
    assert np.all(np.diff(body.cumulative) >= -1e-12)
    # orthonormal loadings
    assert np.allclose(body.loadings.T @ body.loadings, np.eye(body.num_components), atol=1e-9)


def test_full_reconstruction_returns_source(rig, clip, body):
    X = pcam.shot_parameters(clip.root_positions, clip.local_rotations, pcam.body_joints(rig))
    assert np.max(np.abs(body.reconstruct(body.scores) - X)) < 1e-6
    root, rot = body.pose_from_scores(body.scores)
    assert np.max(np.abs(root - clip.root_positions)) < 1e-6
    assert _same_rotation(rot, clip.local_rotations, 1e-6)
    assert np.allclose(rot[:, rig.bat_joint], [1, 0, 0, 0])


def test_error_falls_monotonically(rig, clip, body):
    X = pcam.shot_parameters(clip.root_positions, clip.local_rotations, pcam.body_joints(rig))
    errs = [np.sqrt(np.mean((body.reconstruct(body.scores, k) - X) ** 2))
            for k in range(0, body.num_components + 1)]
    assert all(b <= a + 1e-9 for a, b in zip(errs, errs[1:]))
    assert errs[0] > errs[3] > errs[-1]
    assert errs[-1] < 1e-6


def test_projecting_source_gives_its_scores(clip, body):
    s = body.project_pose(clip.root_positions, clip.local_rotations)
    assert np.allclose(s, body.scores, atol=1e-9)
    # single poses project the same way
    f = 40
    s1 = body.project_pose(clip.root_positions[f], clip.local_rotations[f], continuous=False)
    assert np.allclose(s1, body.scores[f], atol=1e-9)


def test_style_rmse_of_shot_against_itself_is_zero(rig, clip, body):
    assert pcam.style_error(body, clip.root_positions, clip.local_rotations) < 1e-9
    upper = pcam.fit_clip(rig, clip, "upper")
    assert pcam.style_error(upper, clip.root_positions, clip.local_rotations) < 1e-9
    # a changed clip has a positive error; sign flips of stored quaternions do not matter
    other = clip.copy()
    other.local_rotations = -other.local_rotations
    assert pcam.style_error(body, other.root_positions, other.local_rotations) < 1e-9
    other.local_rotations[:, 7] = quat.mul(other.local_rotations[:, 7], quat.from_euler([0, 0, 20]))
    assert pcam.style_error(body, other.root_positions, other.local_rotations) > 1e-3


def test_style_rmse_formula():
    a = np.zeros((4, 3))
    b = np.zeros((4, 3))
    b[0] = (3, 4, 0)            # distance 5 in one frame of four
    assert np.isclose(pcam.style_rmse(a, b), np.sqrt(25 / 4))


def test_constant_parameters_do_not_produce_nan(rig, clip):
    still = clip.copy()
    still.local_rotations[:, 3] = quat.from_euler([10, 20, 30])   # a frozen joint
    still.root_positions[:, 1] = 95.0                             # constant height
    p = pcam.fit_clip(rig, still, "body")
    for arr in (p.mean, p.sd, p.loadings, p.scores, p.explained):
        assert np.all(np.isfinite(arr))
    root, rot = p.pose_from_scores(p.scores[:, :3])
    assert np.all(np.isfinite(root)) and np.all(np.isfinite(rot))
    assert np.allclose(root[:, 1], 95.0)
    assert _same_rotation(rot[:, 3], quat.from_euler([10, 20, 30]), 1e-9)
    # a completely still clip: all parameters constant
    frozen = Clip(np.repeat(clip.root_positions[:1], 10, 0), np.repeat(clip.local_rotations[:1], 10, 0))
    p = pcam.fit_clip(rig, frozen, "body")
    assert np.all(np.isfinite(p.scores)) and np.all(np.isfinite(p.explained))
    root, rot = p.pose_from_scores(np.zeros(2))
    assert np.allclose(root, frozen.root_positions[0])


def test_upper_body_part(rig, clip):
    up = pcam.fit_clip(rig, clip, "upper")
    names = [rig.skeleton.names[j] for j in up.joints]
    assert "Hips" not in names and "LeftUpLeg" not in names and "Bat" not in names
    assert "Spine" in names and "Head" in names and "RightHand" in names and "LeftHand" in names
    assert up.num_params == 4 * len(names)
    root, rot = up.pose_from_scores(np.zeros(3))
    assert np.allclose(root, clip.root_positions.mean(0))
    assert np.allclose(np.linalg.norm(rot, axis=-1), 1)


def test_single_and_batched_poses_agree(body):
    s = body.scores[:5, :2]
    root, rot = body.pose_from_scores(s)
    r1, q1 = body.pose_from_scores(s[3])
    assert root.shape == (5, 3) and rot.shape[0] == 5
    assert np.allclose(r1, root[3]) and np.allclose(q1, rot[3])


def test_multi_shot_space(rig, clip):
    other = smooth_random_clip(rig, 60, seed=5)
    p = pcam.fit_clips(rig, [clip, other])
    assert p.scores.shape[0] == clip.num_frames + other.num_frames
    assert np.isclose(p.explained.sum(), 1)


def test_real_mocap_golf_swing():
    """A real swing (CMU 63_02): a few PCs carry most of it, as the dissertation
    found for cricket shots; all PCs give it back exactly."""
    from tests.conftest import MOCAP
    from engine import bvh
    path = MOCAP / "cmu_63_02_golf_swing.bvh"
    assert path.exists(), f"the shared CMU capture is missing: {path}"
    skel, c = bvh.read(path)
    root, rot = c.root_positions[1::4], c.local_rotations[1::4]     # skip the added T-pose; 30 fps
    p = pcam.fit(root, rot)
    assert p.num_params == 3 + 4 * skel.num_joints
    assert p.cumulative[2] > 0.7
    r, q = p.pose_from_scores(p.scores)
    assert np.max(np.abs(r - root)) < 1e-6
    assert _same_rotation(q, rot, 1e-6)
    assert pcam.style_error(p, root, rot) < 1e-9


def _bundled_shots(rig):
    from engine.library import load_library
    from engine.rig import assets_dir
    assert (assets_dir() / "shots" / "library.json").exists(), "the bundled shot library is missing"
    return load_library(rig=rig)


def test_bundled_shots_reconstruct_and_adapt_in_place(rig):
    """Every bundled shot: all PCs give it back; adapting it to its own FK hit
    point changes nothing, so its style error is 0 at either wrist setting."""
    for shot in _bundled_shots(rig):
        p = pcam.fit_clip(rig, shot.clip, "upper")
        body = pcam.fit_clip(rig, shot.clip, "body")
        root, rot = body.pose_from_scores(body.scores)
        assert np.max(np.abs(root - shot.clip.root_positions)) < 1e-6
        assert _same_rotation(rot[:, :rig.animated_joints], shot.clip.local_rotations[:, :rig.animated_joints], 1e-6)
        try:
            from engine.adapt import AdaptSettings, Adapter
        except ImportError:
            continue
        adapter = Adapter(rig, shot)
        for dof in (0, 2):
            a = adapter.adapt(shot.hit_point, AdaptSettings(wrist_dof=dof))
            assert pcam.style_error(p, a.root_positions, a.local_rotations) < 1e-3, shot.name
