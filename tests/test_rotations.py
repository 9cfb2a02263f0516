"""media.rotations: signcast's conventions (scalar-first quaternions, Shoemake Euler orders, w >= 0)
on top of scipy.spatial.transform, checked against definitions written out here."""
import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from comparisons.params.bba import ORDER_NAMES
from media import rotations

AXES = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
ALL_ORDERS = tuple(a + b + c + frame for a, b, c in itertools.product("XYZ", repeat=3) if a != b and b != c
                   for frame in "sr")


def random_quaternions(rng, n):
    return rotations.canonical(rotations.from_axis_angle(rng.normal(size=(n, 3)), rng.uniform(0, np.pi, n)))


def same_rotation(a, b):
    """Largest |1 - |<a, b>||: 0 when a = +-b, unit quaternions (..., 4)."""
    return float(np.max(np.abs(1.0 - np.abs(np.sum(a * b, axis=-1)))))


def test_quaternions_are_scalar_first_and_rotate_column_vectors():
    q = rotations.from_axis_angle([0, 0, 1], np.pi / 2)
    np.testing.assert_allclose(q, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-15)
    np.testing.assert_allclose(rotations.to_matrix(q) @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)
    np.testing.assert_allclose(rotations.rotate(q, [1.0, 0, 0]), [0, 1.0, 0], atol=1e-15)
    np.testing.assert_allclose(rotations.as_rotation(q).as_quat(), [[0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)]])


def test_from_axis_angle_keeps_the_sign_of_the_half_angle():
    angle = np.array([-4.0, -1.0, 0.0, 1.0, 4.0])                  # beyond pi: w = cos(angle / 2) < 0
    q = rotations.from_axis_angle(np.tile([0.0, 2.0, 0.0], (5, 1)), angle)
    np.testing.assert_allclose(q, np.stack([np.cos(angle / 2), 0 * angle, np.sin(angle / 2), 0 * angle], axis=1),
                               atol=1e-15)


def test_bba_rotation_orders_are_the_24_shoemake_orders():
    assert len(ORDER_NAMES) == 24 and set(ORDER_NAMES) == set(ALL_ORDERS)


@pytest.mark.parametrize("order", ALL_ORDERS)
def test_from_euler_applies_the_first_angle_first(order):
    """Static: R(a3) R(a2) R(a1) about the parent's axes; rotating: R(a1) R(a2) R(a3) about the bone's."""
    angles = np.random.default_rng(1).uniform(-3, 3, (20, 3))
    q1, q2, q3 = (rotations.from_axis_angle(np.tile(AXES[order[k]], (20, 1)), angles[:, k]) for k in range(3))
    expected = rotations.multiply(rotations.multiply(q1, q2), q3) if order[3] == "r" \
        else rotations.multiply(rotations.multiply(q3, q2), q1)
    q = rotations.from_euler(angles, order)
    assert np.all(q[:, 0] >= 0)
    np.testing.assert_allclose(q, rotations.canonical(expected), atol=1e-14)


@pytest.mark.parametrize("order", ALL_ORDERS)
def test_euler_round_trip_is_exact_in_every_order(order):
    rng = np.random.default_rng(2)
    angles = rng.uniform(-1, 1, (200, 3)) * [3.1, 1.5, 3.1]
    if order[0] == order[2]:
        angles[:, 1] = np.abs(angles[:, 1]) + 0.01
    np.testing.assert_allclose(rotations.to_euler(rotations.from_euler(angles, order), order), angles, atol=1e-12)
    q = random_quaternions(rng, 200)
    angles = rotations.to_euler(q, order)
    middle = (0.0, np.pi) if order[0] == order[2] else (-np.pi / 2, np.pi / 2)
    assert np.all(np.abs(angles[:, [0, 2]]) <= np.pi) and np.all((angles[:, 1] >= middle[0]) & (angles[:, 1] <= middle[1]))
    np.testing.assert_allclose(rotations.from_euler(angles, order), q, atol=1e-14)


@pytest.mark.parametrize("order", ALL_ORDERS)
def test_euler_angles_in_gimbal_lock_still_give_the_same_rotation(order):
    limits = (0.0, np.pi) if order[0] == order[2] else (-np.pi / 2, np.pi / 2)
    rng = np.random.default_rng(4)
    angles = rng.uniform(-3, 3, (2, 20, 3))
    for k, limit in enumerate(limits):
        angles[k, :, 1] = limit
    angles[:, 0] = 0.0                                               # the rest pose included
    q = rotations.from_euler(angles, order)
    back = rotations.to_euler(q, order)
    assert same_rotation(rotations.from_euler(back, order), q) < 1e-14
    np.testing.assert_allclose(back[..., 1], angles[..., 1], atol=1e-7)


def test_unknown_euler_orders_are_rejected():
    for order in ("XXYs", "XYZ", "XYZq", "xyzs", "XYYr"):
        with pytest.raises(ValueError, match="Euler order"):
            rotations.from_euler(np.zeros(3), order)


def test_matrix_round_trip_in_every_branch_with_w_non_negative():
    rng = np.random.default_rng(5)
    q = random_quaternions(rng, 100)
    turns = np.stack([rotations.from_axis_angle(AXES[a], 3.0) for a in "XYZ"])   # trace < 0, each diagonal largest
    q = np.concatenate([q, turns, -turns, [rotations.IDENTITY]])
    m = rotations.to_matrix(q)
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", m, m), np.broadcast_to(np.eye(3), m.shape), atol=1e-14)
    back = rotations.from_matrix(m)
    assert np.all(back[:, 0] >= 0)
    np.testing.assert_allclose(back, rotations.canonical(q), atol=1e-14)
    assert rotations.from_matrix(m[:104].reshape(13, 8, 3, 3)).shape == (13, 8, 4)


def test_rotate_broadcasts_one_rotation_over_many_vectors():
    rng = np.random.default_rng(6)
    q = random_quaternions(rng, 1)[0]
    v = rng.normal(size=(7, 5, 3))
    np.testing.assert_allclose(rotations.rotate(q, v), v @ rotations.to_matrix(q).T, atol=1e-14)
    q_many = random_quaternions(rng, 7)[:, None]
    np.testing.assert_allclose(rotations.rotate(q_many, v), np.einsum("tij,tbj->tbi", rotations.to_matrix(q_many[:, 0]), v),
                               atol=1e-14)


def test_rotate_is_scipys_apply_within_rounding():
    """media.rotations.rotate (compiled, media/rotation_loops.py) against scipy's from_quat(q).apply(v): non-unit
    quaternions over six decades, the axes and the identity, broadcast and transposed inputs, a zero quaternion
    (scipy's error). Stated tolerance: 1e-12 relative to |v| (the rotated vector's length is |v|)."""
    rng = np.random.default_rng(12)
    q = rng.normal(size=(20000, 4)) * 10.0 ** rng.uniform(-3, 3, size=(20000, 1))
    v = rng.normal(size=(20000, 3)) * 10.0 ** rng.uniform(-6, 3, size=(20000, 1))
    q[500:800] = np.eye(4)[rng.integers(0, 4, 300)] * rng.choice([-1.0, 1.0], (300, 1))
    for qq, vv in ((q, v), (q[:1], v[:1]), (q[:3000], np.asfortranarray(v[:3000])), (q[7], v[:50])):
        expected = Rotation.from_quat(np.broadcast_to(qq, np.broadcast_shapes(qq.shape, vv.shape[:-1] + (4,)))
                                      .reshape(-1, 4)[:, [1, 2, 3, 0]]).apply(vv.reshape(-1, 3))
        got = rotations.rotate(qq, vv).reshape(-1, 3)
        scale = np.linalg.norm(vv.reshape(-1, 3), axis=1, keepdims=True)
        assert np.all(np.abs(got - expected) <= 1e-12 * scale)
    with pytest.raises(ValueError, match="zero norm"):
        rotations.rotate(np.zeros((2, 4)), v[:2])


def test_from_axis_angle_is_scipys_from_rotvec_within_rounding():
    """media.rotations.from_axis_angle (compiled) against scipy's from_rotvec of the unit axis times the angle:
    axes over ten decades, zero axes (the identity), angles of +-0 and around small angles, broadcast shapes;
    within 1e-15 per component (sign included: both give (cos(a / 2), sin(a / 2) axis))."""
    def reference(axis, angle):
        axis = np.asarray(axis, dtype=np.float64)
        unit = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-300)
        rotvec = unit * np.asarray(angle, dtype=np.float64)[..., None]
        return Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_quat().reshape(rotvec.shape[:-1] + (4,))[..., [3, 0, 1, 2]]

    rng = np.random.default_rng(14)
    axis = rng.normal(size=(20000, 3)) * 10.0 ** rng.uniform(-5, 5, size=(20000, 1))
    angle = rng.uniform(-4, 4, 20000) * 10.0 ** rng.uniform(-6, 0, 20000)
    axis[:100], angle[100:200], angle[200:300] = 0.0, 0.0, -0.0
    angle[300:400] = 1e-4 * rng.choice([1 - 2e-16, 1.0, 1 + 2e-16], 100)
    for a, b in ((axis, angle), (axis[0], angle[:50]), (axis[:6, None], angle[None, :7]), (axis[5], 0.3)):
        np.testing.assert_allclose(rotations.from_axis_angle(a, b), reference(a, b), rtol=0, atol=1e-15)


def test_compiled_multiply_is_the_numpy_product():
    rng = np.random.default_rng(15)
    q = rng.normal(size=(3000, 4))
    for a, b in ((q, q[::-1]), (q[0], q), (q[:40, None], q[None, :30]), (q[5], q[6])):
        expected = rotations._multiply_numpy(a, b)
        got = rotations.multiply(a, b)
        assert got.shape == expected.shape
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-14)


def test_cross_is_numpys():
    rng = np.random.default_rng(13)
    for a_shape, b_shape in (((40, 3), (40, 3)), ((3,), (40, 3)), ((5, 40, 3), (40, 3)), ((3,), (3,))):
        a, b = rng.normal(size=a_shape), rng.normal(size=b_shape)
        np.testing.assert_allclose(rotations.cross(a, b), np.cross(a, b), rtol=0, atol=1e-15)


@pytest.mark.parametrize("order", ALL_ORDERS)
def test_compiled_euler_conversions_are_scipys_within_rounding(order):
    """from_euler_table (the BBA decoder's, with held values) and euler_split (the BBA encoder's, with held bones)
    against scipy's from_euler / as_euler in every order: quaternions within 1e-12 per component (w >= 0),
    angles within 1e-9 rad away from gimbal lock and the same rotation (1e-12) in it."""
    rng = np.random.default_rng(16)
    table = np.round(rng.uniform(-3.2, 3.2, size=(40, 18)) / 1e-3)          # angle units of 1e-3 rad
    table[10:20] = table[9]                                                 # held frames
    table[:, 3:6] = 0.0
    got = rotations.from_euler_table(table, 6, 1e-3, order)
    expected = rotations.from_euler(table.reshape(40, 6, 3) * 1e-3, order)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    q = random_quaternions(rng, 300).reshape(30, 10, 4)
    q[5:9] = q[4]                                                           # held bones
    locked = rotations.from_euler(np.array([[0.3, np.pi / 2 if order[0] != order[2] else 0.0, -0.2]]), order)
    q[29, 0] = locked[0]
    angles = rotations.euler_split(q, order)
    reference = rotations.to_euler(q, order)
    np.testing.assert_allclose(angles[:29], reference[:29], rtol=0, atol=1e-9)
    assert same_rotation(rotations.from_euler(angles, order), q) < 1e-12
    with pytest.raises(ValueError, match="zero norm"):
        rotations.euler_split(np.zeros((1, 4)), order)


def test_compiled_slerp_rows_are_slerp():
    rng = np.random.default_rng(17)
    q0, q1 = random_quaternions(rng, 500), random_quaternions(rng, 500)
    q1[:50] = q0[:50]                                                       # sin(alpha) ~ 0
    q1[50:100] = -q1[50:100]
    t = rng.uniform(0, 1, 500)
    np.testing.assert_allclose(rotations.slerp_rows(q0, q1, t), rotations.slerp(q0, q1, t), rtol=0, atol=1e-12)


def test_axis_angle_round_trip_with_angles_in_zero_to_pi():
    rng = np.random.default_rng(7)
    axis = rng.normal(size=(50, 3))
    angle = rng.uniform(-np.pi, np.pi, 50)
    back_axis, back_angle = rotations.to_axis_angle(rotations.from_axis_angle(axis, angle))
    unit = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    np.testing.assert_allclose(back_angle, np.abs(angle), atol=1e-14)
    np.testing.assert_allclose(back_axis, np.sign(angle)[:, None] * unit, atol=1e-13)
    identity_axis, identity_angle = rotations.to_axis_angle(rotations.IDENTITY)
    assert identity_angle == 0.0 and np.array_equal(identity_axis, [1.0, 0, 0])


def test_multiply_and_angle_between_agree_with_scipy():
    rng = np.random.default_rng(8)
    a, b = random_quaternions(rng, 40), random_quaternions(rng, 40)
    composed = rotations.as_rotation(a) * rotations.as_rotation(b)
    np.testing.assert_allclose(rotations.multiply(a, b), rotations.as_quaternion(composed, (40,)), atol=1e-15)
    expected = (rotations.as_rotation(a).inv() * rotations.as_rotation(b)).magnitude()
    np.testing.assert_allclose(rotations.angle_between(a, b), expected, atol=1e-7)   # arccos near 1: ~1e-8


def test_slerp_agrees_with_scipy_slerp_and_takes_the_shortest_arc():
    rng = np.random.default_rng(9)
    q0, q1 = random_quaternions(rng, 2)
    t = np.linspace(0, 1, 11)
    expected = rotations.as_quaternion(Slerp([0.0, 1.0], rotations.as_rotation(np.stack([q0, q1])))(t), (11,))
    for end in (q1, -q1):                                            # -q1 is the same rotation
        q = rotations.slerp(np.broadcast_to(q0, (11, 4)), np.broadcast_to(end, (11, 4)), t)
        assert same_rotation(q, expected) < 1e-14
        np.testing.assert_allclose(q[0], q0, atol=1e-15)
    near = rotations.slerp(q0, rotations.normalize(q0 + 1e-12), 0.5)  # sin(alpha) ~ 0: normalised lerp
    np.testing.assert_allclose(near, q0, atol=1e-12)


def test_scipy_sequence_names():
    assert rotations.scipy_sequence("XYZs") == "xyz" and rotations.scipy_sequence("ZYXr") == "ZYX"
    assert Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).approx_equal(
        Rotation.from_euler("z", 0.3) * Rotation.from_euler("y", 0.2) * Rotation.from_euler("x", 0.1))


def test_atan2_series_is_numpys_within_an_ulp():
    """The Euler split's branch-free atan2 (media/rotation_loops.atan2_series) against NumPy's arctan2: within 5e-16
    rad on 1e5 pairs over ten decades of scale, and exact on the axes and signed zeros (+-pi on the negative x
    axis, as C's atan2)."""
    from numba import njit

    from media.rotation_loops import atan2_series

    @njit
    def loop(y, x):
        out = np.empty(len(y))
        for r in range(len(y)):
            out[r] = atan2_series(y[r], x[r])
        return out

    rng = np.random.default_rng(18)
    y = rng.normal(size=100_000) * 10.0 ** rng.integers(-5, 5, 100_000)
    x = rng.normal(size=100_000) * 10.0 ** rng.integers(-5, 5, 100_000)
    np.testing.assert_allclose(loop(y, x), np.arctan2(y, x), rtol=0, atol=5e-16)
    edges_y = np.array([0.0, 0.0, -0.0, -0.0, 1.0, -1.0, 0.0, 0.0, 1.0, 1.0, -1.0, -1.0, 1e-300, np.sqrt(2) - 1, 1.0, 5e-324])
    edges_x = np.array([1.0, -1.0, 1.0, -1.0, 0.0, 0.0, 0.0, -0.0, 1.0, -1.0, 1.0, -1.0, 1.0, 1.0, np.sqrt(2) - 1, 1.0])
    got, expected = loop(edges_y, edges_x), np.arctan2(edges_y, edges_x)
    np.testing.assert_allclose(got, expected, rtol=0, atol=5e-16)
    assert np.array_equal(np.signbit(got), np.signbit(expected))
    assert got[1] == np.pi and got[3] == -np.pi and got[4] == np.pi / 2 and got[5] == -np.pi / 2
