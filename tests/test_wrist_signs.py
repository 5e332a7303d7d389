"""Pass 1's position term reads the hand's turning in the forearm's frame (0.29.0).

:func:`splicer.align.costs.wrist_sign_features` (worked answers and a slow reference),
:func:`splicer.align.costs.position_features` with them, the position kernel against a slow
reference for any number of columns, where the signs are switched on
(:func:`splicer.stages.align.wrist_signs_compare`) and that only pass 1's DTW at the body's rate
reads them, its uncovered penalty taken from its own costs.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import splicer.defaults as D
from splicer.align.band import make_band
from splicer.align.costs import d1_cost, phase_features, position_features, wrist_sign_features
from splicer.align.wrist import ANATOMICAL, STYLOID, hand_in_forearm
from splicer.filters import gaussian_filter1d
from splicer.rig.markers import Markers


def _turning(angle: np.ndarray, fps: float = 30.0, *, shoulder_wave: float = 0.0) -> Markers:
    """Markers whose hand turns by ``angle`` (radians) in the forearm's x-z plane; the forearm along
    x, the wrist's width along y; the arm swings sideways by ``shoulder_wave`` (moves every
    marker alike: the hand does not turn in the forearm)."""
    n = len(angle)
    p = np.zeros((n, 4, 3))
    p[:, 0, 1], p[:, 1, 1], p[:, 2, 0] = 0.03, -0.03, 0.25
    p[:, 3, 0], p[:, 3, 2] = -0.08 * np.cos(angle), 0.08 * np.sin(angle)
    p += (shoulder_wave * np.sin(np.arange(n) / fps * 7.0))[:, None, None] * np.array([0.0, 1.0, 0.0])
    p[:, :, 1] += 1.4  # above the shoulder's height: positions are shoulder-relative anyway
    return Markers(p, np.zeros((n, 3)), np.zeros(n), 1, fps, "right")


def _slow_signs(points, fps, smooth_s, ramp):
    """The definition, one component and frame at a time."""
    d = hand_in_forearm(points)
    if smooth_s > 0:
        d = gaussian_filter1d(d, smooth_s * fps, axis=0, mode="nearest")
    n = len(d)
    out = np.zeros((n, 3))
    for k in range(3):
        v = [(d[min(t + 1, n - 1), k] - d[max(t - 1, 0), k]) / (2.0 if 0 < t < n - 1 else 1.0) for t in range(n)]
        rms = np.sqrt(np.mean(np.square(v)))
        for t in range(n):
            out[t, k] = 0.0 if rms == 0 else max(-1.0, min(1.0, v[t] / (ramp * rms)))
    return out


def test_signs_worked():
    # the hand turns one way for a second, then back: z (the hand's component across the forearm's
    # plane) and x (along the forearm, -cos of the angle) rise then fall; y (the wrist's width) never moves
    t = np.arange(60) / 30.0
    s = wrist_sign_features(_turning(np.where(t < 1.0, t, 2.0 - t)), smooth_s=0.0, ramp=0.3)
    assert s.shape == (60, 3)
    assert s[10, 2] == 1.0 and s[50, 2] == -1.0
    assert s[10, 0] == 1.0 and s[50, 0] == -1.0
    np.testing.assert_array_equal(s[:, 1], 0.0)
    # a ramp: velocities under ramp x the RMS are graded, not full signs
    slow = wrist_sign_features(_turning(0.3 * np.sin(2 * np.pi * t)), smooth_s=0.0, ramp=1.0)
    assert 0.0 < np.abs(slow[:, 2]).min() + 1e-12 and np.abs(slow[:, 2]).max() == 1.0
    assert ((np.abs(slow[:, 2]) > 0.05) & (np.abs(slow[:, 2]) < 0.95)).any()


def test_signs_against_the_slow_reference():
    rng = np.random.default_rng(3)
    ang = np.cumsum(rng.normal(0.0, 0.05, 90))
    mk = _turning(ang, shoulder_wave=0.05)
    for smooth_s, ramp in ((0.0, 0.3), (0.05, 0.3), (0.1, 1.0)):
        np.testing.assert_allclose(wrist_sign_features(mk, smooth_s=smooth_s, ramp=ramp),
                                   _slow_signs(mk.points, mk.fps, smooth_s, ramp), rtol=0, atol=1e-12)
    # the defaults are splicer.defaults'
    np.testing.assert_array_equal(wrist_sign_features(mk), wrist_sign_features(mk, smooth_s=D.WRIST_SIGN_SMOOTH_S,
                                                                                ramp=D.WRIST_SIGN_RAMP))


def test_signs_ignore_the_arm_moving_as_a_whole():
    # every marker moved alike (a shoulder's or elbow's swing in a second performance): the hand
    # does not turn in the forearm, and its signs are those of the still arm
    t = np.arange(90) / 30.0
    ang = 0.4 * np.sin(2 * np.pi * 0.7 * t)
    np.testing.assert_allclose(wrist_sign_features(_turning(ang, shoulder_wave=0.2)),
                               wrist_sign_features(_turning(ang)), atol=1e-9)
    still = wrist_sign_features(_turning(np.zeros(90), shoulder_wave=0.2))
    np.testing.assert_array_equal(still, 0.0)


def test_signs_refuse_bad_settings_and_short_takes():
    mk = _turning(np.zeros(10))
    for kw in ({"smooth_s": -1.0}, {"ramp": 0.0}, {"ramp": np.nan}):
        with pytest.raises(ValueError):
            wrist_sign_features(mk, **kw)
    one = _turning(np.zeros(1))
    assert wrist_sign_features(one).shape == (1, 3) and not wrist_sign_features(one).any()


def test_position_features_append_the_signs(monkeypatch):
    t = np.arange(90) / 30.0
    mk = _turning(0.4 * np.sin(2 * np.pi * 0.7 * t), shoulder_wave=0.1)
    plain = position_features(mk)
    both = position_features(mk, wrist_signs=True)
    assert plain.shape == (90, 9) and both.shape == (90, 12)
    np.testing.assert_array_equal(both[:, :9], plain)
    np.testing.assert_array_equal(both[:, 9:], D.WRIST_SIGN_SCALE * wrist_sign_features(mk))
    assert both.flags.c_contiguous
    f = phase_features(mk, position=True, wrist_signs=True)
    np.testing.assert_array_equal(f.position, both)
    monkeypatch.setattr(D, "WRIST_SIGN_SCALE", 0.0)  # switched off: the nine coordinates alone
    assert position_features(mk, wrist_signs=True).shape == (90, 9)
    # a take that never moves: zeros, as many columns as asked for
    monkeypatch.setattr(D, "WRIST_SIGN_SCALE", 2.0)
    still = _turning(np.zeros(20))
    assert position_features(still, wrist_signs=True).shape == (20, 12) and not position_features(still, wrist_signs=True).any()


def test_position_term_against_the_slow_reference():
    """The term the kernel adds: weight x the mean squared difference over the columns, any number
    of them (nine positions, or twelve with the signs)."""
    rng = np.random.default_rng(7)
    t = np.arange(40) / 30.0
    b = phase_features(_turning(0.4 * np.sin(5 * t), shoulder_wave=0.1), position=True, wrist_signs=True)
    h = phase_features(_turning(0.3 * np.sin(4 * t + 0.5) + 0.01 * rng.normal(size=40), shoulder_wave=0.07),
                       position=True, wrist_signs=True)
    band = make_band(40, 40, 8.0)
    for cols in (9, 12):
        bb = type(b)(**{**b.__dict__, "position": np.ascontiguousarray(b.position[:, :cols])})
        hh = type(h)(**{**h.__dict__, "position": np.ascontiguousarray(h.position[:, :cols])})
        w = 2.5
        with_term, without = d1_cost(bb, hh, position_weight=w)(band, 0, 40), d1_cost(bb, hh)(band, 0, 40)
        for i in range(40):  # each row's own cells (the chunk is padded to the widest row)
            for c in range(band.hi[i] - band.lo[i] + 1):
                j = band.lo[i] + c
                want = w * np.mean((bb.position[i] - hh.position[j]) ** 2)
                assert with_term[i, c] - without[i, c] == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_position_columns_must_match():
    t = np.arange(30) / 30.0
    b = phase_features(_turning(np.sin(5 * t)), position=True, wrist_signs=True)
    h = phase_features(_turning(np.sin(4 * t)), position=True)
    with pytest.raises(ValueError, match="same wrist_signs"):
        d1_cost(b, h, position_weight=1.0)
    d1_cost(b, h)  # without the term the columns are not read


def test_wrist_signs_compare(monkeypatch):
    from splicer.stages.align import wrist_signs_compare

    t = np.arange(60) / 30.0
    moving = _turning(0.4 * np.sin(2 * np.pi * t)).points
    still = _turning(np.zeros(60)).points

    def side(placed, body=moving, hands=moving):
        return SimpleNamespace(placed=placed, body=SimpleNamespace(points=body), hands=SimpleNamespace(points=hands))

    assert wrist_signs_compare(side((ANATOMICAL, ANATOMICAL)))
    assert wrist_signs_compare(side((STYLOID, STYLOID)))
    # placed differently (the refinement turns one onto the other; the signs are components, so not here)
    assert not wrist_signs_compare(side(("optical", ANATOMICAL)))
    # ... but virtual wrist markers on the styloids are placed as optical ones are (0.31.0)
    assert wrist_signs_compare(side((STYLOID, "optical"))) and wrist_signs_compare(side(("optical", STYLOID)))
    assert not wrist_signs_compare(side((ANATOMICAL, STYLOID)))
    assert not wrist_signs_compare(side((ANATOMICAL, ANATOMICAL), hands=still))  # a hand that never turns
    gap = moving.copy()
    gap[5, 3] = np.nan
    assert not wrist_signs_compare(side((ANATOMICAL, ANATOMICAL), body=gap))
    monkeypatch.setattr(D, "WRIST_SIGN_SCALE", 0.0)
    assert not wrist_signs_compare(side((ANATOMICAL, ANATOMICAL)))


def _pair(n=300, m=330, seed=0):
    """A body and a hands take of one turning-and-swinging performance, the hands re-timed."""
    rng = np.random.default_rng(seed)
    fps = 30.0
    tb = np.arange(n) / fps
    th = np.linspace(0.0, tb[-1], m) ** 1.05 / tb[-1] ** 0.05
    f = lambda x: 0.5 * np.sin(2.1 * x) + 0.3 * np.sin(3.3 * x + 1.0)  # noqa: E731
    body = _turning(f(tb), fps, shoulder_wave=0.1)
    hands = _turning(f(th) + 0.002 * rng.normal(size=m), fps, shoulder_wave=0.1)
    return body, hands


def test_pass1_reads_the_signs_at_the_body_rate_only(monkeypatch):
    import splicer.align.passes as P

    body, hands = _pair()
    seen = []
    real = P.phase_features

    def spy(markers, **kw):
        seen.append((markers.fps, kw.get("position"), kw.get("wrist_signs")))
        return real(markers, **kw)

    monkeypatch.setattr(P, "phase_features", spy)
    p = P.pass1(body, hands, width=60.0, position_weight=3.0, wrist_signs=True, coarse_fps=10.0)
    assert p.wrist_signs and p.position_weight == 3.0
    assert {(f, w) for f, _, w in seen} == {(10.0, False), (30.0, True)}  # the coarse guide without them
    # open ends: the locating level (10 fps) without, the full-rate pass with them, its uncovered
    # penalty from its own costs
    seen.clear()
    po = P.pass1(body, hands, width=60.0, position_weight=3.0, wrist_signs=True, ends="open")
    assert po.wrist_signs and {(f, w) for f, _, w in seen} == {(10.0, False), (30.0, True)}
    feats = [tuple(real(x, position=True, wrist_signs=True) for x in (body, hands))]
    want = P.uncovered_penalty(P._arm_samples([P.Arm(body, hands, position_weight=3.0, wrist_signs=True)], feats,
                                              "window")[0], P.UNCOVERED_QUANTILE)
    assert po.uncovered_cost == pytest.approx(want) and po.uncovered_cost != po.located.uncovered_cost
    # without a position weight there is no term to read them: as before
    seen.clear()
    p0 = P.pass1(body, hands, width=60.0, position_weight=0.0, wrist_signs=True, ends="open")
    assert not p0.wrist_signs and p0.uncovered_cost == p0.located.uncovered_cost
    monkeypatch.setattr(D, "WRIST_SIGN_SCALE", 0.0)
    assert not P.pass1(body, hands, width=60.0, position_weight=3.0, wrist_signs=True).wrist_signs


def test_the_arms_resampled_for_a_coarser_level_drop_the_signs():
    import splicer.align.passes as P

    body, hands = _pair(n=120, m=130)
    arms = [P.Arm(body, hands, position_weight=3.0, wrist_signs=True)]
    coarse = P._resampled(arms, 10.0)
    assert not coarse[0].wrist_signs and coarse[0].position_weight == 3.0 and coarse[0].body.fps == 10.0


# ---- optical markers: the signs alone (0.31.0) ----

def test_position_features_without_coordinates_are_the_signs_alone():
    t = np.arange(90) / 30.0
    mk = _turning(0.4 * np.sin(2 * np.pi * 0.7 * t), shoulder_wave=0.1)
    only = position_features(mk, wrist_signs=True, coordinates=False)
    assert only.shape == (90, 3) and only.flags.c_contiguous
    np.testing.assert_array_equal(only, position_features(mk, wrist_signs=True)[:, 9:])
    np.testing.assert_array_equal(phase_features(mk, position=True, wrist_signs=True, coordinates=False).position, only)
    with pytest.raises(ValueError, match="need the hand-in-forearm signs"):
        position_features(mk, coordinates=False)


def test_the_signs_alone_against_the_slow_reference():
    """Weight w on the three sign columns alone adds w x their mean squared difference: the same as
    4w on the twelve columns with the nine coordinates zeroed (how the weight was chosen)."""
    t = np.arange(40) / 30.0
    b = phase_features(_turning(0.4 * np.sin(5 * t), shoulder_wave=0.1), position=True, wrist_signs=True,
                       coordinates=False)
    h = phase_features(_turning(0.3 * np.sin(4 * t + 0.5), shoulder_wave=0.07), position=True, wrist_signs=True,
                       coordinates=False)
    band = make_band(40, 40, 8.0)
    w = D.OPTICAL_SIGN_WEIGHT
    with_term, without = d1_cost(b, h, position_weight=w)(band, 0, 40), d1_cost(b, h)(band, 0, 40)
    pad = lambda f: type(f)(**{**f.__dict__, "position": np.ascontiguousarray(  # noqa: E731
        np.concatenate([np.zeros((len(f.position), 9)), f.position], axis=1))})
    twelve = d1_cost(pad(b), pad(h), position_weight=4 * w)(band, 0, 40)
    for i in range(40):
        for c in range(band.hi[i] - band.lo[i] + 1):
            j = band.lo[i] + c
            want = w * np.sum((b.position[i] - h.position[j]) ** 2) / 3.0
            assert with_term[i, c] - without[i, c] == pytest.approx(want, rel=1e-9, abs=1e-12)
            assert twelve[i, c] == pytest.approx(with_term[i, c], rel=1e-12, abs=1e-12)


def test_pass1_with_the_signs_alone():
    import splicer.align.passes as P

    body, hands = _pair()
    p = P.pass1(body, hands, width=60.0, position_weight=1.25, wrist_signs=True, coordinates=False, ends="open")
    assert p.wrist_signs and p.position_weight == 1.25
    # the locating level has no signs, so no position term at all: D1 alone there
    d1_only = P.pass1(body, hands, width=60.0, ends="open")
    assert p.located.uncovered_cost == pytest.approx(d1_only.located.uncovered_cost)
    np.testing.assert_array_equal(p.located.path, d1_only.located.path)
    with pytest.raises(ValueError, match="needs the hand-in-forearm signs"):
        P.pass1(body, hands, width=60.0, position_weight=1.25, coordinates=False)
    # an arm without coordinates at a coarser rate: no term (nothing left to compare)
    arm = P.Arm(body, hands, position_weight=1.25, wrist_signs=True, coordinates=False)
    assert arm.coarser(10.0).position_weight == 0.0
    assert P.Arm(body, hands, position_weight=3.0, wrist_signs=True).coarser(10.0).position_weight == 3.0


def test_position_weights_of_optical_markers():
    from splicer.options import SpliceOptions
    from splicer.stages.align import position_coordinates, position_weights

    t = np.arange(60) / 30.0
    moving = _turning(0.4 * np.sin(2 * np.pi * t)).points

    def side(placed, real=True, hand_only=False):
        return SimpleNamespace(placed=placed, real={"hands": {}} if real else {}, hand_only=hand_only,
                               body=SimpleNamespace(points=moving), hands=SimpleNamespace(points=moving))

    auto, three = SpliceOptions(), SpliceOptions(position_weight=3.0)
    both = side(("optical", "optical"))
    assert position_weights(auto, both, False) == (D.OPTICAL_SIGN_WEIGHT, D.OPTICAL_SIGN_WEIGHT)
    assert position_weights(auto, both, True) == (D.OPTICAL_SIGN_WEIGHT, D.OPTICAL_SIGN_WEIGHT)
    assert position_weights(three, both, False) == (3.0, 3.0)  # a number weighs the signs
    assert not position_coordinates(both)
    # optical hands against the body's virtual markers on the styloids (placed as optical ones are): the signs
    assert position_weights(auto, side((STYLOID, "optical")), False) == (D.OPTICAL_SIGN_WEIGHT,) * 2
    assert position_weights(three, side(("optical", STYLOID)), False) == (3.0, 3.0)
    # ... across the palm: placed differently, the signs do not compare, and there is no other term
    assert position_weights(auto, side(("optical", ANATOMICAL)), False) == (0.0, 0.0)
    assert position_weights(three, side((ANATOMICAL, "optical")), False) == (0.0, 0.0)
    # virtual markers as before
    virtual = side((ANATOMICAL, ANATOMICAL), real=False)
    assert position_coordinates(virtual)
    assert position_weights(auto, virtual, False) == (D.POSITION_WEIGHT, 0.0)
    assert position_weights(auto, virtual, True) == (D.POSITION_WEIGHT_NOISY, D.POSITION_WEIGHT_NOISY)
    assert position_weights(auto, side((ANATOMICAL, ANATOMICAL), real=False, hand_only=True), False) == (0.0, 0.0)
