"""The bundled skinned batsman (assets/batsman.glb) and its loader."""
import numpy as np
import pytest

from engine import quat
from engine.skeleton import bind_positions, forward_kinematics, skinning_matrices


@pytest.fixture(scope="module")
def meshes(rig):
    from app.render.mesh import load_glb
    return load_glb(None, rig)


@pytest.fixture(scope="module")
def body(meshes):
    return meshes["Batsman"]


def _colour_mask(mesh, rgb):
    return np.all(np.abs(mesh.colors[:, :3] - np.asarray(rgb)) < 1.5 / 255, axis=1)


def _skin(mesh, M):
    """CPU linear-blend skinning of the rest positions ``(V,3)`` with matrices ``M (J,4,4)``."""
    p = np.concatenate([mesh.positions, np.ones((len(mesh.positions), 1))], 1)
    per = np.einsum("vkab,vb->vka", M[mesh.joints], p)
    return np.einsum("vk,vka->va", mesh.weights, per)[:, :3]


def _pose(rig, rotations):
    sk = rig.skeleton
    local = quat.identity((sk.num_joints,))
    for name, (axis, deg) in rotations.items():
        local[sk.index(name)] = quat.from_axis_angle(np.asarray(axis, float), np.radians(deg))
    g_r, g_p = forward_kinematics(sk.parents, sk.offsets, local)
    return skinning_matrices(g_r, g_p, bind_positions(sk)).astype(float)


def test_skin_joints_match_rig(body, rig):
    assert body.skin_joint_names == rig.skeleton.names
    assert body.joints.shape == body.weights.shape == (len(body.positions), 4)
    assert body.joints.min() >= 0 and body.joints.max() < rig.skeleton.num_joints


def test_inverse_bind_is_translation_by_minus_bind_position(body, rig):
    bind = bind_positions(rig.skeleton)
    ibm = body.inverse_bind
    assert np.allclose(ibm[:, :3, :3], np.eye(3), atol=1e-6)
    assert np.allclose(ibm[:, :3, 3], -bind, atol=1e-4)


def test_weights_sum_to_one_at_most_four(body):
    w = body.weights
    assert np.all(w >= 0)
    assert np.allclose(w.sum(1), 1.0, atol=1e-5)
    assert np.all((w > 0).sum(1) <= 4)


def test_triangle_count_and_normals(body, meshes):
    assert 15_000 <= body.num_triangles <= 80_000
    assert np.allclose(np.linalg.norm(body.normals, axis=1), 1.0, atol=1e-3)
    assert meshes["Ball"].num_triangles > 100


def test_rest_pose_is_the_rig_t_pose(body, rig):
    """Feet on the ground, head near the Head end site, arms spread along +-X."""
    lo, hi = body.positions.min(0), body.positions.max(0)
    assert -1.0 < lo[1] < 1.5
    head_top = bind_positions(rig.skeleton)[rig.skeleton.index("Head"), 1] + rig.skeleton.end_sites[rig.skeleton.index("Head")][1]
    assert abs(hi[1] - head_top) < 8.0
    assert hi[0] > 80 and lo[0] < -80          # fists at the ends of the arms


def test_bat_bound_to_left_hand_only(body, rig):
    from tools.make_batsman import GRIP, WILLOW
    bat = _colour_mask(body, WILLOW) | _colour_mask(body, GRIP)
    assert bat.sum() > 200
    hand = rig.skeleton.index("LeftHand")
    w = body.weights[bat]
    j = body.joints[bat]
    assert np.allclose(np.where(j == hand, w, 0).sum(1), 1.0)


def test_bat_geometry_from_rig(body, rig):
    """86 cm handle-top to toe along rig.bat axis; blade no wider than 10.8 cm; grip on the handle."""
    from tools.make_batsman import GRIP, WILLOW
    b = rig.bat
    bat = _colour_mask(body, WILLOW) | _colour_mask(body, GRIP)
    hand = bind_positions(rig.skeleton)[rig.skeleton.index("LeftHand")]
    grip = hand + np.asarray(b["left_grip"])
    axis, normal = np.asarray(b["axis"], float), np.asarray(b["face_normal"], float)
    across = np.cross(normal, axis)
    rel = body.positions[bat] - grip
    along = rel @ axis
    assert abs(along.min() + b["grip_to_top"]) < 0.5
    assert abs(along.max() - (b["length"] - b["grip_to_top"])) < 0.5
    assert np.ptp(rel @ across) <= b["blade_width"] + 1e-3
    assert np.ptp(rel @ normal) <= b["blade_thickness"] + 1e-3
    # the Bat joint sits on the face centre lifted by the ball radius
    bat_joint = bind_positions(rig.skeleton)[rig.bat_joint]
    face = (rel @ normal).max()
    assert abs((bat_joint - grip) @ normal - face - rig.ball_radius) < 0.2


def test_bat_moves_rigidly_with_the_hand(body, rig):
    from tools.make_batsman import WILLOW
    bat = _colour_mask(body, WILLOW)
    M = _pose(rig, {"LeftArm": ((0, 0, 1), -60), "LeftForeArm": ((0, 1, 0), -90),
                    "LeftForeArmRoll": ((1, 0, 0), 70), "Spine1": ((0, 1, 0), 30)})
    moved = _skin(body, M)[bat]
    rest = body.positions[bat]
    d0 = np.linalg.norm(rest[:50, None] - rest[None, :50], axis=-1)
    d1 = np.linalg.norm(moved[:50, None] - moved[None, :50], axis=-1)
    assert np.allclose(d0, d1, atol=1e-3)


def test_forearm_twist_spread_no_candy_wrapper(body, rig):
    """A 100 degree forearm twist keeps the forearm's cross-section (weights shared by
    ForeArm and ForeArmRoll along the bone), unlike a single-bone binding."""
    from tools.make_batsman import SHIRT
    sleeve = _colour_mask(body, SHIRT) & (body.positions[:, 0] > 50) & (body.positions[:, 0] < 64)
    assert sleeve.sum() > 30
    names = rig.skeleton.names
    j = body.joints[sleeve]
    w = body.weights[sleeve]
    roll = np.where(j == names.index("LeftForeArmRoll"), w, 0).sum(1)
    assert roll.min() < 0.2 and roll.max() > 0.8 and np.any((roll > 0.3) & (roll < 0.7))
    M = _pose(rig, {"LeftForeArmRoll": ((1, 0, 0), 100)})
    moved = _skin(body, M)[sleeve]
    centre = bind_positions(rig.skeleton)[names.index("LeftForeArm")]
    r0 = np.linalg.norm((body.positions[sleeve] - centre)[:, 1:], axis=1)
    r1 = np.linalg.norm((moved - centre)[:, 1:], axis=1)
    assert (r1 / r0).min() > 0.6


def test_elbow_and_knee_blend_smoothly(body, rig):
    """Vertices around the elbow and knee are shared between the two bones."""
    names = rig.skeleton.names
    for a, b in (("LeftArmRoll", "LeftForeArm"), ("RightLeg", "RightUpLeg"), ("Spine1", "Spine2")):
        ia, ib = names.index(a), names.index(b)
        wa = np.where(body.joints == ia, body.weights, 0).sum(1)
        wb = np.where(body.joints == ib, body.weights, 0).sum(1)
        shared = (wa > 0.2) & (wb > 0.2)
        assert shared.sum() > 20, (a, b)


def _oriented_triangles(faces) -> set:
    """Triangles as a set of vertex-index triples, each rotated to start at its
    smallest index: the same surface with the same winding, whatever order a
    library emits the faces in."""
    f = np.asarray(faces).reshape(-1, 3)
    rolled = np.stack([np.roll(f, -k, axis=1) for k in range(3)], axis=1)   # (T, 3, 3)
    first = rolled[np.arange(len(f)), np.argmin(f, axis=1)]
    return set(map(tuple, first.tolist()))


def test_oriented_triangles_ignore_order_but_not_winding():
    faces = np.array([[0, 1, 2], [2, 3, 0]])
    assert _oriented_triangles(faces[::-1]) == _oriented_triangles(np.roll(faces, 1, axis=1))
    assert _oriented_triangles(faces[:, ::-1]) != _oriented_triangles(faces)


def test_committed_glb_matches_the_script(body, meshes, rig):
    """assets/batsman.glb is what tools/make_batsman.py builds: the same vertices,
    weights and oriented triangles (as sets: trimesh 5 emits faces in another order)."""
    from tools.make_batsman import build
    model = build(rig)
    assert np.allclose(model["body"].vertices, body.positions, atol=1e-4)
    assert np.allclose(model["weights"], body.weights, atol=1e-6)
    for key, name in (("body", "Batsman"), ("shadow", "BatsmanShadow"),
                      ("lod1", "BatsmanLod1"), ("lod2", "BatsmanLod2")):
        built, committed = model[key], meshes[name]
        assert np.allclose(built.vertices, committed.positions, atol=1e-4), name
        assert len(built.faces) == committed.num_triangles, name
        assert _oriented_triangles(built.faces) == _oriented_triangles(committed.indices), name


def test_unknown_skin_joint_is_a_clear_error(tmp_path, rig):
    import pygltflib
    from app.render.mesh import default_glb_path, load_glb
    g = pygltflib.GLTF2().load(str(default_glb_path()))
    g.nodes[3].name = "NotAJoint"
    path = tmp_path / "bad.glb"
    g.save_binary(str(path))
    with pytest.raises(ValueError, match="NotAJoint"):
        load_glb(path, rig)


@pytest.mark.parametrize("name, share", [("BatsmanShadow", 0.5), ("BatsmanLod1", 0.55), ("BatsmanLod2", 0.35)])
def test_coarse_copies_keep_skin_and_extent(body, meshes, rig, name, share):
    """``BatsmanShadow`` (the shadow caster), ``BatsmanLod1`` and ``BatsmanLod2`` (drawn
    when he is smaller on screen): the same skin, a fraction of the triangles, the same extent."""
    shadow = meshes[name]
    assert shadow.skin_joint_names == rig.skeleton.names
    assert shadow.num_triangles < body.num_triangles * share
    assert np.allclose(shadow.weights.sum(1), 1.0, atol=1e-5)
    assert np.allclose(shadow.positions.min(0), body.positions.min(0), atol=2.0)
    assert np.allclose(shadow.positions.max(0), body.positions.max(0), atol=2.0)
    # posed, it stays inside the posed body's box (the coarse rings lie on the fine surface)
    M = _pose(rig, {"LeftArm": ((0, 0, 1), -60), "RightUpLeg": ((1, 0, 0), -40)})
    a, b = _skin(shadow, M), _skin(body, M)
    assert np.all(a.min(0) > b.min(0) - 2.0) and np.all(a.max(0) < b.max(0) + 2.0)
