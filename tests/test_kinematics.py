"""Forward kinematics against positions worked out by hand (tests/data/fk_known.bvh)."""

import numpy as np

from splicer.io.bvh import read_bvh
from splicer.model.kinematics import global_transforms, rest_positions
from splicer.model.rotations import quat_from_euler, quat_rotate, quat_mul, euler_from_quat

from conftest import DATA


def test_fk_known_answer():
    m = read_bvh(DATA / "fk_known.bvh")
    _, pos = global_transforms(m)
    # frame 0: root at (1,2,3); Arm turned +90 about Z, so its child offset (0,5,0) -> (-5,0,0)
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [11, 2, 3], [6, 2, 3]], atol=1e-9)
    # frame 1: root turned +90 about Y: (10,0,0) -> (0,0,-10); (0,5,0) unchanged by Y
    np.testing.assert_allclose(pos[1], [[1, 2, 3], [1, 2, -7], [1, 7, -7]], atol=1e-9)
    # frame 2: root +90 about Z: Arm at (0,10,0); Hand rotation (its own) does not move Hand;
    # Arm has no rotation, so Hand = Arm + Rz90 (0,5,0) = (-5,10,0)
    np.testing.assert_allclose(pos[2], [[0, 0, 0], [0, 10, 0], [-5, 10, 0]], atol=1e-9)


def test_fk_subset_matches_full():
    m = read_bvh(DATA / "fk_known.bvh")
    rot, pos = global_transforms(m)
    rot2, pos2 = global_transforms(m, [2])
    np.testing.assert_allclose(pos2[:, 0], pos[:, 2])
    np.testing.assert_allclose(rot2[:, 0], rot[:, 2])


def test_rest_positions():
    m = read_bvh(DATA / "fk_known.bvh")
    np.testing.assert_allclose(rest_positions(m.skeleton), [[0, 0, 0], [10, 0, 0], [10, 5, 0]])


def test_euler_order_is_intrinsic_bvh(rng):
    # ZXY in BVH means R = Rz @ Rx @ Ry
    ang = rng.uniform(-170, 170, size=(20, 3))
    q = quat_from_euler(ang, "ZXY")
    ex = np.array([1.0, 0, 0, 0])
    qz = quat_from_euler(np.c_[ang[:, 0], 0 * ang[:, :2]], "ZXY")
    qx = quat_from_euler(np.c_[0 * ang[:, 0], ang[:, 1], 0 * ang[:, 0]], "ZXY")
    qy = quat_from_euler(np.c_[0 * ang[:, :2], ang[:, 2]], "ZXY")
    np.testing.assert_allclose(np.abs(np.sum(q * quat_mul(qz, quat_mul(qx, qy)), axis=-1)), 1, atol=1e-12)
    back = euler_from_quat(q, "ZXY")
    q2 = quat_from_euler(back, "ZXY")
    np.testing.assert_allclose(np.abs(np.sum(q * q2, axis=-1)), 1, atol=1e-12)
    v = rng.normal(size=(20, 3))
    assert np.allclose(np.linalg.norm(quat_rotate(q, v), axis=-1), np.linalg.norm(v, axis=-1))
    del ex


def test_quat_from_euler_matches_scipy_every_order(rng):
    from scipy.spatial.transform import Rotation

    ang = rng.uniform(-360, 360, size=(50, 3))
    for order in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"):
        ours = quat_from_euler(ang, order)
        ref = Rotation.from_euler(order, ang, degrees=True).as_quat(scalar_first=True)
        np.testing.assert_allclose(np.abs(np.sum(ours * ref, axis=-1)), 1.0, atol=1e-12)
    two = quat_from_euler(ang[:, :2], "ZX")
    ref = Rotation.from_euler("ZX", ang[:, :2], degrees=True).as_quat(scalar_first=True)
    np.testing.assert_allclose(np.abs(np.sum(two * ref, axis=-1)), 1.0, atol=1e-12)
