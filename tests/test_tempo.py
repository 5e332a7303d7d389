"""Tempo-matched smoothing (splicer.align.tempo): the tempo read from time maps, each take's
further smoothing, the varying-width Gaussian that applies it, and the second opinion that uses it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from splicer.align.costs import phase_features
from splicer.align.tempo import map_tempo, tempo_blur
from splicer.filters import gaussian_filter1d, varying_gaussian_filter1d
from splicer.rig.markers import Markers


def _slow_varying(x, sigma, mode="nearest", truncate=4.0):
    """The definition, one output sample at a time (axis 0)."""
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    out = np.empty_like(x)
    for i in range(n):
        if sigma[i] == 0:
            out[i] = x[i]
            continue
        r = int(truncate * sigma[i] + 0.5)
        acc, norm = np.zeros(x.shape[1:]), 0.0
        for k in range(-r, r + 1):
            j = i + k
            if mode == "nearest":
                j = min(max(j, 0), n - 1)
            else:
                j = j % (2 * n)
                j = 2 * n - 1 - j if j >= n else j
            w = np.exp(-0.5 * (k / sigma[i]) ** 2)
            acc += w * x[j]
            norm += w
        out[i] = acc / norm
    return out


@pytest.mark.parametrize("mode", ["nearest", "reflect"])
def test_varying_gaussian_matches_its_definition(mode):
    rng = np.random.default_rng(3)
    x = rng.normal(size=(40, 2, 3))
    sigma = np.where(rng.random(40) < 0.3, 0.0, rng.uniform(0.2, 6.0, 40))
    got = varying_gaussian_filter1d(x, sigma, axis=0, mode=mode)
    np.testing.assert_allclose(got, _slow_varying(x, sigma, mode), rtol=1e-12, atol=1e-12)
    # one width everywhere is the plain Gaussian; along another axis too
    np.testing.assert_allclose(varying_gaussian_filter1d(x, np.full(40, 2.5), axis=0, mode=mode),
                               gaussian_filter1d(x, 2.5, axis=0, mode=mode), rtol=1e-12, atol=1e-13)
    xt = np.moveaxis(x, 0, -1)
    np.testing.assert_allclose(varying_gaussian_filter1d(xt, sigma, axis=-1, mode=mode),
                               np.moveaxis(got, 0, -1), rtol=1e-12, atol=1e-12)
    # widths of 0 keep the input as it is (a float copy)
    same = varying_gaussian_filter1d(x, np.zeros(40), axis=0)
    assert np.array_equal(same, x) and same is not x


def test_varying_gaussian_refuses_bad_widths():
    x = np.zeros(5)
    for bad in (np.zeros(4), np.array([0, 1, -1, 0, 0.0]), np.array([0, np.nan, 0, 0, 0.0])):
        with pytest.raises(ValueError, match="sigma"):
            varying_gaussian_filter1d(x, bad)
    with pytest.raises(ValueError, match="mode"):
        varying_gaussian_filter1d(x, np.ones(5), mode="wrap")


def test_map_tempo_worked_answers():
    # half speed for 2 s, then twice the speed (body at 30 fps; maps in common frames)
    c = np.concatenate([np.arange(60) * 0.5, 30.0 + np.arange(1, 61) * 2.0])
    t = map_tempo([c], 30.0, slope_s=0.0)
    assert t[5] == 0.5 and t[100] == 2.0 and t[0] == 0.5 and t[-1] == 2.0
    # two sides averaged; an uncovered stretch (NaN) takes its neighbours' tempo
    other = c.copy()
    other[70:90] = np.nan
    t2 = map_tempo([c, other], 30.0, slope_s=0.0)
    np.testing.assert_allclose(t2, t)
    gone = np.full_like(c, np.nan)
    gone[:40] = c[:40]
    t3 = map_tempo([gone], 30.0, slope_s=0.0)
    assert np.allclose(t3[:39], 0.5) and np.allclose(t3[39:], 0.5)  # the last slope known, carried on
    # clipped: a map that stands still or jumps
    flat = np.concatenate([np.zeros(30), np.arange(30) * 10.0])
    tf = map_tempo([flat], 30.0, slope_s=0.0, limits=(0.2, 5.0))
    assert tf[10] == 0.2 and tf[50] == 5.0
    # smoothed: the step becomes a ramp, the plateaus stay
    ts = map_tempo([c], 30.0, slope_s=0.5)
    assert ts[5] == pytest.approx(0.5, abs=1e-3) and ts[115] == pytest.approx(2.0, abs=1e-3)
    assert 0.5 < ts[60] < 2.0
    assert np.allclose(map_tempo([np.full(10, np.nan)], 30.0), 1.0)
    with pytest.raises(ValueError):
        map_tempo([c, c[:-1]], 30.0)
    with pytest.raises(ValueError):
        map_tempo([], 30.0)


def test_tempo_blur_worked_answers():
    # body frames 0-1 at half the hands' tempo (the hands ran twice as fast: the body is blurred
    # further), frames 2-3 at twice it (the hands are)
    t = np.array([0.5, 0.5, 2.0, 2.0])
    b, h = tempo_blur(t, np.array([0.0, 0.5, 1.0, 3.0]), 6)
    r3 = np.sqrt(3.0)
    np.testing.assert_allclose(b, [r3, r3, 0, 0])
    np.testing.assert_allclose(h, [0, r3, r3, r3, r3, r3])  # hands frames past the map: its last tempo
    # total blur: sqrt(1 + f^2) of the metric's: the body's 1 / t, the hands' t
    np.testing.assert_allclose(np.sqrt(1 + b[:2] ** 2), 1 / t[:2])
    # a map that stands still: the later frame's tempo; uncovered frames are skipped
    b2, h2 = tempo_blur(np.array([1.0, 3.0, 3.0]), np.array([0.0, 0.0, np.nan]), 2)
    np.testing.assert_allclose(h2, [np.sqrt(8.0), np.sqrt(8.0)])
    assert np.array_equal(b2, np.zeros(3))
    _, h3 = tempo_blur(np.array([2.0, 2.0]), np.array([np.nan, np.nan]), 3)
    assert np.array_equal(h3, np.zeros(3))
    with pytest.raises(ValueError):
        tempo_blur(np.array([0.0, 1.0]), np.zeros(2), 2)


def _markers(n=120, seed=0, blur=None):
    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.normal(size=(n, 4, 3)), axis=0)
    sh = rng.normal(size=(n, 3))
    return Markers(pts, sh, np.zeros(n), 1, 30.0, "left", blur)


def test_phase_features_smooth_by_the_markers_blur_first():
    mk = _markers()
    blur = np.linspace(0.0, 3.0, mk.n_frames)
    smooth_s = 0.1
    got = phase_features(replace(mk, blur=blur), smooth_s=smooth_s)
    rel = varying_gaussian_filter1d(mk.relative(), blur * (smooth_s * mk.fps), axis=0)  # as phase_features forms it
    ref = phase_features(Markers(rel, np.zeros((mk.n_frames, 3)), mk.heading, mk.up, mk.fps, mk.side),
                         smooth_s=smooth_s)
    np.testing.assert_allclose(got.vel, ref.vel, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got.acc, ref.acc, rtol=1e-12, atol=1e-12)
    # no blur, or a blur of 0 everywhere: the plain features
    plain = phase_features(mk, smooth_s=smooth_s)
    zero = phase_features(replace(mk, blur=np.zeros(mk.n_frames)), smooth_s=smooth_s)
    np.testing.assert_array_equal(zero.vel, plain.vel)
    assert not np.allclose(got.vel, plain.vel)


def test_markers_blur_is_checked_and_frozen():
    mk = _markers(n=10, blur=np.ones(10))
    with pytest.raises(ValueError):
        mk.blur[0] = 2.0
    for bad in (np.ones(9), -np.ones(10), np.full(10, np.inf)):
        with pytest.raises(ValueError, match="blur"):
            _markers(n=10, blur=bad)
    from splicer.align.evidence import played_backwards

    back = played_backwards(_markers(n=10, blur=np.arange(10.0)))
    assert back.blur.tolist() == list(np.arange(10.0)[::-1])


def test_tempo_markers_blur_each_take_by_the_first_maps():
    """On a real splice's sides: maps at half the body's tempo over the first half and 1.25 times
    it over the second give the body sqrt(3) of further smoothing in the first half and the hands
    0.75 where the second half falls on them; the other take none there."""
    from splicer import splice
    from splicer.evaluation.synth import make_gesture_take
    from splicer.evaluation.separate import separate
    from splicer.stages.recheck import tempo_markers

    take = make_gesture_take(12.0, 30.0, np.random.default_rng(4))
    sep = separate(take, rng=np.random.default_rng(1))
    res = splice(sep.body, sep.hands)
    n = sep.body.n_frames
    half, edge = n // 2, 60  # four of the slope's smoothing widths (0.5 s at 30 fps) from the step
    c = np.concatenate([np.arange(half) * 0.5, half * 0.5 + np.arange(1, n - half + 1) * 1.25])
    sides = {}
    for s, r in res.sides.items():
        assert c[-1] < r.markers.hands.n_frames - 1
        sides[s] = replace(r, hands_frame=r.markers.spaces.common_to_hands(c))
    out = tempo_markers(sides)
    for s, mk in out.items():
        assert mk.body.blur.shape == (n,) and mk.hands.blur.shape == (mk.hands.n_frames,)
        np.testing.assert_allclose(mk.body.blur[: half - edge], np.sqrt(3.0), atol=1e-3)
        np.testing.assert_allclose(mk.body.blur[half + edge:], 0.0, atol=1e-3)
        late = slice(int(c[half + edge]), int(c[-1]))
        np.testing.assert_allclose(mk.hands.blur[late], 0.75, atol=1e-3)
        np.testing.assert_allclose(mk.hands.blur[: int(c[half - edge])], 0.0, atol=1e-3)
        # the rest of the markers as they were
        assert np.array_equal(mk.body.points, res.sides[s].markers.body.points) and mk.spaces is res.sides[s].markers.spaces
