"""Virtual markers: placement and equivariance under a turn about the up axis."""

import numpy as np
import pytest

from splicer.io.bvh import read_bvh
from splicer.model.kinematics import global_transforms
from splicer.rig.markers import arm_markers
from splicer.rig.roles import find_roles
from splicer.model.rotations import quat_mul, quat_rotate, yaw_quat_deg


def _turn_root(m, angle_deg, up=1):
    """The motion turned about the up axis through the origin (root rotation and position)."""
    q = yaw_quat_deg(angle_deg, up)
    rot = quat_mul(q[None], m.rotations[:, 0])
    m2 = m.with_rotations([0], rot[:, None])
    return m2.with_translations(0, quat_rotate(q[None], m.translations[:, 0])), q


def _synthetic_take():
    from splicer.evaluation.synth import make_gesture_take

    return make_gesture_take(4.0, 30.0, np.random.default_rng(3))


@pytest.fixture(scope="module")
def take():
    return _synthetic_take()


def test_marker_geometry(take):
    roles = find_roles(take.skeleton, source="synthetic")
    for side, arm in roles.sides.items():
        mk = arm_markers(take, arm, roles.up)
        _, pos = global_transforms(take, [arm.wrist, arm.elbow, arm.upper_arm, arm.fingers["middle"][0]])
        np.testing.assert_allclose(0.5 * (mk.points[:, 0] + mk.points[:, 1]), pos[:, 0], atol=1e-9)
        np.testing.assert_allclose(mk.points[:, 2], 0.5 * (pos[:, 0] + pos[:, 1]), atol=1e-9)
        np.testing.assert_allclose(mk.points[:, 3], pos[:, 3], atol=1e-9)
        np.testing.assert_allclose(mk.shoulder, pos[:, 2], atol=1e-9)


@pytest.mark.parametrize("angle", [90.0, -37.0])
def test_markers_turn_with_the_motion(take, angle):
    roles = find_roles(take.skeleton, source="synthetic")
    turned, q = _turn_root(take, angle, roles.up)
    for side, arm in roles.sides.items():
        a = arm_markers(take, arm, roles.up)
        b = arm_markers(turned, arm, roles.up)
        np.testing.assert_allclose(b.points, quat_rotate(q, a.points), atol=1e-6)
        np.testing.assert_allclose(b.shoulder, quat_rotate(q, a.shoulder), atol=1e-6)
        np.testing.assert_allclose(b.heading - a.heading, np.radians(angle), atol=1e-6)


def test_markers_on_hand_only_files(shared_motions):
    for name in ("leap-hands/fingers-ok.bvh", "manipnet-hands/teapot3_leftHand.bvh"):
        m = _quiet_read(shared_motions / name)
        r = find_roles(m.skeleton, source=name)
        (arm,) = r.sides.values()
        mk = arm_markers(m, arm, r.up)
        assert np.all(np.isfinite(mk.points))
        assert np.all(mk.shoulder == 0)
        # the virtual forearm marker sits behind the wrist, away from the hand marker
        w = 0.5 * (mk.points[:, 0] + mk.points[:, 1])
        cos = np.sum((mk.points[:, 2] - w) * (mk.points[:, 3] - w), axis=-1)
        assert np.median(cos) < 0


def _quiet_read(path):
    import warnings
    from splicer.errors import SplicerWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SplicerWarning)
        return read_bvh(path)
