"""Forward kinematics against hand-computed positions, under rotated and mirrored roots."""
import numpy as np

from engine import quat
from engine.skeleton import Clip, Skeleton, clip_fk, forward_kinematics, skinning_matrices, bind_positions

PARENTS = np.array([-1, 0, 1])
OFFSETS = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 5.0, 0.0]])


def chain_positions(root_pos, rotations):
    t = OFFSETS.copy()
    t[0] = root_pos
    return forward_kinematics(PARENTS, t, rotations)[1]


def test_fk_matches_hand_computation():
    rot = quat.from_euler(np.array([[0, 90, 0], [90, 0, 0], [0, 0, 0]], float), "ZYX")
    pos = chain_positions([1.0, 2.0, 3.0], rot)
    # Ry(90) takes +X to -Z; Rz(90) takes +Y to -X, then Ry(90) takes -X to +Z.
    assert np.allclose(pos, [[1, 2, 3], [1, 2, -7], [1, 2, -2]], atol=1e-12)


def test_fk_batches_over_frames():
    rng = np.random.default_rng(1)
    rot = quat.normalize(rng.normal(size=(20, 3, 4)))
    t = np.broadcast_to(OFFSETS, (20, 3, 3)).copy()
    _, pos = forward_kinematics(PARENTS, t, rot)
    for f in (0, 7, 19):
        assert np.allclose(pos[f], forward_kinematics(PARENTS, t[f], rot[f])[1])


def test_fk_under_rotated_root_rotates_everything():
    rng = np.random.default_rng(2)
    rot = quat.normalize(rng.normal(size=(3, 4)))
    root = np.array([4.0, -1.0, 2.0])
    base = chain_positions(root, rot)
    Q = quat.from_axis_angle([0.3, 1.0, -0.2], 1.1)
    rot2 = rot.copy()
    rot2[0] = quat.mul(Q, rot[0])
    moved = chain_positions(quat.rotate(Q, root), rot2)
    assert np.allclose(moved, quat.rotate(Q, base), atol=1e-12)


def test_fk_under_mirrored_root_mirrors_everything():
    """Mirroring x -> -x: offsets flip x, quaternions (w,x,y,z) -> (w,x,-y,-z)."""
    rng = np.random.default_rng(3)
    rot = quat.normalize(rng.normal(size=(3, 4)))
    root = np.array([4.0, -1.0, 2.0])
    base = chain_positions(root, rot)
    flip = np.array([-1.0, 1.0, 1.0])
    t = OFFSETS * flip
    t[0] = root * flip
    mirrored = forward_kinematics(PARENTS, t, rot * np.array([1.0, 1.0, -1.0, -1.0]))[1]
    assert np.allclose(mirrored, base * flip, atol=1e-12)


def test_skinning_matrices_are_identity_in_bind_pose_and_move_vertices_rigidly():
    skel = Skeleton(["a", "b", "c"], PARENTS, OFFSETS)
    bind = bind_positions(skel)
    rest = quat.identity((1, 3))
    clip = Clip(OFFSETS[:1].copy(), rest)
    g_rot, g_pos = clip_fk(skel, clip)
    M = skinning_matrices(g_rot, g_pos, bind)
    assert np.allclose(M, np.eye(4), atol=1e-6)
    rot = quat.from_euler(np.array([[[0, 30, 0], [45, 0, 0], [0, 0, 10]]], float))
    g_rot, g_pos = clip_fk(skel, Clip(OFFSETS[:1].copy(), rot))
    M = skinning_matrices(g_rot, g_pos, bind)[0]
    # the bind position of each joint lands on its posed position
    homog = np.concatenate([bind, np.ones((3, 1))], axis=1)
    assert np.allclose(np.einsum("jab,jb->ja", M, homog)[:, :3], g_pos[0], atol=1e-5)
