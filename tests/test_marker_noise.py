"""Optical markers' noise: estimated from third differences, drawn, and what it does to the wrist's signal."""

import numpy as np
import pytest

from splicer.align.wrist import hand_in_forearm, noise_share
from splicer.rig.marker_noise import marker_noise, noise_markers, role_noise


def test_marker_noise_recovers_white_noise_on_smooth_motion():
    rng = np.random.default_rng(0)
    t = np.arange(3000) / 100.0  # 30 s at 100 Hz
    arm = np.stack([300 * np.sin(2 * np.pi * 0.7 * t), 200 * np.cos(2 * np.pi * 1.1 * t), 50 * t], axis=1)  # mm
    pts = np.stack([arm, arm, arm + 40.0], axis=1)
    pts[:, 0] += rng.normal(0.0, 1.5, (len(t), 3))
    pts[:, 2] += rng.normal(0.0, 0.5, (len(t), 3))
    pts[1000:1100, 2] = np.nan  # a gap: the differences that touch it are left out
    sd = marker_noise(pts)
    assert sd[0] == pytest.approx(1.5, rel=0.05)
    assert sd[1] < 0.01  # smooth motion alone leaves almost nothing (arm jerk x (1/100 s)^3)
    assert sd[2] == pytest.approx(0.5, rel=0.05)
    # a spike does not move the median-based estimate
    spiky = np.array(pts)
    spiky[500, 0] += 200.0
    assert marker_noise(spiky)[0] == pytest.approx(sd[0], rel=0.02)
    # too few differences: NaN; wrong shape: an error
    few = np.full((50, 1, 3), np.nan)
    few[:6, 0] = 1.0  # three differences of three coordinates: nine values
    assert np.isnan(marker_noise(few)[0]) and np.isnan(marker_noise(pts[:3])).all()
    with pytest.raises(ValueError, match="shape"):
        marker_noise(pts[:, :, :2])


def test_role_noise_worked_answer():
    # averaging k markers: sqrt(sum sd^2) / k
    got = role_noise(np.array([1.0, 2.0, 2.0, np.nan]), {"p1": [0], "p3": [1, 2], "p4": [3]})
    assert got["p1"] == 1.0 and got["p3"] == pytest.approx(np.sqrt(8.0) / 2.0) and np.isnan(got["p4"])


def test_noise_markers_draws_like_the_markers():
    pts, sh = noise_markers({"p1": 2.0, "p2": 1.0, "p3": 0.5, "shoulder": 0.25}, 20000, seed=3)
    assert pts.shape == (20000, 4, 3) and sh.shape == (20000, 3)
    np.testing.assert_allclose(pts.std(axis=(0, 2)), [2.0, 1.0, 0.5, 0.0], rtol=0.02)  # p4 not given: zeros
    assert sh.std() == pytest.approx(0.25, rel=0.02)
    again, _ = noise_markers({"p1": 2.0, "p2": 1.0, "p3": 0.5, "shoulder": 0.25}, 20000, seed=3)
    assert np.array_equal(pts, again)  # fixed draw: a splice does not change from run to run


def _arm(frames):
    """p1, p2, p3 fixed; the hand p4 swinging in the forearm's frame (as tests/test_wrist.py)."""
    a = 0.6 * np.sin(frames / 4.0) + 0.3 * np.sin(frames / 11.0)
    b = 0.4 * np.cos(frames / 6.0)
    p = np.zeros((len(frames), 4, 3))
    p[:, 0], p[:, 1], p[:, 2] = [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-10.0, 0.0, 0.0]
    p[:, 3] = np.stack([np.cos(a) * np.cos(b), np.sin(b), np.sin(a) * np.cos(b)], axis=1) * 3.0
    return p


def test_noise_share_worked():
    fps = 30.0
    hands = _arm(np.arange(400, dtype=float))
    c = 50.0 + np.arange(250, dtype=float)  # body frame i shows hands frame 50 + i: slope 1
    body = _arm(c)
    kw = dict(fps=fps, smooth_s=0.05, slope_s=0.5)
    assert noise_share(body, hands, c, **kw) == 0.0  # no draws: a solved skeleton's markers
    rng = np.random.default_rng(1)
    nb, nh = rng.normal(0, 0.01, body.shape), rng.normal(0, 0.01, hands.shape)
    # the body's share by hand: the draw's change to the rates over the rates' power
    from splicer.filters import gaussian_filter1d

    def rate(p):
        return np.gradient(gaussian_filter1d(hand_in_forearm(p), 0.05 * fps, axis=0, mode="nearest"), axis=0)

    want_b = np.sum(np.mean((rate(body + nb) - rate(body)) ** 2, axis=0)) / np.sum(np.mean(rate(body) ** 2, axis=0))
    assert noise_share(body, hands, c, body_noise=nb, **kw) == pytest.approx(want_b, rel=1e-9)
    both = noise_share(body, hands, c, body_noise=nb, hands_noise=nh, **kw)
    assert both == pytest.approx(2 * want_b, rel=0.25)  # the same noise in each take, at the same tempo: about twice
    louder = noise_share(body, hands, c, body_noise=3 * nb, **kw)
    assert louder == pytest.approx(9 * want_b, rel=0.1)  # a share of power: three times the noise, nine times
    still = np.repeat(body[:1], len(c), axis=0)
    assert noise_share(still, hands, c, body_noise=nb, **kw) == np.inf
    assert np.isnan(noise_share(body[:2], hands, c[:2], body_noise=nb[:2], **kw))
    with pytest.raises(ValueError, match="finite"):
        noise_share(body, hands, np.where(np.arange(250) == 3, np.nan, c), body_noise=nb, **kw)


def test_to_common_carries_markers_and_their_noise_alike():
    """stages.markers.to_common: the axes relabelled so that the body's axis is up (a cyclic
    permutation), then resampled to the body's rate; linear, so a noise draw carried the same way
    is the difference it makes to the carried markers."""
    from splicer.rig.markers import Markers
    from splicer.stages.markers import to_common

    t = np.arange(121, dtype=np.float64)  # 2 s at 60 fps, z up
    pts = np.stack([np.stack([t, 2 * t, 3 * t + k], axis=1) for k in range(4)], axis=1)
    sh = np.stack([t, -t, np.full_like(t, 5.0)], axis=1)
    m = Markers(pts, sh, np.zeros(len(t)), 2, 60.0, "left")
    same = to_common(m, 2)
    assert same is m  # already z up, no rate given: untouched
    y_up = to_common(m, 1)  # new axis k takes old axis (k + 1) % 3: z becomes y
    assert y_up.up == 1 and y_up.fps == 60.0
    np.testing.assert_array_equal(y_up.points[5, 0], [2 * 5.0, 3 * 5.0, 5.0])
    np.testing.assert_array_equal(y_up.shoulder[5], [-5.0, 5.0, 5.0])
    half = to_common(m, 1, 30.0)  # and at half the rate: linear motion keeps its values at the kept instants
    assert half.fps == 30.0 and half.n_frames == 61
    np.testing.assert_allclose(half.points[10, 3], [2 * 20.0, 3 * 20.0 + 3, 20.0], atol=1e-9)
    noise = Markers(np.random.default_rng(0).normal(size=pts.shape), np.zeros_like(sh), np.zeros(len(t)), 2, 60.0, "left")
    noisy = Markers(pts + noise.points, sh, m.heading, 2, 60.0, "left")
    np.testing.assert_allclose(to_common(noisy, 1, 30.0).points - half.points, to_common(noise, 1, 30.0).points,
                               atol=1e-9)
