"""splicer's own Euler and matrix conversions (no scipy at run time) against scipy's, as a reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from splicer.model.rotations import euler_from_quat, quat_angle_deg, quat_from_euler, quat_from_matrix, quat_to_matrix

ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]


@pytest.fixture
def quats(rng):
    q = rng.normal(size=(500, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_matches_scipy_and_round_trips(quats, order):
    e = euler_from_quat(quats, order)
    ref = Rotation.from_quat(quats, scalar_first=True).as_euler(order, degrees=True)
    np.testing.assert_allclose(e, ref, atol=1e-9)
    assert quat_angle_deg(quat_from_euler(e, order), quats).max() < 1e-5


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("middle", [90.0, -90.0])
def test_euler_at_gimbal_lock_keeps_the_rotation(order, middle):
    q = quat_from_euler(np.array([[10.0, middle, 30.0]]), order)
    e = euler_from_quat(q, order)
    assert e[0, 2] == 0.0 and abs(abs(e[0, 1]) - 90.0) < 1e-6
    assert quat_angle_deg(quat_from_euler(e, order), q).max() < 1e-5


def test_matrix_round_trip_and_scipy(quats):
    m = quat_to_matrix(quats)
    q = quat_from_matrix(m)
    assert np.all(q[:, 0] >= 0)
    ref = Rotation.from_matrix(m).as_quat(scalar_first=True)
    ref *= np.sign(ref[:, :1])
    np.testing.assert_allclose(q, ref, atol=1e-12)


def test_degenerate_matrices():
    assert quat_from_matrix(np.zeros((3, 3))).tolist() == [1.0, 0.0, 0.0, 0.0]
    assert quat_from_matrix(np.zeros((0, 3, 3))).shape == (0, 4)
    with pytest.raises(ValueError, match="NaN or infinity"):
        quat_from_matrix(np.full((3, 3), np.nan))


def test_bad_order_is_refused():
    with pytest.raises(ValueError, match="three distinct axes"):
        euler_from_quat(np.array([1.0, 0, 0, 0]), "ZXZ")
