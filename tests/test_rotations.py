"""Worked answers for splicer.model.rotations: each function on hand-computed quaternions, and
against scipy's Rotation on seeded random inputs."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from splicer.model.rotations import (cross3, euler_channels_deg, euler_from_quat, quat_angle, quat_angle_deg, quat_between,
                               quat_conj, quat_from_euler, quat_from_matrix, quat_hemisphere, quat_median, quat_mul,
                               quat_normalize, quat_rotate, quat_slerp, quat_to_matrix, yaw_quat_deg)

S45 = np.sqrt(0.5)  # cos 45 = sin 45
I = np.array([1.0, 0, 0, 0])


def _random(rng, shape):
    return quat_normalize(rng.standard_normal(shape + (4,)))


def _same_rotation(a, b, atol=1e-12):
    a, b = np.asarray(a), np.asarray(b)
    sign = np.where(np.sum(a * b, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    np.testing.assert_allclose(a, sign * b, atol=atol)


def test_quat_from_euler_single_axes_by_hand():
    # half angles: 90 deg about X -> (cos 45, sin 45, 0, 0); 180 about Y -> (0, 0, 1, 0);
    # -60 about Z -> (cos -30, 0, 0, sin -30) = (0.866025, 0, 0, -0.5)
    np.testing.assert_allclose(quat_from_euler([90.0, 0, 0], "XYZ"), [S45, S45, 0, 0], atol=1e-15)
    np.testing.assert_allclose(quat_from_euler([0.0, 180.0, 0], "XYZ"), [0, 0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(quat_from_euler([0.0, 0, -60.0], "xyz"), [np.sqrt(3) / 2, 0, 0, -0.5], atol=1e-15)


def test_quat_from_euler_is_the_intrinsic_product_in_file_order():
    # "ZXY" with (90, 90, 0): Rz(90) @ Rx(90) = qz * qx = (c, 0, 0, s) * (c, s, 0, 0)
    # = (c^2, c s, s c, s^2) = (0.5, 0.5, 0.5, 0.5)
    np.testing.assert_allclose(quat_from_euler([90.0, 90.0, 0.0], "ZXY"), [0.5, 0.5, 0.5, 0.5], atol=1e-15)
    # the other order, X then Z: qx * qz = (c^2, c s, -s c, s^2)
    np.testing.assert_allclose(quat_from_euler([90.0, 0.0, 90.0], "XYZ"), [0.5, 0.5, -0.5, 0.5], atol=1e-15)


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "YZX", "ZYX", "XZY", "YXZ"])
def test_euler_round_trip_and_scipy(order, rng):
    e = rng.uniform(-170, 170, (50, 3))
    e[:, 1] = rng.uniform(-80, 80, 50)  # away from gimbal lock
    q = quat_from_euler(e, order)
    _same_rotation(q, Rotation.from_euler(order, e, degrees=True).as_quat(scalar_first=True))
    np.testing.assert_allclose(euler_from_quat(q, order), e, atol=1e-9)
    assert euler_from_quat(np.zeros((0, 4)), order).shape == (0, 3)
    assert euler_from_quat(q.reshape(5, 10, 4), order).shape == (5, 10, 3)


@pytest.mark.parametrize("order", ["X", "ZY", "ZXY", "XYZ", "YZX", "ZYX", "XZY", "YXZ", "XYX", "ZZZ"])
def test_quat_from_euler_equals_the_hamilton_product_of_its_axes_bit_for_bit(order, rng):
    """The written-out products (no zero terms) against the slow reference: quat_mul of the
    one-axis quaternions in file order, for any shape and for the values 0, 180 and -90."""
    e = rng.uniform(-400, 400, (600, len(order)))
    e[::7], e[::11, 0], e[::13] = 0.0, 180.0, -90.0
    half = 0.5 * np.radians(e)
    ref = None
    for k, axis in enumerate(order):
        qa = np.zeros((len(e), 4))
        qa[:, 0] = np.cos(half[:, k])
        qa[:, 1 + "XYZ".index(axis)] = np.sin(half[:, k])
        ref = qa if ref is None else quat_mul(ref, qa)
    np.testing.assert_array_equal(quat_from_euler(e, order), ref)
    np.testing.assert_array_equal(quat_from_euler(e.reshape(20, 30, -1), order), ref.reshape(20, 30, 4))
    np.testing.assert_array_equal(quat_from_euler(np.zeros((3, 0)), ""), [[1.0, 0, 0, 0]] * 3)


def test_quat_from_euler_refuses_a_wrong_order_length():
    with pytest.raises(ValueError, match="'ZX' does not match 3 angles"):
        quat_from_euler([1.0, 2.0, 3.0], "ZX")


def test_hamilton_products_by_hand():
    i, j, k = np.eye(4)[1], np.eye(4)[2], np.eye(4)[3]
    np.testing.assert_array_equal(quat_mul(i, j), k)       # ij = k
    np.testing.assert_array_equal(quat_mul(j, i), -k)      # ji = -k
    np.testing.assert_array_equal(quat_mul(j, k), i)       # jk = i
    np.testing.assert_array_equal(quat_mul(k, i), j)       # ki = j
    np.testing.assert_array_equal(quat_mul(i, i), -I)      # i^2 = -1
    # (1, 2, 3, 4)(5, 6, 7, 8) = (5 - 12 - 21 - 32, 6 + 10 + 24 - 28, 7 - 16 + 15 + 24, 8 + 14 - 18 + 20)
    np.testing.assert_array_equal(quat_mul([1.0, 2, 3, 4], [5.0, 6, 7, 8]), [-60, 12, 30, 24])


def test_quat_mul_applies_the_right_factor_first(rng):
    a, b = _random(rng, (20,)), _random(rng, (20,))
    ref = (Rotation.from_quat(a, scalar_first=True) * Rotation.from_quat(b, scalar_first=True)).as_quat(scalar_first=True)
    _same_rotation(quat_mul(a, b), ref)
    # broadcasting: one quaternion times many
    assert quat_mul(a[0], b).shape == (20, 4)


def test_conjugate_inverts():
    np.testing.assert_array_equal(quat_conj([1.0, 2, 3, 4]), [1, -2, -3, -4])
    q = quat_from_euler([10.0, 20, 30], "ZXY")
    np.testing.assert_allclose(quat_mul(q, quat_conj(q)), I, atol=1e-15)


def test_rotate_vectors_by_hand_and_scipy(rng):
    z90 = np.array([S45, 0, 0, S45])
    np.testing.assert_allclose(quat_rotate(z90, [1.0, 0, 0]), [0, 1, 0], atol=1e-15)   # x -> y
    np.testing.assert_allclose(quat_rotate(z90, [0.0, 1, 0]), [-1, 0, 0], atol=1e-15)  # y -> -x
    np.testing.assert_allclose(quat_rotate(z90, [0.0, 0, 2]), [0, 0, 2], atol=1e-15)   # the axis stays
    q, v = _random(rng, (30,)), rng.standard_normal((30, 3))
    np.testing.assert_allclose(quat_rotate(q, v), Rotation.from_quat(q, scalar_first=True).apply(v), atol=1e-12)


def test_matrices_by_hand_and_scipy(rng):
    z90 = np.array([S45, 0, 0, S45])
    np.testing.assert_allclose(quat_to_matrix(z90), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    x180 = np.array([0.0, 1, 0, 0])
    np.testing.assert_allclose(quat_to_matrix(x180), np.diag([1.0, -1, -1]), atol=1e-15)
    q = _random(rng, (4, 5))
    m = quat_to_matrix(q)
    np.testing.assert_allclose(m, Rotation.from_quat(q.reshape(-1, 4), scalar_first=True).as_matrix().reshape(4, 5, 3, 3),
                               atol=1e-12)
    _same_rotation(quat_from_matrix(m), q)
    np.testing.assert_allclose(quat_from_matrix(np.diag([1.0, -1, -1])), x180, atol=1e-15)
    assert quat_from_matrix(np.zeros((0, 3, 3))).shape == (0, 4)


def test_normalize():
    np.testing.assert_allclose(quat_normalize([0.0, 3, 0, 4]), [0, 0.6, 0, 0.8], atol=1e-15)
    np.testing.assert_allclose(quat_normalize([[2.0, 0, 0, 0], [0, 0, -5, 0]]), [[1, 0, 0, 0], [0, 0, -1, 0]])


def test_hemisphere_flips_runs_and_respects_the_axis():
    a = quat_from_euler([10.0, 0, 0], "XYZ")
    b = quat_from_euler([20.0, 0, 0], "XYZ")
    seq = np.stack([a, -b, -a, a])  # dots: -, +, - -> flips -1, -1, +1 (cumulative)
    out = quat_hemisphere(seq)
    np.testing.assert_allclose(out, np.stack([a, b, a, a]), atol=1e-15)
    np.testing.assert_array_equal(seq[1], -b)  # input untouched
    # time along axis 1 of a (K, T, 4) array
    out1 = quat_hemisphere(seq[None], axis=1)
    np.testing.assert_allclose(out1[0], out, atol=1e-15)
    np.testing.assert_array_equal(quat_hemisphere(seq[:1]), seq[:1])


def test_slerp_by_hand():
    z90 = np.array([S45, 0, 0, S45])
    # halfway between identity and 90 deg about Z: 45 deg about Z
    np.testing.assert_allclose(quat_slerp(I, z90, 0.5), [np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)], atol=1e-15)
    np.testing.assert_allclose(quat_slerp(I, z90, [0.0, 1.0]), [I, z90], atol=1e-15)
    # -z90 is the same rotation: the short arc gives the same halfway point
    _same_rotation(quat_slerp(I, -z90, 0.5), [np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)])
    # the angle grows linearly in t: a third of 90 is 30
    assert quat_angle_deg(quat_slerp(I, z90, 1 / 3), I) == pytest.approx(30.0, abs=1e-12)


def test_slerp_of_nearly_equal_rotations_is_a_normalised_lerp():
    # 0.01 degrees apart (dot > 0.9995): t = 0.25 lands a quarter of the way
    a = quat_from_euler([0.0, 0, 40.0], "XYZ")
    b = quat_from_euler([0.0, 0, 40.01], "XYZ")
    mid = quat_slerp(a, b, 0.25)
    _same_rotation(mid, quat_from_euler([0.0, 0, 40.0025], "XYZ"), atol=1e-9)
    assert np.linalg.norm(mid) == pytest.approx(1.0, abs=1e-15)


def test_geodesic_angle_by_hand():
    x = quat_from_euler([[0.0, 0, 0], [90.0, 0, 0], [180.0, 0, 0], [-120.0, 0, 0]], "XYZ")
    np.testing.assert_allclose(quat_angle_deg(x, I), [0, 90, 180, 120], atol=1e-12)
    assert quat_angle_deg(x[1], -x[1]) == 0.0  # q and -q are the same rotation
    # tiny angles keep their digits (2 acos(dot) would give ~1e-6 here)
    tiny = quat_from_euler([1e-7, 0, 0], "XYZ")
    assert quat_angle_deg(tiny, I) == pytest.approx(1e-7, rel=1e-6)
    assert quat_angle is quat_angle_deg


def test_median_of_three_rotations_about_one_axis():
    # 10, 20 and 80 deg about X: component-wise medians cos 10 and sin 10 -> exactly 20 deg;
    # the 80 deg outlier does not pull it (a mean would give 36.7)
    q = quat_from_euler([[10.0, 0, 0], [20.0, 0, 0], [80.0, 0, 0]], "XYZ")
    _same_rotation(quat_median(q), quat_from_euler([20.0, 0, 0], "XYZ"))
    q[1] *= -1  # a sign flip of one member changes nothing
    _same_rotation(quat_median(q), quat_from_euler([20.0, 0, 0], "XYZ"))
    # along axis 1
    _same_rotation(quat_median(q[None], axis=1)[0], quat_from_euler([20.0, 0, 0], "XYZ"))


def test_between_by_hand():
    # x onto y: 90 deg about z; any lengths
    np.testing.assert_allclose(quat_between([2.0, 0, 0], [0.0, 3, 0]), [S45, 0, 0, S45], atol=1e-15)
    # opposite: a half turn about x cross y-axis-alt: u = x, alt = (0, 1, 0), perp = x cross y = z
    np.testing.assert_allclose(quat_between([1.0, 0, 0], [-1.0, 0, 0]), [0, 0, 0, 1], atol=1e-15)
    # u = z: |u_x| < 0.9, alt = x, perp = z cross x = y
    np.testing.assert_allclose(quat_between([0.0, 0, 1], [0.0, 0, -1]), [0, 0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(quat_between([0.0, 1, 0], [0.0, 1, 0]), I, atol=1e-15)


def test_between_maps_u_onto_v(rng):
    u, v = rng.standard_normal((40, 3)), rng.standard_normal((40, 3))
    q = quat_between(u, v)
    got = quat_rotate(q, u / np.linalg.norm(u, axis=-1, keepdims=True))
    np.testing.assert_allclose(got, v / np.linalg.norm(v, axis=-1, keepdims=True), atol=1e-12)


def test_yaw_takes_degrees():
    np.testing.assert_allclose(yaw_quat_deg(90.0, 1), [S45, 0, S45, 0], atol=1e-15)
    np.testing.assert_allclose(yaw_quat_deg([180.0, 0.0], 2), [[0, 0, 0, 1], [1, 0, 0, 0]], atol=1e-15)


def test_euler_channels_unwrap_and_follow_a_reference():
    # 170 -> -170 about X is a 20-degree step: unwrapped, 170 -> 190
    q = quat_from_euler([[170.0, 0, 0], [-170.0, 0, 0], [-150.0, 0, 0]], "XYZ")
    np.testing.assert_allclose(euler_channels_deg(q, "XYZ"), [[170, 0, 0], [190, 0, 0], [210, 0, 0]], atol=1e-9)
    # each angle within 180 of its reference: 170 near 530 -> 530; 190 near -100 -> -170
    near = np.array([[530.0, 0, 0], [-100.0, 0, 0], [210.0, 360, 0]])
    np.testing.assert_allclose(euler_channels_deg(q, "XYZ", near_deg=near),
                               [[530, 0, 0], [-170, 0, 0], [210, 360, 0]], atol=1e-9)
    # input need not be normalised
    np.testing.assert_allclose(euler_channels_deg(3 * q, "XYZ"), euler_channels_deg(q, "XYZ"), atol=1e-9)


def test_euler_from_quat_gives_the_same_bits_wherever_its_arrays_lie():
    # numpy 1.26 (AVX-512) computed arctan2 of strided columns with last-bit differences that
    # depended on the heap's state: the same rotations gave Euler angles 1 ULP apart from one call
    # to the next (a CI flake in test_separate).  Allocations of varying size between calls move
    # the arrays euler_from_quat allocates; every call must give the first call's bits.
    from splicer.model.rotations import atan2_stable, euler_from_quat, quat_normalize
    q = quat_normalize(np.random.default_rng(3).normal(size=(1351, 4)))
    first = euler_from_quat(q, "ZXY")
    junk = []
    for k in range(300):
        junk.append(np.empty(1 + (k * 37) % 257))
        np.testing.assert_array_equal(euler_from_quat(q, "ZXY"), first)
    cols = np.random.default_rng(4).normal(size=(1351, 9))
    ref = atan2_stable(cols[:, 3].copy(), cols[:, 4].copy())
    for off in range(13):
        buf = np.empty(cols.size + off)
        moved = buf[off:].reshape(cols.shape)
        moved[:] = cols
        np.testing.assert_array_equal(atan2_stable(moved[:, 3], moved[:, 4]), ref)


def _quat_mul_reference(a, b):
    """The Hamilton product of one pair, term by term (the textbook formula)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


@pytest.mark.parametrize("sa,sb", [((7,), (7,)), ((5, 3), (5, 3)), ((3,), (6, 3)), ((4, 1), (1, 6)), ((2, 3), ())])
def test_cross3_and_quat_mul_broadcast_bit_for_bit(sa, sb):
    """cross3 equals np.cross exactly (it replaced it in the hot paths); quat_mul equals the
    textbook product pair by pair, with numpy's broadcasting."""
    rng = np.random.default_rng(len(sa) * 10 + len(sb))
    a, b = rng.standard_normal(sa + (3,)), rng.standard_normal(sb + (3,))
    assert cross3(a, b).tobytes() == np.cross(a, b).tobytes()
    assert cross3(a, b).shape == np.broadcast_shapes(a.shape, b.shape)
    qa, qb = rng.standard_normal(sa + (4,)), rng.standard_normal(sb + (4,))
    got = quat_mul(qa, qb)
    A, B = np.broadcast_arrays(qa, qb)
    ref = np.array([_quat_mul_reference(x, y) for x, y in zip(A.reshape(-1, 4), B.reshape(-1, 4))])
    assert got.shape == A.shape and got.reshape(-1, 4).tobytes() == ref.reshape(-1, 4).tobytes()


def test_cross3_by_hand():
    np.testing.assert_array_equal(cross3([1.0, 0, 0], [0.0, 1, 0]), [0, 0, 1])   # x × y = z
    np.testing.assert_array_equal(cross3([0.0, 0, 2], [0.0, 3, 0]), [-6, 0, 0])  # 2z × 3y = -6x
