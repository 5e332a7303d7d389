"""Tests of the evaluation protocol (splicer.evaluation.separate, ALGORITHM.md section 8)."""

from pathlib import Path

import numpy as np
import pytest

from splicer.model.kinematics import global_transforms
from splicer.rig.roles import find_roles
from splicer.model.rotations import quat_angle_deg, quat_rotate
from splicer.evaluation.separate import finger_joints, moving_finger_joints, separate, wrist_rooted
from splicer.evaluation.synth import make_gesture_take
from splicer.transfer.sampling import sample_rotations

SHARED = Path(__file__).resolve().parents[2] / "shared" / "motions"
ZEGGS = SHARED / "zeggs" / "067_Speech_2_x_1_0.bvh"


@pytest.fixture(scope="module")
def take():
    return make_gesture_take(10.0, 30.0, np.random.default_rng(11))


@pytest.fixture(scope="module")
def sep(take):
    return separate(take, rng=np.random.default_rng(5), hand_only="wrist")


def _heading(motion, up):
    """Heading of the root about ``up`` (radians, counter-clockwise about +up), shape (T,)."""
    rot, _ = global_transforms(motion, [0])
    a, b = (up + 1) % 3, (up + 2) % 3
    fwd = np.zeros(3)
    fwd[a] = 1.0
    v = quat_rotate(rot[:, 0], fwd)
    return np.arctan2(v[:, b], v[:, a])


def _check_separation(take, sep, *, finger_tol_deg):
    sk = take.skeleton
    r = find_roles(sk)
    fj = finger_joints(take, r)
    # body: fingers at identity, everything else untouched
    body = sep.body
    assert body.n_frames == take.n_frames and body.frame_time == take.frame_time
    np.testing.assert_allclose(quat_angle_deg(body.rotations[:, fj], np.array([1.0, 0, 0, 0])), 0.0, atol=1e-6)
    finger_cols = np.concatenate([sk.rotation_columns(j) for j in fj])
    other = np.setdiff1d(np.arange(sk.n_channels), finger_cols)
    np.testing.assert_array_equal(body.channels[:, other], take.channels[:, other])
    # truth: strictly increasing from 0 to the last hands frame
    t = sep.truth
    assert t.shape == (take.n_frames,)
    assert np.all(np.diff(t) > 0)
    assert t[0] == pytest.approx(0.0, abs=1e-9)
    assert t[-1] == pytest.approx(sep.hands.n_frames - 1, abs=1e-6)
    ratio = np.diff(t) * take.fps / sep.params["hands_fps"]
    assert ratio.min() > 0.45 and ratio.max() < 2.2
    # the hands at the true times show the take's wrists and fingers (up to 0.5 deg noise + interpolation)
    wrists = [a.wrist for a in r.sides.values()]
    fw = fj + wrists
    err = quat_angle_deg(sample_rotations(sep.hands.rotations[:, fw], t), take.rotations[:, fw])
    assert err.mean() < 1.0
    assert np.percentile(err, 99) < finger_tol_deg
    # the arms are confined: the forearm moves less in the hands than in the body
    elbow = r.sides["right"].elbow
    spread_body = quat_angle_deg(take.rotations[:, elbow], take.rotations[:, elbow].mean(0) / np.linalg.norm(take.rotations[:, elbow].mean(0))).mean()
    qh = sep.hands.rotations[:, elbow]
    spread_hands = quat_angle_deg(qh, qh.mean(0) / np.linalg.norm(qh.mean(0))).mean()
    assert spread_hands < 0.8 * spread_body
    # root turned by the drawn yaw, held nearly still
    yaw = sep.params["yaw_deg"]
    assert 25.0 <= abs(yaw) <= 60.0
    h_take = _heading(take, r.up)
    h_hands = sample_rotations(np.stack([np.cos(_heading(sep.hands, r.up) / 2), np.zeros(sep.hands.n_frames),
                                         np.zeros(sep.hands.n_frames), np.sin(_heading(sep.hands, r.up) / 2)], -1)[:, None], t)
    h_hands = 2 * np.arctan2(h_hands[:, 0, 3], h_hands[:, 0, 0])
    diff = np.degrees(np.angle(np.exp(1j * (h_hands - h_take))))
    np.testing.assert_allclose(diff, yaw, atol=0.5)
    root = sep.hands.translations[:, 0]
    horiz = [a for a in range(3) if a != r.up]
    assert np.ptp(root[:, horiz], axis=0).max() < 15.0
    return err


def test_separation_synthetic(take, sep):
    before = take.channels.copy()
    _check_separation(take, sep, finger_tol_deg=2.0)
    np.testing.assert_array_equal(take.channels, before)
    assert sep.hands.fps == pytest.approx(2 * take.fps)
    assert sep.params["amplitude"].min() >= 0.25 and sep.params["amplitude"].max() <= 0.7


def test_deterministic_per_seed(take):
    a = separate(take, rng=np.random.default_rng(9))
    b = separate(take, rng=np.random.default_rng(9))
    c = separate(take, rng=np.random.default_rng(10))
    np.testing.assert_array_equal(a.hands.channels, b.hands.channels)
    np.testing.assert_array_equal(a.truth, b.truth)
    assert a.params["yaw_deg"] == b.params["yaw_deg"]
    assert a.hands.n_frames != c.hands.n_frames or not np.allclose(a.truth, c.truth)


def test_options(take):
    s = separate(take, rng=np.random.default_rng(1), hands_fps=45.0, warp_speed=(1.0, 1.0),
                 amplitude=(1.0, 1.0), yaw_deg=(30.0, 30.0), noise_deg=0.0)
    assert s.hands.fps == pytest.approx(45.0)
    np.testing.assert_allclose(s.truth, np.arange(take.n_frames) * 45.0 / 30.0, atol=1e-9)
    assert abs(s.params["yaw_deg"]) == 30.0
    # no warp, no pull, no noise: the arms match the take exactly at the true times
    r = find_roles(take.skeleton)
    joints = [j for a in r.sides.values() for j in (a.upper_arm, a.elbow, a.wrist)]
    err = quat_angle_deg(sample_rotations(s.hands.rotations[:, joints], s.truth), take.rotations[:, joints])
    assert err.max() < 1.0
    with pytest.raises(ValueError):
        separate(take, rng=np.random.default_rng(1), hand_only="elbow")


def test_hand_only_wrist(take, sep):
    r = find_roles(take.skeleton)
    for side, arm in r.sides.items():
        ho = sep.hand_only[side]
        assert ho.source == f"hands_{side}.bvh"
        assert ho.skeleton.names[0] == take.skeleton.names[arm.wrist]
        assert len(ho.skeleton.channels[0]) == 6
        assert ho.n_frames == sep.hands.n_frames
        # same world positions of the hand joints as in the full hands motion
        joints = [arm.wrist] + take.skeleton.descendants(arm.wrist)
        _, p_full = global_transforms(sep.hands, joints)
        _, p_only = global_transforms(ho)
        np.testing.assert_allclose(p_only, p_full, atol=1e-6)
        ro = find_roles(ho.skeleton, source=ho.source)
        assert set(ro.sides) == {side}
        assert set(ro.sides[side].fingers) == set(arm.fingers)
    # wrist_rooted on a joint directly: same as the separation's
    np.testing.assert_array_equal(wrist_rooted(sep.hands, r.sides["left"].wrist, source="hands_left.bvh").channels,
                                  sep.hand_only["left"].channels)


def test_moving_finger_joints(take):
    r = find_roles(take.skeleton)
    fj = finger_joints(take, r)
    assert len(fj) == 30
    mv = moving_finger_joints(take, r, min_range_deg=5.0)
    assert set(mv) <= set(fj) and len(mv) > 20
    frozen = take.with_rotations(fj, np.tile([1.0, 0, 0, 0], (take.n_frames, len(fj), 1)))
    assert moving_finger_joints(frozen, r) == []


def test_real_zeggs_take():
    if not ZEGGS.is_file():
        pytest.skip("../shared/motions not found")
    from splicer.io.bvh import read_bvh

    take = read_bvh(ZEGGS).slice(0, 450)
    s = separate(take, rng=np.random.default_rng(2))
    _check_separation(take, s, finger_tol_deg=3.0)
    assert len(moving_finger_joints(take)) >= 20
