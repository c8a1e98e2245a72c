"""Quaternion identities and conversions."""
import numpy as np
import pytest

from engine import quat

rng = np.random.default_rng(7)
Q = quat.normalize(rng.normal(size=(500, 4)))
R = quat.normalize(rng.normal(size=(500, 4)))
V = rng.normal(size=(500, 3))


def same_rotation(a, b, tol=1e-9):
    return np.all(np.abs(np.abs(np.sum(a * b, axis=-1)) - 1) < tol)


def test_identity_and_inverse():
    assert np.allclose(quat.mul(Q, quat.inverse(Q)), quat.identity((500,)), atol=1e-12)
    assert np.allclose(quat.mul(quat.identity(), Q), Q)
    assert np.allclose(quat.rotate(quat.identity(), V), V)


def test_mul_is_composition_of_rotations():
    lhs = quat.rotate(quat.mul(Q, R), V)
    rhs = quat.rotate(Q, quat.rotate(R, V))
    assert np.allclose(lhs, rhs, atol=1e-12)


def test_rotation_preserves_length_and_matches_matrix():
    assert np.allclose(np.linalg.norm(quat.rotate(Q, V), axis=-1), np.linalg.norm(V, axis=-1))
    M = quat.to_matrix(Q)
    assert np.allclose(np.einsum("nij,nj->ni", M, V), quat.rotate(Q, V), atol=1e-12)
    assert np.allclose(np.linalg.det(M), 1.0)
    assert same_rotation(quat.from_matrix(M), Q)


@pytest.mark.parametrize("order", ["ZYX", "XYZ", "YXZ", "ZXY", "XZY", "YZX"])
def test_euler_round_trip_every_bvh_order(order):
    e = rng.uniform(-170, 170, size=(300, 3))
    e[:, 1] = rng.uniform(-89, 89, size=300)
    q = quat.from_euler(e, order)
    assert np.allclose(quat.to_euler(q, order), e, atol=1e-9)
    # to_euler of any rotation gives angles that rebuild the same rotation
    assert same_rotation(quat.from_euler(quat.to_euler(Q, order), order), Q)


def test_euler_zyx_is_rz_ry_rx_for_column_vectors():
    z, y, x = 30.0, -20.0, 50.0
    def rot(axis, deg):
        return quat.to_matrix(quat.from_axis_angle(np.eye(3)[axis], np.radians(deg)))
    expected = rot(2, z) @ rot(1, y) @ rot(0, x)
    assert np.allclose(quat.to_matrix(quat.from_euler([z, y, x], "ZYX")), expected)


def test_euler_gimbal_lock_is_finite_and_exact():
    e = np.array([[40.0, 90.0, 10.0], [-20.0, -90.0, 70.0]])
    q = quat.from_euler(e, "ZYX")
    back = quat.to_euler(q, "ZYX")
    assert np.all(np.isfinite(back))
    assert same_rotation(quat.from_euler(back, "ZYX"), q)


def test_slerp_endpoints_midpoint_and_shortest_arc():
    assert same_rotation(quat.slerp(Q, R, 0.0), Q)
    assert same_rotation(quat.slerp(Q, R, 1.0), R)
    mid = quat.slerp(Q, R, 0.5)
    assert np.allclose(quat.angle_between(Q, mid), quat.angle_between(mid, R), atol=1e-6)
    # -R is the same rotation: slerp must take the same (short) path
    assert same_rotation(quat.slerp(Q, -R, 0.5), mid)


def test_between_maps_u_onto_v_including_opposite_and_zero():
    U = rng.normal(size=(200, 3))
    W = rng.normal(size=(200, 3))
    W[0] = -U[0]  # opposite
    got = quat.rotate(quat.between(U, W), U)
    unit = lambda a: a / np.linalg.norm(a, axis=-1, keepdims=True)
    assert np.allclose(unit(got), unit(W), atol=1e-9)
    assert np.allclose(quat.between(np.zeros(3), np.ones(3)), quat.identity())


def test_exp_log_inverse():
    r = quat.log(Q)
    assert np.all(np.linalg.norm(r, axis=-1) <= np.pi + 1e-9)
    assert same_rotation(quat.exp(r), Q)
    assert np.allclose(quat.exp(np.zeros(3)), quat.identity())
    assert np.allclose(quat.log(quat.exp(r)), r, atol=1e-9)


def test_make_continuous_removes_sign_flips():
    q = quat.slerp(Q[0], Q[1], np.linspace(0, 1, 50))
    flipped = q * np.where(rng.random(50) < 0.5, -1, 1)[:, None]
    cont = quat.make_continuous(flipped)
    assert np.all(np.sum(cont[1:] * cont[:-1], axis=-1) > 0)
    assert same_rotation(cont, q)
