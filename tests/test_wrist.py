"""The wrist's refinement of the time map (splicer.align.wrist, stage refine_time_maps)."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from splicer.align.wrist import ANATOMICAL as W_ANATOMICAL, STYLOID as W_STYLOID
from splicer.align.wrist import (comparable_placements, expected_offsets, hand_in_forearm, offset_costs, offset_posterior,
                                 rate_mismatch, refine_map, turn_onto)


def _slow_posterior(e, step, lam, max_step, temperature):
    """Every path enumerated for tiny inputs, weighed exp(-cost / temperature): each row's posterior."""
    n, S = e.shape
    post = np.zeros((n, S))
    for path in itertools.product(range(S), repeat=n):
        full = (S // 2,) + path  # the path starts from the middle column (offset 0), its first move any size
        if any(abs(full[t] - full[t - 1]) > max_step for t in range(2, n + 1)):
            continue
        c = sum(e[t, path[t]] for t in range(n)) + sum(lam * ((full[t] - full[t - 1]) * step) ** 2 for t in range(1, n + 1))
        w = np.exp(-c / temperature)
        for t in range(n):
            post[t, path[t]] += w
    return post / post.sum(axis=1, keepdims=True)


def test_hand_in_forearm_worked_answer():
    # wrist centre at the origin, forearm marker along +x, wrist width along +y (z = x × y = +z)
    p = np.array([[[0.0, 1, 0], [0, -1, 0], [5, 0, 0], [-3, 0, 4]]])
    np.testing.assert_allclose(hand_in_forearm(p), [[-0.6, 0.0, 0.8]])
    # the same arm turned and moved as a whole: the same components
    a = 0.7
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    np.testing.assert_allclose(hand_in_forearm(p @ rot.T * 3.0 + [1, 2, 3]), [[-0.6, 0.0, 0.8]], atol=1e-12)
    # a wrist width not orthogonal to the forearm is made so
    q = p.copy()
    q[0, 0] = [2.0, 1.0, 0.0]
    q[0, 1] = [-2.0, -1.0, 0.0]
    assert np.all(np.isfinite(hand_in_forearm(q)))
    # coincident markers: zeros, not NaN
    assert np.array_equal(hand_in_forearm(np.zeros((2, 4, 3))), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"\(T, 4, 3\)"):
        hand_in_forearm(np.zeros((3, 3, 3)))


@pytest.mark.parametrize("seed", range(8))
def test_expected_offsets_against_enumeration(seed):
    rng = np.random.default_rng(seed)
    n, S = int(rng.integers(1, 6)), int(rng.choice([1, 3, 5]))
    e = 3.0 * rng.random((n, S))
    offsets = (np.arange(S) - S // 2) * 0.25
    step, lam, max_step = 0.25, float(rng.choice([0.0, 3.0, 40.0])), int(rng.integers(0, 3))
    temperature = float(rng.choice([0.5, 1.0, 2.0]))
    got = expected_offsets(e, offsets, step=step, lam=lam, max_step=max_step, temperature=temperature)
    post = _slow_posterior(e, step, lam, max_step, temperature)
    np.testing.assert_allclose(got, post @ offsets, rtol=1e-9, atol=1e-12)
    mean, sd = offset_posterior(e, offsets, step=step, lam=lam, max_step=max_step, temperature=temperature)
    np.testing.assert_array_equal(mean, got)
    np.testing.assert_allclose(sd, np.sqrt(post @ offsets ** 2 - (post @ offsets) ** 2), rtol=1e-7, atol=1e-9)


def test_expected_offsets_worked_answers():
    # one row, two... three columns, no penalty: the posterior is softmax(-e)
    got = expected_offsets(np.array([[np.log(3.0), 0.0, 50.0]]), np.array([-1.0, 0.0, 1.0]), lam=0.0, max_step=1)
    np.testing.assert_allclose(got, [-0.25], atol=1e-12)  # weights 1/4, 3/4, ~0
    # its standard deviation: sqrt(1/4 * 1 + 3/4 * 0 - 1/16) = sqrt(3) / 4
    _, sd = offset_posterior(np.array([[np.log(3.0), 0.0, 50.0]]), np.array([-1.0, 0.0, 1.0]), lam=0.0, max_step=1)
    np.testing.assert_allclose(sd, [np.sqrt(3.0) / 4], atol=1e-12)
    # one column: nothing to doubt
    assert offset_posterior(np.ones((3, 1)), np.zeros(1))[1].tolist() == [0.0, 0.0, 0.0]
    # nothing to go by (all costs equal): symmetric about the middle, the expected offset 0
    offsets = (np.arange(9) - 4) * 0.25
    np.testing.assert_allclose(expected_offsets(np.zeros((6, 9)), offsets), 0.0, atol=1e-12)
    # a clear dip at the edge is reached when it is worth the steps, and the mean follows it
    e = np.full((12, 9), 4.0)
    e[:, 8] = 0.0
    assert np.all(expected_offsets(e, offsets)[4:] > 0.9)
    with pytest.raises(ValueError, match="finite"):
        expected_offsets(np.array([[np.nan]]), np.zeros(1))
    with pytest.raises(ValueError, match="temperature"):
        expected_offsets(np.ones((2, 3)), np.zeros(3), temperature=0.0)
    with pytest.raises(ValueError, match="offsets"):
        expected_offsets(np.ones((2, 3)), np.zeros(2))


def test_offset_costs_against_a_slow_reference():
    rng = np.random.default_rng(5)
    vb, vh = rng.normal(size=(50, 3)), rng.normal(size=(80, 3))
    c, slope, offsets = np.linspace(-3, 85, 50), rng.random(50) + 0.5, np.arange(-4, 5) * 0.25  # past both ends too
    want = np.empty((50, 9))
    for t in range(50):
        for s, o in enumerate(offsets):
            w = min(max(c[t] + o, 0.0), 79.0)
            h = np.array([np.interp(w, np.arange(80.0), vh[:, q]) for q in range(3)])
            want[t, s] = np.sum((vb[t] - slope[t] * h) ** 2)
    got = offset_costs(vb, vh, c, slope, offsets)
    np.testing.assert_allclose(got * np.median(want), want, rtol=1e-12)  # returned divided by the median


def _arm(frames: np.ndarray) -> np.ndarray:
    """Markers of an arm whose hand swings in the forearm's frame: p1, p2, p3 fixed, p4 moving."""
    a = 0.6 * np.sin(frames / 4.0) + 0.3 * np.sin(frames / 11.0)
    b = 0.4 * np.cos(frames / 6.0)
    p = np.zeros((len(frames), 4, 3))
    p[:, 0] = [0.0, 1.0, 0.0]
    p[:, 1] = [0.0, -1.0, 0.0]
    p[:, 2] = [-10.0, 0.0, 0.0]
    p[:, 3] = np.stack([np.cos(a) * np.cos(b), np.sin(b), np.sin(a) * np.cos(b)], axis=1) * 3.0
    return p


def test_refine_map_recovers_a_shift():
    fps = 30.0
    m = 400
    hands = _arm(np.arange(m, dtype=float))
    truth = 50.0 + 1.2 * np.arange(250)  # body frame i shows hands frame 50 + 1.2 i
    body = _arm(truth)
    wrong = truth + 3.0  # three frames late everywhere
    fit = refine_map(body, hands, wrong, fps=fps, radius_s=0.25, smooth_s=0.05, offset_smooth_s=1 / 3, slope_s=0.5)
    refined, d = fit.refined, fit.offset
    # the path starts from the map (a 3-frame move costs 90 at the first frame), so the expected
    # offset reaches the truth over the first second and a half; measured 0.044 frames at most past it
    inner = slice(50, -30)
    assert np.max(np.abs(refined[inner] - truth[inner])) < 0.1
    assert np.all(np.abs(refined - truth) < 3.0)  # never further than the map it started from
    assert np.all(np.diff(refined) >= 0)
    np.testing.assert_allclose(d[inner], -3.0, atol=0.1)
    # radius 0, or too few frames: unchanged
    same = refine_map(body, hands, wrong, fps=fps, radius_s=0.0, smooth_s=0.05, offset_smooth_s=0.3, slope_s=0.5)
    assert np.array_equal(same.refined, wrong) and not same.offset.any() and not same.sd.any()
    with pytest.raises(ValueError, match="finite"):
        refine_map(body, hands, np.where(np.arange(250) == 5, np.nan, wrong), fps=fps, radius_s=0.25, smooth_s=0.05,
                   offset_smooth_s=0.3, slope_s=0.5)


def test_rate_mismatch_worked():
    fps = 30.0
    hands = _arm(np.arange(400, dtype=float))
    truth = 50.0 + np.arange(250)  # body frame i shows hands frame 50 + i
    body = _arm(truth)
    right = rate_mismatch(body, hands, truth, fps=fps, smooth_s=0.05)
    late = rate_mismatch(body, hands, truth + 3.0, fps=fps, smooth_s=0.05)
    assert right < 0.01  # the same motion (measured 0.0027: the body's smoothing meets its ends)
    assert late > 0.3 and late > 100 * right  # three frames late: the rates part (measured 0.55; one frame 0.067)
    # the same hand turned as a whole in the hands take (markers placed a little differently): no matter
    a = 0.4
    rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    assert rate_mismatch(body, hands @ rot.T, truth, fps=fps, smooth_s=0.05) == pytest.approx(right, abs=1e-9)
    # nothing to compare: NaN; a map that is not a number: an error
    assert np.isnan(rate_mismatch(body[:2], hands, truth[:2], fps=fps, smooth_s=0.05))
    still = np.repeat(body[:1], 250, axis=0)
    assert np.isnan(rate_mismatch(still, hands, truth, fps=fps, smooth_s=0.05))
    with pytest.raises(ValueError, match="finite"):
        rate_mismatch(body, hands, np.where(np.arange(250) == 7, np.nan, truth), fps=fps, smooth_s=0.05)


def test_refine_map_leaves_a_right_map_alone():
    fps = 30.0
    hands = _arm(np.arange(300, dtype=float))
    truth = 20.0 + np.arange(200) * 0.9
    refined = refine_map(_arm(truth), hands, truth, fps=fps, radius_s=0.25, smooth_s=0.05, offset_smooth_s=1 / 3,
                         slope_s=0.5).refined
    err = np.abs(refined - truth)
    assert err[:-30].max() < 0.05 and err.max() < 0.35  # measured 0.033 and 0.28 at the last frame (the body's last frame is differenced one-sided)


# ---------------------------------------------------------------- the stage, on the bundled sample

def _slow_local_rate_mismatch(body, hands, c, fps, smooth_s, window_s):
    """The reference: every window's own Kabsch (turn_onto) and sums, one frame at a time."""
    from splicer.align.wrist import _direction, turn_onto
    from splicer.transfer.sampling import sample_linear

    xb = _direction(body, smooth_s, fps)
    xh = sample_linear(_direction(hands, smooth_s, fps), c)
    vb, vh = np.gradient(xb, axis=0), np.gradient(xh, axis=0)
    half = max(1, int(round(window_s * fps / 2.0)))
    out = np.full(len(c), np.nan)
    for t in range(len(c)):
        sl = slice(max(t - half, 0), min(t + half + 1, len(c)))
        r = turn_onto(xh[sl], xb[sl])
        e = np.sum(vb[sl] ** 2)
        if e > 0:
            out[t] = np.sum((vb[sl] - vh[sl] @ r.T) ** 2) / e
    return out


def test_local_rate_mismatch_against_the_slow_reference():
    from splicer.align.wrist import local_rate_mismatch

    fps = 30.0
    rng = np.random.default_rng(3)
    hands = _arm(np.arange(300, dtype=float)) + rng.normal(0.0, 0.02, (300, 4, 3))
    c = 20.0 + np.cumsum(rng.uniform(0.5, 1.5, 200))  # a wandering map
    body = _arm(c + rng.normal(0.0, 1.0, 200))
    for window_s in (0.1, 1.0, 3.0, 20.0):
        fast = local_rate_mismatch(body, hands, c, fps=fps, smooth_s=0.05, window_s=window_s)
        np.testing.assert_allclose(fast, _slow_local_rate_mismatch(body, hands, c, 30.0, 0.05, window_s), rtol=1e-9,
                                   atol=1e-12)


def test_local_rate_mismatch_worked():
    """Right along the first half, three frames late along the second: the windows say where."""
    from splicer.align.wrist import local_rate_mismatch

    fps = 30.0
    hands = _arm(np.arange(400, dtype=float))
    truth = 50.0 + np.arange(250)
    body = _arm(truth)
    c = truth + np.where(np.arange(250) < 125, 0.0, 3.0)
    m = local_rate_mismatch(body, hands, c, fps=fps, smooth_s=0.05, window_s=1.0)
    assert m.shape == (250,)
    assert np.all(m[20:105] < 0.01) and np.all(m[145:240] > 0.3)  # a window: 15 frames each side of a frame
    # the whole map in one window: rate_mismatch's figure (up to the smoothing at the window's ends)
    whole = local_rate_mismatch(body, hands, truth, fps=fps, smooth_s=0.05, window_s=1000.0)
    assert np.allclose(whole, whole[0]) and whole[0] == pytest.approx(rate_mismatch(body, hands, truth, fps=fps,
                                                                                     smooth_s=0.05), abs=1e-3)
    # windows the body's hand moves in less than min_motion of the median window's motion: NaN
    assert np.isfinite(m).all()
    half = local_rate_mismatch(body, hands, c, fps=fps, smooth_s=0.05, window_s=1.0, min_motion=1.0)
    assert 0.3 < np.isnan(half).mean() < 0.7 and np.array_equal(half[~np.isnan(half)], m[~np.isnan(half)])
    assert np.isnan(local_rate_mismatch(body, hands, c, fps=fps, smooth_s=0.05, window_s=1.0, min_motion=10.0)).all()
    with pytest.raises(ValueError, match="min_motion"):
        local_rate_mismatch(body, hands, c, fps=fps, smooth_s=0.05, window_s=1.0, min_motion=-1.0)
    # a hand still in its forearm: NaN; bad arguments: errors
    still = np.repeat(body[:1], 250, axis=0)
    assert np.isnan(local_rate_mismatch(still, hands, truth, fps=fps, smooth_s=0.05, window_s=1.0)).all()
    with pytest.raises(ValueError, match="finite"):
        local_rate_mismatch(body, hands, np.where(np.arange(250) == 7, np.nan, truth), fps=fps, smooth_s=0.05,
                            window_s=1.0)
    with pytest.raises(ValueError, match="positive"):
        local_rate_mismatch(body, hands, truth, fps=fps, smooth_s=0.05, window_s=0.0)
    with pytest.raises(ValueError, match="one map frame per body frame"):
        local_rate_mismatch(body, hands, truth[:-1], fps=fps, smooth_s=0.05, window_s=1.0)


from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import splicer  # noqa: E402
from splicer.options import SpliceOptions  # noqa: E402
from test_trend import sample_stages  # noqa: E402,F401  (the sample's sides before the trend stage)

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


@pytest.fixture(scope="module")
def weighed(sample_stages):
    """The sample's sides after the trend stage, with its four pins (tolerance 2 hands frames)."""
    return splicer.trend_time_maps(sample_stages, SpliceOptions())


def test_stage_switches(weighed):
    for opts in (SpliceOptions(merge="median"), SpliceOptions(wrist_radius_s=0)):
        out = splicer.refine_time_maps(weighed, opts)
        assert all(out[s] is weighed[s] for s in weighed)
    with pytest.raises(splicer.SplicerError, match="wrist_radius_s"):
        splicer.splice(MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh", wrist_radius_s=-1)


def test_stage_holds_every_pin_moves_within_its_radius_and_is_better_on_the_sample(weighed):
    truth = np.loadtxt(MOTIONS / "sample_truth.csv", delimiter=",", skiprows=1, usecols=1)
    out = splicer.refine_time_maps(weighed, SpliceOptions())
    for s, r in out.items():
        tm, before = r.hands_frame, weighed[s].hands_frame
        assert np.all(np.diff(tm) >= 0) and tm.min() >= 0 and tm.max() <= r.markers.spaces.n_hands - 1
        for p in r.pins:
            assert abs(tm[p.body] - p.hands) <= p.tolerance + 1e-9, (s, p)
        radius_hands = 0.25 * r.markers.spaces.hands_fps
        assert 0 < np.max(np.abs(tm - before)) <= radius_hands + 1e-9
        assert r.extra["wrist_shift_frames"] == pytest.approx(np.mean(np.abs(tm - before)), abs=1e-3)
        # the sample's ground truth (hands frame per body frame): closer after the stage
        assert np.mean(np.abs(tm - truth)) < np.mean(np.abs(before - truth)), s
    # what the risk model reads: the offset added and its posterior's spread, seconds, per body frame
    for s, r in out.items():
        assert weighed[s].wrist is None and r.wrist is not None
        sh, sd = r.wrist.shift_s, r.wrist.sd_s
        assert sh.shape == sd.shape == r.hands_frame.shape
        assert np.all(np.isfinite(sh)) and np.all(np.isfinite(sd))  # the sample is covered throughout
        assert np.all(sh >= 0) and np.all(sd >= 0) and sd.max() <= 0.25  # within the radius
        assert sh.max() > 0 and 0 < np.median(sd) < 0.1
        # the shift is the move before the pins and the monotone pass: near the final move, in seconds
        moved = np.abs(r.hands_frame - weighed[s].hands_frame) / r.markers.spaces.hands_fps
        assert np.median(np.abs(sh - moved)) < 0.01
    # without pins the stage still never leaves the hands take
    free = {s: replace(r, markers=replace(r.markers, pins=())) for s, r in weighed.items()}
    for s, r in splicer.refine_time_maps(free, SpliceOptions()).items():
        assert np.all(np.diff(r.hands_frame) >= 0)


def test_stage_rounds_start_where_the_last_left(weighed, monkeypatch):
    """WRIST_ROUNDS rounds where the markers carry no measured noise: each round refines the map
    the last one left, and the evidence the risk model reads is their summed offset and the last
    round's spread; a side with a noise draw (optical markers) gets one round."""
    import splicer.align.wrist as W
    import splicer.defaults as D

    calls = []
    real = W.refine_map

    def counting(body, hands, c, **kw):
        calls.append(np.array(c))
        return real(body, hands, c, **kw)

    monkeypatch.setattr(W, "refine_map", counting)
    monkeypatch.setattr(D, "WRIST_ROUNDS", 1)
    one = splicer.refine_time_maps(weighed, SpliceOptions())
    assert len(calls) == len(weighed)
    calls.clear()
    monkeypatch.setattr(D, "WRIST_ROUNDS", 2)
    two = splicer.refine_time_maps(weighed, SpliceOptions())
    assert len(calls) == 2 * len(weighed)
    for k, s in enumerate(weighed):
        sp, first = weighed[s].markers.spaces, calls[2 * k]
        fit1 = real(weighed[s].markers.body.points[:len(first)], weighed[s].markers.hands.points, first,
                    fps=sp.body_fps, radius_s=D.WRIST_RADIUS_S, smooth_s=D.WRIST_SMOOTH_S,
                    offset_smooth_s=D.WRIST_OFFSET_SMOOTH_S, slope_s=D.WRIST_SLOPE_S)
        np.testing.assert_array_equal(calls[2 * k + 1], fit1.refined)  # round two starts where round one left
        assert not np.array_equal(two[s].hands_frame, one[s].hands_frame)
    calls.clear()
    noisy = {s: replace(r, markers=replace(r.markers, noise={"body": np.zeros_like(r.markers.body.points)}))
             for s, r in weighed.items()}  # a (silent) noise draw: the markers are optical
    assert all(r.markers.placed != ("optical", "optical") for r in noisy.values())
    out = splicer.refine_time_maps(noisy, SpliceOptions())
    assert len(calls) == len(weighed)  # optical markers on one take, virtual ones on the other: one round
    assert all(r.extra["wrist_rounds"] == 1 and r.extra["wrist_noise_share"] == 0.0 for r in out.values())


def test_stage_rounds_stop_once_settled(weighed, monkeypatch):
    """Between WRIST_ROUNDS_MIN and WRIST_ROUNDS rounds: after the first WRIST_ROUNDS_MIN, the
    rounds stop at the first one that moves the map by less than WRIST_SETTLE_S on average (in
    body frames, WRIST_SETTLE_S x the body rate), and the report says how many ran."""
    import splicer.align.wrist as W
    import splicer.defaults as D

    moves = []
    real = W.refine_map

    def recording(*a, **kw):
        fit = real(*a, **kw)
        moves.append(float(np.mean(np.abs(fit.offset))))
        return fit

    monkeypatch.setattr(W, "refine_map", recording)
    monkeypatch.setattr(D, "WRIST_ROUNDS", 6)
    monkeypatch.setattr(D, "WRIST_ROUNDS_MIN", 2)
    monkeypatch.setattr(D, "WRIST_SETTLE_S", 1.0)  # every round settles: the minimum runs
    out = splicer.refine_time_maps(weighed, SpliceOptions())
    assert len(moves) == 2 * len(weighed) and all(r.extra["wrist_rounds"] == 2 for r in out.values())
    moves.clear()
    monkeypatch.setattr(D, "WRIST_SETTLE_S", 0.0)  # none settles: the most run
    out = splicer.refine_time_maps(weighed, SpliceOptions())
    assert len(moves) == 6 * len(weighed) and all(r.extra["wrist_rounds"] == 6 for r in out.values())
    six = {s: r.hands_frame for s, r in out.items()}
    moves.clear()
    settle_s = 1.0 / 300.0  # a tenth of a frame at 30 fps: the sample's sides settle after 3 and 4 rounds
    monkeypatch.setattr(D, "WRIST_SETTLE_S", settle_s)
    out = splicer.refine_time_maps(weighed, SpliceOptions())
    k = 0
    for s, r in out.items():
        n = r.extra["wrist_rounds"]
        mine, k = moves[k:k + n], k + n
        fps = r.markers.spaces.body_fps
        assert 2 <= n <= 6
        assert all(m >= settle_s * fps for m in mine[2 - 1:n - 1])  # each round past the minimum moved enough to go on
        assert n == 6 or mine[-1] < settle_s * fps  # and the last one settled (or the most ran)
        if n < 6:
            assert not np.array_equal(r.hands_frame, six[s])
    assert k == len(moves) and any(2 < r.extra["wrist_rounds"] < 6 for r in out.values())


@pytest.mark.parametrize("placed, quiet_rounds", [(("optical", "optical"), 2), (("optical", W_STYLOID), 2),
                                                  ((W_STYLOID, "optical"), 2), (("optical", W_ANATOMICAL), 1)])
def test_stage_rounds_of_optical_markers_follow_their_noise(weighed, monkeypatch, placed, quiet_rounds):
    """Optical markers get WRIST_ROUNDS rounds where their measured noise makes up less than
    WRIST_ROUNDS_NOISE_SHARE_MAX of the hand's motion relative to the forearm and the other take's
    markers are optical or virtual ones on the styloids; one above, or against virtual markers
    across the palm."""
    import splicer.align.wrist as W
    import splicer.defaults as D

    calls = []
    real = W.refine_map
    monkeypatch.setattr(W, "refine_map", lambda *a, **kw: calls.append(1) or real(*a, **kw))
    monkeypatch.setattr(D, "WRIST_ROUNDS", 2)

    def optical(scale_cm):
        rng = np.random.default_rng(5)
        return {s: replace(r, markers=replace(r.markers, placed=placed,
                                              noise={"body": scale_cm * rng.standard_normal(r.markers.body.points.shape)}))
                for s, r in weighed.items()}

    quiet = splicer.refine_time_maps(optical(1e-4), SpliceOptions())  # a micrometre (the sample is in cm): shares 4e-7, 8e-7
    assert len(calls) == quiet_rounds * len(weighed)
    for s, r in quiet.items():
        assert r.extra["wrist_rounds"] == quiet_rounds and 0.0 < r.extra["wrist_noise_share"] < D.WRIST_ROUNDS_NOISE_SHARE_MAX
    calls.clear()
    jittery = splicer.refine_time_maps(optical(0.02), SpliceOptions())  # 0.2 mm, a fifth of the protocol's least: 0.017, 0.034
    assert len(calls) == len(weighed)
    for s, r in jittery.items():
        assert r.extra["wrist_rounds"] == 1 and r.extra["wrist_noise_share"] > D.WRIST_ROUNDS_NOISE_SHARE_MAX


def test_turn_onto_recovers_a_rotation():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(50, 3))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rot = q * np.sign(np.linalg.det(q))  # proper
    np.testing.assert_allclose(turn_onto(a, a @ rot.T), rot, atol=1e-12)
    np.testing.assert_allclose(turn_onto(a, a), np.eye(3), atol=1e-12)
    assert np.linalg.det(turn_onto(a, -a)) == pytest.approx(1.0)  # a reflection is never returned


def test_comparable_placements():
    full = "p1-p2 index-pinky, p3 elbow, p4 middle"
    assert comparable_placements(full, full)
    assert comparable_placements("optical", full) and comparable_placements(full, "optical")
    assert comparable_placements("optical", "optical")
    assert comparable_placements("optical", W_STYLOID) and comparable_placements(W_STYLOID, "optical")
    assert not comparable_placements(W_STYLOID, full)  # only made against optical markers
    assert not comparable_placements("p1-p2 across-across, p3 elbow, p4 hand", full)  # a body without fingers
    assert not comparable_placements("p1-p2 index-pinky, p3 forearm joint, p4 middle", "optical")
    assert not comparable_placements("", "")
    # a Leap file's virtual forearm (turned with its forearm joint) against the body's real one
    assert comparable_placements(full, "p1-p2 index-pinky, p3 forearm joint, p4 middle")
    assert not comparable_placements("p1-p2 index-pinky, p3 forearm joint, p4 middle", full)  # not the other way
    # a forearm turned with the hand holds no wrist motion, placed alike or not
    wrist_rooted = "p1-p2 index-pinky, p3 hand, p4 middle"
    assert not comparable_placements(wrist_rooted, wrist_rooted)


def test_real_rigs_run_the_stage_only_where_markers_are_placed_alike(shared_motions):
    """Real files: the CMU body's hand has no finger joints of its own kind (its markers come from a
    thumb End Site and the hand's), so against the bundled sample's full hands the stage does not
    run; the ZEGGS body against the same hands does; a Leap (forearm-rooted) hand is placed alike
    against the ZEGGS body, but its forearm joint turns with its hand, so its hand never turns in
    the forearm's frame and the stage has nothing to read (until 0.21.0 it ran and moved nothing);
    a ManipNet (wrist-rooted) one is not placed alike."""
    from splicer.align.wrist import wrist_moves
    from splicer.rig.markers import marker_placement
    from splicer.rig.roles import find_roles

    cases = ((shared_motions / "cmu" / "01_01.bvh", MOTIONS / "sample_hands.bvh", False, False),
             (shared_motions / "zeggs" / "067_Speech_2_x_1_0.bvh", MOTIONS / "sample_hands.bvh", True, True),
             (shared_motions / "zeggs" / "067_Speech_2_x_1_0.bvh", shared_motions / "leap-hands" / "clenching.bvh", True, False),
             (shared_motions / "zeggs" / "067_Speech_2_x_1_0.bvh", shared_motions / "manipnet-hands" / "teapot3_rightHand.bvh",
              False, False))
    for body, hands, alike, runs in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the Leap file's short Frames: line (reported, not the point here)
            r = splicer.splice(body, hands, side="right")
        mk = r.sides["right"].markers
        assert comparable_placements(*mk.placed) is alike, (body.name, hands.name, mk.placed)
        if alike:  # the Leap hand is still in its forearm's frame
            assert wrist_moves(mk.body.points) and wrist_moves(mk.hands.points) is runs
        assert ("wrist_shift_frames" in r.report.to_dict()["sides"]["right"]) is runs, (body.name, hands.name)
    cmu = splicer.read_bvh(shared_motions / "cmu" / "01_01.bvh")
    assert marker_placement(cmu.skeleton, find_roles(cmu.skeleton).sides["right"]) == "p1-p2 thumb*-hand, p3 elbow, p4 hand"


def test_offset_costs_median_over_spread_rows_for_long_takes(monkeypatch):
    import splicer.align.wrist as W

    rng = np.random.default_rng(8)
    vb, vh = rng.normal(size=(400, 3)), rng.normal(size=(500, 3))
    c, slope, offsets = np.linspace(10, 480, 400), np.ones(400), np.arange(-2, 3) * 0.25
    raw = offset_costs(vb, vh, c, slope, offsets) * 1.0
    monkeypatch.setattr(W, "_MEDIAN_CELLS", 100)  # 2,000 cells: every 20th row
    got = offset_costs(vb, vh, c, slope, offsets)
    # the same costs up to one scale, now the median of rows 0, 20, 40, ... instead of all rows
    ratio = got / raw
    assert np.allclose(ratio, ratio.flat[0])
    np.testing.assert_allclose(np.median(got[::20]), 1.0)
    assert abs(np.median(got) - 1.0) > 1e-6  # not the median of every cell


def test_stage_leaves_a_side_with_unreadable_markers(weighed):
    """A marker that is not a number anywhere (a broken optical file past the gap filling): the
    side keeps its map rather than failing the splice."""
    s, r = next(iter(weighed.items()))
    pts = np.array(r.markers.hands.points)
    pts[5, 3, 0] = np.nan
    bad_hands = type(r.markers.hands)(pts, r.markers.hands.shoulder, r.markers.hands.heading, r.markers.hands.up,
                                      r.markers.hands.fps, r.markers.hands.side)
    broken = {s: replace(r, markers=replace(r.markers, hands=bad_hands))}
    assert splicer.refine_time_maps(broken, SpliceOptions())[s] is broken[s]


def test_a_wrist_that_never_turns_holds_nothing_to_read():
    """wrist_moves: a hand fixed in its forearm's frame (the forearm carried with the hand, as the
    Leap clips' forearm joint is) reads as no wrist motion, and markers_compare refuses it; the
    same markers with the hand swinging read as motion (worked answers)."""
    from splicer.align.wrist import ANATOMICAL, STILL_WRIST, markers_compare, wrist_moves

    t = np.arange(200)
    q = np.stack([np.cos(t / 20.0), np.sin(t / 20.0), np.zeros(len(t))], axis=1)  # the whole arm turning about z
    rigid = np.stack([q * 0.0 + [0.0, 0.0, 1.0], q * 0.0 - [0.0, 0.0, 1.0], -10.0 * q, 3.0 * q], axis=1)
    assert not wrist_moves(rigid)  # the hand keeps its direction in the (turning) forearm's frame
    moving = rigid.copy()
    moving[:, 3] += np.stack([np.zeros(len(t)), np.zeros(len(t)), 0.5 * np.sin(t / 7.0)], axis=1)
    assert wrist_moves(moving) and np.max(np.std(hand_in_forearm(moving), axis=0)) > 1e3 * STILL_WRIST
    assert markers_compare((ANATOMICAL, ANATOMICAL), moving, moving)
    assert not markers_compare((ANATOMICAL, ANATOMICAL), moving, rigid)
    assert not wrist_moves(moving[:1])  # one frame: nothing to read


# ---------------------------------------------------------------- where the body holds still (0.29.0)

def _held_body(truth: np.ndarray, hold: slice) -> np.ndarray:
    """The body's arm along ``truth``, its hand frozen over ``hold`` (the body performer holds)."""
    body = _arm(truth)
    body[hold] = body[hold.start - 1]
    return body


def test_refine_map_reads_nothing_where_the_body_holds_still():
    """A body that holds for 1.5 s while the hands go on: the true map is flat there.  Reading
    the hold, the refinement matches the still hand to wherever the hands move least and drifts
    off the flat map; told the hold (``still``), it carries the offset across it by the offset
    path's smoothness, and the map stays flat within a tenth of a frame (worked: the map is right
    before and after the hold, so the offset is 0 on both sides)."""
    fps = 30.0
    hands = _arm(np.arange(400, dtype=float))
    idx = np.arange(250, dtype=float)
    hold = slice(100, 145)
    truth = 50.0 + idx
    truth[hold] = truth[hold.start - 1]
    truth[hold.stop:] -= hold.stop - hold.start  # the body resumes where it held
    body = _held_body(truth, hold)
    kw = dict(fps=fps, radius_s=0.25, smooth_s=0.05, offset_smooth_s=1 / 3, slope_s=0.5)
    read = refine_map(body, hands, truth, **kw)
    still = np.zeros(250, bool)
    still[hold.start - 4:hold.stop + 4] = True
    told = refine_map(body, hands, truth, still=still, **kw)
    inside = slice(hold.start + 5, hold.stop - 5)
    assert np.max(np.abs(told.offset[inside])) < 0.1
    # measured: up to 1.02 frames off reading the hold, 0.073 told
    assert np.max(np.abs(read.offset[inside])) > 5 * np.max(np.abs(told.offset[inside]))
    # frames outside the hold and its margin are read as before (the offset path is one path, so
    # only nearly: measured within 0.0096 frames 40 frames away from the hold)
    far = np.r_[0:hold.start - 40, hold.stop + 40:250]
    np.testing.assert_allclose(told.offset[far], read.offset[far], atol=0.02)
    with pytest.raises(ValueError, match="one flag per frame"):
        refine_map(body, hands, truth, still=still[:-1], **kw)


def test_stage_leaves_the_holds_unread(weighed, monkeypatch):
    """The stage hands refine_map the body holds of pass 1 (its held rows' holds, plus
    WRIST_HOLD_MARGIN_S either side, clipped to the covered span); none without holds or with
    the margin None."""
    from dataclasses import replace as dc_replace

    import splicer.align.wrist as W
    import splicer.defaults as D
    from splicer.align.holds import held_rows
    from splicer.stages.transfer import _covered_span, _held_frames

    seen = []
    real = W.refine_map

    def spy(*a, **kw):
        seen.append(kw.get("still"))
        return real(*a, **kw)

    monkeypatch.setattr(W, "refine_map", spy)
    splicer.refine_time_maps(weighed, SpliceOptions())
    assert seen and all(s is None for s in seen)  # the sample's body never holds still
    r = weighed["left"]
    n = len(r.hands_frame)
    held = held_rows(n, [(200, 240)])
    al = dc_replace(r.alignment, pass1=dc_replace(r.alignment.pass1, held_rows=held))
    pad = int(round(D.WRIST_HOLD_MARGIN_S * r.markers.spaces.body_fps))
    still = _held_frames(al, 0, n - 1, r.markers.spaces.body_fps)
    assert np.flatnonzero(still).tolist() == list(range(200 - pad, 241 + pad))
    assert _held_frames(al, 220, n - 1, 30.0)[:20].all()  # a span starting inside the hold
    assert _held_frames(al, 300, n - 1, 30.0) is None  # the hold outside the span
    monkeypatch.setattr(D, "WRIST_HOLD_MARGIN_S", None)
    assert _held_frames(al, 0, n - 1, 30.0) is None
    seen.clear()
    monkeypatch.setattr(D, "WRIST_HOLD_MARGIN_S", 0.125)
    splicer.refine_time_maps({"left": dc_replace(r, alignment=al)}, SpliceOptions())
    a = _covered_span(al)[0]
    assert seen and all(s is not None and s[200 - a] and s[240 - a] for s in seen)
