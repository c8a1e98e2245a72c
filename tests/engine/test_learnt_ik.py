"""Learnt IK (engine/learnt_ik.py, reference 002): the dual-layer model on synthetic
data with known clusters, a training constraint finding its own pose, the
exponential-map smoothing of eq. 13, a training shot rebuilt from its own constraints."""
import numpy as np
import pytest

from engine import learnt_ik as L, quat
from engine.skeleton import Skeleton

Z = np.array([0.0, 0.0, 1.0])


def planar_arm():
    """base -> shoulder -> elbow -> tip, two 30 cm links; the limb is shoulder..tip under base."""
    skel = Skeleton(["base", "shoulder", "elbow", "tip"], [-1, 0, 1, 2],
                    [[0, 0, 0], [0, 10, 0], [30, 0, 0], [30, 0, 0]])
    return skel, L.make_limb("arm", skel, [1, 2, 3], [3], parent=0)


def planar_poses(shoulder_deg, elbow_deg):
    """Local rotations (F, 3, 4) turning shoulder and elbow about z (tip: identity)."""
    s, e = np.atleast_1d(np.radians(shoulder_deg)), np.atleast_1d(np.radians(elbow_deg))
    return np.stack([quat.from_axis_angle(np.broadcast_to(Z, (len(s), 3)), s), quat.from_axis_angle(np.broadcast_to(Z, (len(e), 3)), e),
                     quat.identity(s.shape)], axis=1)


def test_known_clusters_are_found():
    """Three separated groups of poses: three first-layer clusters, one angle
    cluster each, their means at the groups' centres, Q(mu) their FK."""
    rng = np.random.default_rng(1)
    centres = np.array([[0.0, 20.0], [60.0, 40.0], [-70.0, 90.0]])
    sh = np.concatenate([c[0] + rng.normal(0, 0.5, 40) for c in centres])
    el = np.concatenate([c[1] + rng.normal(0, 0.5, 40) for c in centres])
    _, limb = planar_arm()
    m = L.train(limb, planar_poses(sh, el), L.LearntSettings(clusters=3, tolerance=0.2))
    assert m.p_mu.shape == (3, 3) and m.angle_clusters == 3
    assert sorted(m.a_count) == [40, 40, 40]
    want = planar_poses(centres[:, 0], centres[:, 1])
    got_err = [min(quat.angle_between(m.a_quat[k], w).max() for k in range(3)) for w in want]
    assert max(got_err) < 0.5                          # degrees
    assert np.allclose(m.a_eff, L.limb_fk(limb, m.a_quat)[:, 2], atol=1e-9)
    assert np.all(m.p_d[:, :2] > 0) and np.all(m.p_d < 2.0)   # 0.5 deg of noise at 60 cm; z: planar


def test_two_branches_under_one_constraint_cluster():
    """Elbow up and elbow down reach the same tip: one constraint cluster, two angle
    clusters (appendix A finds the count); the previous frame (F) picks the branch."""
    sh = np.array([30.0, 30.5, 29.5, -30.0, -30.5, -29.5])
    el = np.array([-60.0, -61.0, -59.0, 60.0, 61.0, 59.0])
    _, limb = planar_arm()
    s = L.LearntSettings(clusters=1, tolerance=0.1, G=1.0, F=1.0, A=0.0, B=1.0)
    m = L.train(limb, planar_poses(sh, el), s)
    assert m.angle_clusters == 2 and sorted(m.a_count) == [3, 3]
    x = L.limb_fk(limb, planar_poses(30.0, -60.0))[0, 2]
    for prev_sh, prev_el in ((30.0, -60.0), (-30.0, 60.0)):
        prev = planar_poses(prev_sh, prev_el)[0]
        got = L.solve_limb(m, x, prev)
        assert quat.angle_between(got, prev).max() < 2.0, (prev_sh, got)


def test_training_constraint_looks_up_its_training_pose(rig):
    """Tolerance 0 keeps every training pose as its own angle cluster; without the
    previous-frame term and smoothing, a training frame's constraint gives that pose."""
    from engine.library import load_library
    shots = load_library(rig=rig)
    s = L.LearntSettings(tolerance=0.0, F=0.0, A=0.0, B=1.0)
    models = L.train_chains(rig, [sh.clip.local_rotations for sh in shots], s)
    sh = shots[3]
    for name, m in models.items():
        x = L.constraints(m.limb, *sh.fk)
        q, _ = L.lookup(m, x)
        pos = L.limb_fk(m.limb, q)
        true = L.limb_fk(m.limb, sh.clip.local_rotations[:, m.limb.joints])
        assert np.abs(pos - true).max() < 1e-6, name


def test_smoothing_is_eq13_on_exponential_maps():
    """One training pose mu: frame t gives exp(A e_{t-1} + B log mu), starting from the
    given previous pose; A=0, B=1 gives mu itself."""
    _, limb = planar_arm()
    mu = planar_poses(np.array([40.0]), np.array([-50.0]))
    prev = planar_poses(-10.0, 20.0)[0]
    x = np.repeat(L.limb_fk(limb, mu)[:, 2], 4, axis=0)
    for A, B in ((0.3, 0.7), (0.5, 0.25), (0.0, 1.0)):
        m = L.train(limb, mu, L.LearntSettings(clusters=1, A=A, B=B))
        got, _ = L.lookup(m, x, prev)
        e = quat.log(prev)
        for t in range(len(x)):
            e = A * e + B * quat.log(mu[0])
            assert quat.angle_between(got[t], quat.exp(e)).max() < 1e-6, (A, B, t)
    assert quat.angle_between(got, mu).max() < 1e-6


def test_no_previous_frame_takes_the_cluster_pose():
    _, limb = planar_arm()
    mu = planar_poses(np.array([40.0]), np.array([-50.0]))
    m = L.train(limb, mu, L.LearntSettings(clusters=1, A=0.5, B=0.5))
    got = L.solve_limb(m, L.limb_fk(limb, mu)[0, 2])
    assert quat.angle_between(got, mu[0]).max() < 1e-6


def test_training_shot_rebuilt_from_its_constraints_is_near_exact(rig):
    """Default clusters, a small tolerance D (0.01 rad): every limb of a training shot comes back
    within a centimetre (RMS over its joints and frames)."""
    from engine.library import load_library
    shots = load_library(rig=rig)
    s = L.LearntSettings(tolerance=0.01, F=0.0, A=0.0, B=1.0)
    models = L.train_chains(rig, [sh.clip.local_rotations for sh in shots], s)
    for sh in shots[::4]:
        for name, m in models.items():
            q, _ = L.lookup(m, L.constraints(m.limb, *sh.fk))
            d = L.limb_fk(m.limb, q) - L.limb_fk(m.limb, sh.clip.local_rotations[:, m.limb.joints])
            assert np.sqrt((d ** 2).sum(-1).mean()) < 1.0, (sh.name, name)


def test_a_model_answers_anywhere_on_the_pitch(rig):
    """Constraints are relative to the limb root in its parent's frame: moving and
    turning the whole batsman does not change them."""
    from engine.library import load_library
    from engine.skeleton import clip_fk
    sh = load_library(rig=rig)[0]
    limb = L.chain_limb(rig, "right_arm")
    clip = sh.clip.copy()
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(70.0))
    clip.local_rotations[:, 0] = quat.mul(turn, clip.local_rotations[:, 0])
    clip.root_positions = clip.root_positions + [300.0, 5.0, -800.0]
    moved = L.constraints(limb, *clip_fk(sh.skeleton, clip))
    assert np.allclose(moved, L.constraints(limb, *sh.fk), atol=1e-9)


def test_bad_input_is_refused():
    _, limb = planar_arm()
    mu = planar_poses(np.array([40.0]), np.array([-50.0]))
    m = L.train(limb, mu)
    with pytest.raises(ValueError):
        L.solve_limb(m, [np.nan, 0.0, 0.0])
    with pytest.raises(ValueError):
        L.lookup(m, np.zeros((2, 6)))
    with pytest.raises(ValueError):
        L.train(limb, mu, L.LearntSettings(tolerance=-1.0))
    with pytest.raises(ValueError):
        L.train(limb, mu[:, :2])


def test_world_lookup_then_ccd_reaches_a_held_out_pose(rig):
    """learnt+ccd as adapt would wire it: a left-arm model trained without a shot gives
    the start pose for that shot's bat positions (reachable: they are its own); lookup_world
    agrees with constraints + lookup. Plain CCD from that start finishes to 0.1 cm on all but
    a few frames (the square cut's frames 22-23 stick at 2.1 cm in a corner of the limits
    since its pick-up's face was keyed); the adapter's exact solve from the same start, as
    learnt+ccd runs it, reaches every frame."""
    from engine import ccd
    from engine.adapt import AdaptSettings, Adapter
    from engine.learnt_solver import LearntSolver
    from engine.library import load_library
    shots = load_library(rig=rig)
    held = shots[5]
    m = L.train_chains(rig, [s.clip.local_rotations for s in shots if s is not held], names=("left_arm",))["left_arm"]
    g_rot, g_pos = held.fk
    ch = ccd.chain_arrays(rig, "left_arm")
    bat = g_pos[:, ch.effector]
    start = L.lookup_world(m, g_rot[:, ch.parent], g_pos[:, ch.parent], bat[:, None])
    assert np.allclose(start, L.lookup(m, L.constraints(m.limb, g_rot, g_pos))[0], atol=1e-9)
    n = len(ch.joints)
    assert list(m.limb.joints[:n]) == list(ch.joints)
    _, err, _ = ccd.solve(ch, g_rot[:, ch.parent], g_pos[:, ch.parent], start[:, :n], bat)
    assert np.mean(err < 0.1) >= 0.95 and np.median(err) < 0.01
    a = LearntSolver(rig, shots).adapt(Adapter(rig, held), held.hit_point, AdaptSettings(solver="learnt+ccd"),
                                       leave_out=True)
    assert np.linalg.norm(a.global_positions[:, rig.bat_joint] - a.handles, axis=-1).max() < 0.01
