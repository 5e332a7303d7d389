"""Known-answer tests of splicer.transfer.sampling: fractional-frame sampling and random warps."""

import numpy as np
import pytest

from splicer.model.motion import Motion, Skeleton
from splicer.model.rotations import quat_angle_deg, quat_from_euler, quat_normalize
from splicer.transfer.sampling import resample_motion, sample_linear, sample_rotations
from splicer.evaluation.warps import smooth_monotone_warp, smooth_noise


def _random_quats(rng, shape):
    return quat_normalize(rng.standard_normal(shape + (4,)))


def _two_joint_motion(rng, T=12):
    sk = Skeleton(
        names=("root", "arm"),
        parents=np.array([-1, 0]),
        offsets=np.array([[0.0, 1.0, 0.0], [2.0, 0.0, 0.0]]),
        channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                  ("Zrotation", "Xrotation", "Yrotation")),
        end_sites=None,
    )
    t = np.arange(T)[:, None]
    ch = np.concatenate([
        rng.normal(0, 5, (T, 3)),
        np.cumsum(rng.normal(0, 4, (T, 3)), axis=0) + np.array([30.0, -20.0, 10.0]),
        np.cumsum(rng.normal(0, 4, (T, 3)), axis=0) + 0.0 * t,
    ], axis=1)
    return Motion(sk, ch, 1 / 30)


def test_sample_rotations_integer_frames_exact():
    rng = np.random.default_rng(0)
    q = _random_quats(rng, (10, 3))
    out = sample_rotations(q, np.arange(10.0))
    np.testing.assert_allclose(out, q, atol=1e-12)


def test_sample_rotations_half_frame_is_midpoint():
    # identity to 90 degrees about x: halfway is 45 degrees about x
    q = quat_from_euler(np.array([[[0.0, 0.0, 0.0]], [[90.0, 0.0, 0.0]]]), "XYZ")
    out = sample_rotations(q, np.array([0.5, 0.25]))
    np.testing.assert_allclose(out[0, 0], quat_from_euler(np.array([45.0, 0, 0]), "XYZ"), atol=1e-12)
    np.testing.assert_allclose(out[1, 0], quat_from_euler(np.array([22.5, 0, 0]), "XYZ"), atol=1e-12)


def test_sample_rotations_midpoint_equidistant_and_shortest_arc():
    rng = np.random.default_rng(1)
    q = _random_quats(rng, (2, 50))
    q[1] *= -1.0  # opposite hemisphere: same rotations, slerp must still take the short arc
    mid = sample_rotations(q, np.array([0.5]))[0]
    a = quat_angle_deg(mid, q[0])
    b = quat_angle_deg(mid, q[1])
    np.testing.assert_allclose(a, b, atol=1e-9)
    np.testing.assert_allclose(a + b, quat_angle_deg(q[0], q[1]), atol=1e-9)


def test_sample_clips_out_of_range():
    rng = np.random.default_rng(2)
    q = _random_quats(rng, (4, 2))
    out = sample_rotations(q, np.array([-3.0, 7.5]))
    np.testing.assert_allclose(out[0], q[0], atol=1e-12)
    np.testing.assert_allclose(out[1], q[3], atol=1e-12)


def test_sample_linear():
    x = np.arange(12.0).reshape(4, 3)
    out = sample_linear(x, np.array([0.0, 1.5, 3.0, 10.0]))
    np.testing.assert_allclose(out, [[0, 1, 2], [4.5, 5.5, 6.5], [9, 10, 11], [9, 10, 11]])


def test_sample_rejects_bad_frames():
    with pytest.raises(ValueError):
        sample_linear(np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError):
        sample_linear(np.zeros((3, 2)), np.array([np.nan]))
    with pytest.raises(ValueError, match="frames must be a 1-D array of fractional frame numbers, got shape \\(2, 2\\)"):
        sample_linear(np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="^frames must be finite$"):
        sample_linear(np.zeros((3, 2)), np.array([0.0, np.inf]))
    with pytest.raises(ValueError, match="^cannot sample a sequence without frames$"):
        sample_linear(np.zeros((0, 2)), np.array([0.0]))
    for bad in (np.zeros((3, 4)), np.zeros((3, 1, 3))):  # one joint without the joint axis; 3 numbers
        with pytest.raises(ValueError, match=r"q must have shape \(T, K, 4\), got \(3, "):
            sample_rotations(bad, np.array([0.5]))


def test_resample_identity_map_reproduces_channels():
    rng = np.random.default_rng(3)
    m = _two_joint_motion(rng)
    before = m.channels.copy()
    r = resample_motion(m, np.arange(m.n_frames, dtype=float), m.frame_time)
    np.testing.assert_allclose(r.channels, m.channels, atol=1e-9)
    np.testing.assert_array_equal(m.channels, before)


def test_resample_half_frames():
    rng = np.random.default_rng(4)
    m = _two_joint_motion(rng)
    frames = np.arange(0, m.n_frames - 1, 0.5)
    r = resample_motion(m, frames, m.frame_time / 2)
    assert r.n_frames == len(frames)
    assert r.frame_time == pytest.approx(m.frame_time / 2)
    np.testing.assert_allclose(r.channels[::2], m.channels[:-1], atol=1e-9)
    # positions are linear, rotations are geodesic midpoints
    np.testing.assert_allclose(r.channels[1::2, :3], 0.5 * (m.channels[:-1, :3] + m.channels[1:, :3]), atol=1e-12)
    qa, qb, qm = m.rotations[:-1], m.rotations[1:], r.rotations[1::2]
    np.testing.assert_allclose(quat_angle_deg(qm, qa), quat_angle_deg(qm, qb), atol=1e-7)
    np.testing.assert_allclose(quat_angle_deg(qm, qa), 0.5 * quat_angle_deg(qa, qb), atol=1e-7)


def test_smooth_noise_deterministic_and_unit_scale():
    a = smooth_noise(4000, np.random.default_rng(5), sigma=10.0, dims=(3,))
    b = smooth_noise(4000, np.random.default_rng(5), sigma=10.0, dims=(3,))
    np.testing.assert_array_equal(a, b)
    assert a.shape == (4000, 3)
    assert 0.6 < a.std() < 1.4
    assert np.abs(np.diff(a, axis=0)).max() < 0.3  # smooth: small steps


def test_smooth_monotone_warp_bounds():
    w = smooth_monotone_warp(2000, np.random.default_rng(6), min_speed=0.5, max_speed=2.0, sigma=40.0)
    assert w[0] == 0.0
    d = np.diff(w)
    assert d.min() >= 0.5 - 1e-12 and d.max() <= 2.0 + 1e-12
    assert d.max() / d.min() > 1.5  # the speed really varies
    assert np.abs(np.diff(d)).max() < 0.1  # and smoothly (range 1.5 over 2000 frames)


def test_resample_keeps_angles_near_the_original_channels_and_the_source():
    # the arm's Z channel is stored as 370 .. 390 degrees (a file written after a full turn):
    # the written-back Euler angle is brought within 180 degrees of the interpolated channel,
    # so 370 stays 370 (not 10) and halfway between 370 and 380 is 375
    rng = np.random.default_rng(6)
    m = _two_joint_motion(rng, T=3)
    ch = np.array(m.channels)
    ch[:, 6:9] = [[370.0, 0, 0], [380.0, 0, 0], [390.0, 0, 0]]
    m = Motion(m.skeleton, ch, m.frame_time, source="arm.bvh")
    out = resample_motion(m, np.array([0.0, 0.5, 2.0]), 1 / 60)
    np.testing.assert_allclose(out.channels[:, 6], [370.0, 375.0, 390.0], atol=1e-9)
    assert out.source == "arm.bvh" and out.frame_time == 1 / 60


def test_a_one_frame_sequence_is_that_frame_everywhere():
    np.testing.assert_array_equal(sample_linear(np.array([[5.0, 6.0]]), np.array([0.0, 0.7, 3.0])), [[5, 6]] * 3)
    q = np.array([[[0.0, 1.0, 0.0, 0.0]]])
    np.testing.assert_array_equal(sample_rotations(q, np.array([0.0, 0.4])), [[[0, 1, 0, 0]]] * 2)
