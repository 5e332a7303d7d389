"""Tests of the procedural gesturing speaker (splicer.evaluation.synth)."""

import numpy as np
import pytest

from splicer.model.kinematics import global_transforms, rest_positions
from splicer.rig.roles import find_roles
from splicer.model.rotations import quat_angle
from splicer.evaluation.synth import gesture_skeleton, make_gesture_take

FPS = 30.0


@pytest.fixture(scope="module")
def take():
    return make_gesture_take(12.0, FPS, np.random.default_rng(7))


def test_skeleton_layout():
    sk = gesture_skeleton()
    assert sk.names[0] == "Hips"
    assert sk.channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    assert all(c == ("Zrotation", "Xrotation", "Yrotation") for c in sk.channels[1:])
    for side in ("Left", "Right"):
        for part in ("Shoulder", "Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot", "ToeBase"):
            sk.index(side + part)
        for finger in ("Thumb", "Index", "Middle", "Ring", "Pinky"):
            for k in (1, 2, 3):
                sk.index(f"{side}Hand{finger}{k}")
    rest = rest_positions(sk)
    height = rest[sk.index("Head"), 1] + sk.end_sites[sk.index("Head"), 1]
    assert 160 < height < 190  # centimetres, Y up, feet at the floor
    assert abs(rest[sk.index("LeftToeBase"), 1]) < 1.0
    # T-pose: the left hand at +X, the thumb on the radial (front, +Z) side of the index
    lh, rh = rest[sk.index("LeftHand")], rest[sk.index("RightHand")]
    assert lh[0] > 60 and rh[0] < -60 and abs(lh[1] - rh[1]) < 1e-9
    assert rest[sk.index("LeftHandThumb1"), 2] > rest[sk.index("LeftHandIndex1"), 2] > rest[sk.index("LeftHandPinky1"), 2]
    np.testing.assert_allclose(rest[sk.index("RightHandThumb3")] * [-1, 1, 1], rest[sk.index("LeftHandThumb3")])


def test_roles_found(take):
    r = find_roles(take.skeleton, source=take.source)
    assert r.up == 1
    for side in ("left", "right"):
        arm = r.sides[side]
        assert take.skeleton.names[arm.wrist] == side.capitalize() + "Hand"
        assert set(arm.fingers) == {"thumb", "index", "middle", "ring", "pinky"}
        assert all(len(c) == 3 for c in arm.fingers.values())


def test_deterministic():
    a = make_gesture_take(3.0, FPS, np.random.default_rng(3))
    b = make_gesture_take(3.0, FPS, np.random.default_rng(3))
    c = make_gesture_take(3.0, FPS, np.random.default_rng(4))
    assert a.n_frames == round(3.0 * FPS) + 1
    np.testing.assert_array_equal(a.channels, b.channels)
    assert not np.allclose(a.channels, c.channels)


def test_fingers_move_within_limits(take):
    sk = take.skeleton
    r = find_roles(sk)
    ident = np.array([1.0, 0, 0, 0])
    for arm in r.sides.values():
        for finger, chain in arm.fingers.items():
            ang = quat_angle(take.rotations[:, list(chain)], ident)
            assert ang.max() <= 95.0, (finger, ang.max())
        # the fingers do move, several tens of degrees
        mcp = [chain[0] for f, chain in arm.fingers.items() if f != "thumb"]
        rng_deg = quat_angle(take.rotations[:, mcp], take.rotations[:1, mcp]).max(axis=0)
        assert rng_deg.max() > 30.0 and rng_deg.min() > 10.0


def test_smooth_and_plausible(take):
    sk = take.skeleton
    # C1-ish: no channel jumps more than 30 degrees between frames (and no 360 wraps)
    assert np.abs(np.diff(take.channels[:, 3:], axis=0)).max() < 30.0
    _, pos = global_transforms(take)
    hands = pos[:, [sk.index("LeftHand"), sk.index("RightHand")]]
    speed = np.linalg.norm(np.diff(hands, axis=0), axis=-1) * FPS  # cm/s
    assert speed.max() < 400.0
    assert np.percentile(speed, 90) > 20.0  # the hands really gesture
    # hands in front of the body, between hip and head height
    assert hands[..., 2].min() > -5.0
    assert 80 < hands[..., 1].min() and hands[..., 1].max() < 170
    # feet stay near the floor
    feet = pos[:, [sk.index("LeftFoot"), sk.index("RightFoot")]]
    assert np.abs(feet[..., 1] - feet[0, :, 1]).max() < 3.0
