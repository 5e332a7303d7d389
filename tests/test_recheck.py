"""Stage 6c's second opinion (splicer.stages.recheck): a noisy pair aligned again with the arms'
positions weighed more (and once more with tempo-matched smoothing), the pair of maps the hand's
motion relative to the forearm matches best along kept."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import splicer.defaults as D
import splicer.stages.recheck as R
from splicer.options import SpliceOptions
from splicer.stages.log import Log

N = 60
FULL = "p1-p2 index-pinky, p3 elbow, p4 middle"


def _swinging_hand():
    """Wrist markers and forearm fixed, the hand swinging in the forearm's frame: a wrist that moves."""
    t = np.arange(N)
    p = np.zeros((N, 4, 3))
    p[:, 0], p[:, 1], p[:, 2] = [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-10.0, 0.0, 0.0]
    p[:, 3] = np.stack([3.0 * np.cos(t / 5.0), np.zeros(N), 3.0 * np.sin(t / 5.0)], axis=1)
    return p


def _side(weight=D.POSITION_WEIGHT_NOISY, shift=0.0, ratio=0.5, ends="fixed", **mk):
    pts = _swinging_hand()
    markers = dict(spaces=SimpleNamespace(body_fps=30.0, hands_to_common=lambda h: h / 2.0), hand_only=False, real={},
                   body=SimpleNamespace(points=pts), hands=SimpleNamespace(points=pts), placed=(FULL, FULL))
    markers.update(mk)
    return SimpleNamespace(alignment=SimpleNamespace(pass1=SimpleNamespace(position_weight=weight),
                                                     evidence=SimpleNamespace(ratio=ratio), ends=ends),
                           markers=SimpleNamespace(**markers), hands_frame=2.0 * np.arange(N) + shift)


def _pair(**kw):
    return {"left": _side(**kw), "right": _side(**kw)}


@pytest.fixture
def stand_ins(monkeypatch):
    """``realign`` and ``finish`` that record their calls and return a second pair (shifted by
    one hands frame; the tempo-matched one by two); ``coverage_mismatch`` read from a table keyed by
    which pair it is given (``"first"``, ``"second"``, ``"tempo"``); ``tempo_markers`` a stand-in.
    The frame-by-frame combination is off: these read which pair is kept (the combination's
    tests below switch it on)."""
    monkeypatch.setattr(D, "SECOND_OPINION_BLEND_S", 0.0)
    calls, mismatch = [], {}
    second, tempo, shorter = _pair(shift=1.0), _pair(shift=2.0), _pair(shift=0.5)
    for r in shorter.values():  # its overlap ends 20 frames earlier (the first's covers every frame)
        r.hands_frame[-20:] = np.nan
    blurred = {"left": "blurred", "right": "blurred"}

    def realign(opts, log, markers=None):
        assert markers is None or markers is blurred
        short = opts.uncovered_quantile == D.SHORTER_OPINION_QUANTILE
        calls.append((opts.position_weight, markers is not None) + (("shorter",) if short else ()))
        log.note("tempo run" if markers is not None else "shorter run" if short else "second run")
        return "tempo" if markers is not None else "shorter" if short else "aligned"

    def finish(aligned, log):
        return {"tempo": tempo, "shorter": shorter}.get(aligned, second)

    name = lambda sides: ("second" if sides is second else "tempo" if sides is tempo  # noqa: E731
                          else "shorter" if sides is shorter else "first")
    monkeypatch.setattr(R, "coverage_mismatch", lambda pairs: np.array([mismatch[name(p)] for p in pairs]))
    monkeypatch.setattr(R, "tempo_markers", lambda sides: blurred)
    return SimpleNamespace(calls=calls, mismatch=mismatch, second=second, tempo=tempo, shorter=shorter,
                           realign=realign, finish=finish)


def test_the_better_matching_pair_is_kept(stand_ins):
    first = _pair()
    W = D.POSITION_WEIGHT_RECHECK
    stand_ins.mismatch.update({"first": 0.6, "second": 0.4, "tempo": 0.5})
    log = Log()
    log.note("smoothed")  # a note from before the alignment: kept either way
    log.note("first run")
    out = R.position_second_opinion(first, SpliceOptions(), log, realign=stand_ins.realign, finish=stand_ins.finish,
                                    since=1)
    assert out is stand_ins.second and stand_ins.calls == [(W, False), (W, True)]
    assert log.warnings[:2] == ["smoothed", "second run"] and len(log.warnings) == 3
    assert "weighed 30 instead of 10;" in log.warnings[2] and "mismatch 0.400 against 0.600" in log.warnings[2]
    assert "position second opinion" in log.timings and "tempo-matched second opinion" in log.timings

    stand_ins.mismatch.update({"first": 0.6, "second": 0.5, "tempo": 0.3})  # the tempo-matched maps match best
    log = Log()
    log.note("first run")
    out = R.position_second_opinion(first, SpliceOptions(), log, realign=stand_ins.realign, finish=stand_ins.finish,
                                    since=0)
    assert out is stand_ins.tempo and log.warnings[0] == "tempo run"
    assert "smoothed further where one take ran faster" in log.warnings[1] and "mismatch 0.300 against 0.600" in log.warnings[1]

    stand_ins.mismatch.update({"first": 0.4, "second": 0.6, "tempo": 0.5})  # worse: the first pair and its notes stay
    log = Log()
    log.note("first run")
    out = R.position_second_opinion(first, SpliceOptions(), log, realign=stand_ins.realign, finish=stand_ins.finish,
                                    since=0)
    assert out is first and log.warnings == ["first run"]
    stand_ins.mismatch.update({"first": 0.5, "second": 0.5, "tempo": 0.5})  # a tie keeps the first
    assert R.position_second_opinion(first, SpliceOptions(), Log(), realign=stand_ins.realign,
                                     finish=stand_ins.finish, since=0) is first
    stand_ins.mismatch.update({"first": 0.5, "second": 0.4, "tempo": float("nan")})  # a NaN is never the best
    assert R.position_second_opinion(first, SpliceOptions(), Log(), realign=stand_ins.realign,
                                     finish=stand_ins.finish, since=0) is stand_ins.second


def test_tempo_matching_switched_off_aligns_once_more(stand_ins, monkeypatch):
    monkeypatch.setattr(D, "TEMPO_MATCHED", False)
    stand_ins.mismatch.update({"first": 0.6, "second": 0.4})
    out = R.position_second_opinion(_pair(), SpliceOptions(), Log(), realign=stand_ins.realign,
                                    finish=stand_ins.finish, since=0)
    assert out is stand_ins.second and stand_ins.calls == [(D.POSITION_WEIGHT_RECHECK, False)]


@pytest.mark.parametrize("case", ["weight given", "clean pair", "hand-only", "optical", "placed apart", "not a number",
                                  "still wrist", "one side", "switched off"])
def test_who_gets_no_second_opinion(stand_ins, monkeypatch, case):
    opts, sides = SpliceOptions(), _pair()
    if case == "weight given":
        opts = SpliceOptions(position_weight=10.0)
    elif case == "clean pair":  # noise matching did not smooth it: pass 1 weighed positions by 3
        sides = _pair(weight=D.POSITION_WEIGHT)
    elif case == "hand-only":
        sides = _pair(hand_only=True)
    elif case == "optical":
        sides = _pair(real={"hands": {}})
    elif case == "placed apart":  # a wrist-rooted hand file's forearm turns with the hand
        sides = _pair(placed=(FULL, "p1-p2 index-pinky, p3 hand, p4 middle"))
    elif case == "not a number":
        bad = _swinging_hand()
        bad[5, 0, 0] = np.nan
        sides = _pair(body=SimpleNamespace(points=bad))
    elif case == "still wrist":  # the hand never turns in its forearm (a Leap clip's forearm joint turns with it)
        sides = _pair(hands=SimpleNamespace(points=np.ones((N, 4, 3))))
    elif case == "one side":
        sides = {"left": _side()}
    else:
        monkeypatch.setattr(D, "POSITION_WEIGHT_RECHECK", 0.0)
    assert not R.wants_second_opinion(sides, opts)
    out = R.position_second_opinion(sides, opts, Log(), realign=stand_ins.realign, finish=stand_ins.finish, since=0)
    assert out is sides and stand_ins.calls == []


def test_a_pair_that_looks_like_two_performances_gets_one_too(stand_ins):
    """The first alignment no better than the hands played backwards (0.29.1): a second opinion may
    find the performance it lost (its own check then decides its confidence)."""
    sides = _pair(ratio=D.BACKWARDS_RATIO)
    assert R.wants_second_opinion(sides, SpliceOptions())
    stand_ins.mismatch.update({"first": 0.6, "second": 0.4, "tempo": 0.5})
    out = R.position_second_opinion(sides, SpliceOptions(), Log(), realign=stand_ins.realign,
                                    finish=stand_ins.finish, since=0)
    assert out is stand_ins.second and len(stand_ins.calls) == 2


def test_coverage_mismatch_worked_on_stubbed_costs(monkeypatch):
    """The docstring's example: frames 0-3; A covers all four reading 0.1, 0.1, 3.0 (capped at 2)
    and 0.2; B covers frames 0-1 reading 0.2 each: A (0.1 + 0.1 + 2 + 0.2) / 4 = 0.6, B (0.2 + 0.2
    + 0.5 + 0.5) / 4 = 0.35.  A frame A covers without a readable mismatch (NaN) is judged for
    neither; two sides pool their frames."""
    reads = {"A": [0.1, 0.1, 3.0, 0.2], "B": [0.2, 0.2, np.nan, np.nan]}

    def local(r, covered, window_s):
        return np.where(covered, np.asarray(reads[r.name], dtype=float), np.nan)

    monkeypatch.setattr(R, "_local_mismatch", local)
    side = lambda name, hf: SimpleNamespace(name=name, hands_frame=np.asarray(hf, dtype=float))  # noqa: E731
    a = {"left": side("A", [0, 1, 2, 3])}
    b = {"left": side("B", [0, 1, np.nan, np.nan])}
    np.testing.assert_allclose(R.coverage_mismatch([a, b], uncovered=0.5, cap=2.0), [0.6, 0.35])
    np.testing.assert_allclose(R.coverage_mismatch([a, b], uncovered=2.0, cap=2.0), [0.6, 1.1])  # dearer gaps
    reads["A"][3] = np.nan  # not readable where A covers it: frame 3 left out for both
    np.testing.assert_allclose(R.coverage_mismatch([a, b], uncovered=0.5, cap=2.0), [2.2 / 3, 0.9 / 3])
    reads["A"][:] = [np.nan] * 4
    assert np.isnan(R.coverage_mismatch([a, b])).all()  # nothing readable: NaN for all
    reads["A"][:] = [0.1, 0.1, 3.0, 0.2]
    two_a = {"left": a["left"], "right": side("A", [0, 1, 2, 3])}
    two_b = {"left": b["left"], "right": side("B", [0, 1, np.nan, np.nan])}
    np.testing.assert_allclose(R.coverage_mismatch([two_a, two_b], uncovered=0.5, cap=2.0), [0.6, 0.35])


def test_coverage_mismatch_prices_what_each_alignment_leaves_out():
    """The real local mismatch on a hand swinging in its forearm (the hands take at twice the rate,
    the truth 2 t; its markers resampled to the common timeline, as the stages make them).  The right map reads about 0; one 3 body frames late reads more.  A map that
    leaves half the (genuine) frames uncovered pays the uncovered price there, and loses to the
    right map covering all; against the late map covering all it wins once the lateness costs
    more than leaving frames out.  Covering unrelated material (the hands' frames reversed over
    the last 60 body frames) loses to leaving those frames uncovered."""
    n = 240
    t, body = _swinging(n)
    side = lambda hf: _blend_side(body, np.asarray(hf, dtype=float))  # noqa: E731
    right = {"left": side(2.0 * t)}
    late = {"left": side(np.clip(2.0 * t + 6.0, 0, 2 * n - 2))}
    half = {"left": side(np.where(t < n // 2, 2.0 * t, np.nan))}
    cost = R.coverage_mismatch([right, late, half], uncovered=0.5)
    assert cost[0] < 0.05 and cost[1] > 0.2
    assert cost[0] < cost[2] == pytest.approx(0.25 + cost[0] / 2, abs=0.05)
    assert cost[2] < cost[1]  # 3 frames late over every frame costs more than half the frames left out
    junk = 2.0 * t
    junk[-60:] = 2.0 * (n - 1) - 2.0 * (t[-60:] - t[-60]) * 3.0  # the last 60 frames run backwards, thrice as fast
    covers_junk = {"left": side(np.clip(junk, 0, 2 * n - 2))}
    leaves_it = {"left": side(np.where(t < n - 60, 2.0 * t, np.nan))}
    c_junk, c_left = R.coverage_mismatch([covers_junk, leaves_it], uncovered=0.5)
    assert c_left < c_junk


def _swinging(n):
    """Frame numbers and markers of a hand swinging in a still forearm (two sines: no two stretches alike)."""
    t = np.arange(n, dtype=float)
    a = 0.6 * np.sin(t / 5.0) + 0.3 * np.sin(t / 13.0)
    body = np.zeros((n, 4, 3))
    body[:, 0], body[:, 1], body[:, 2] = [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-10.0, 0.0, 0.0]
    body[:, 3] = np.stack([np.cos(a), np.zeros(n), np.sin(a)], axis=1) * 3.0
    return t, body


def _blend_side(body, hf):
    """A side whose hands markers are the body's, on the common timeline (hands-file frame 2 t is
    common frame t)."""
    return SimpleNamespace(markers=SimpleNamespace(spaces=SimpleNamespace(body_fps=30.0, hands_to_common=lambda h: h / 2.0),
                                                   body=SimpleNamespace(points=body), hands=SimpleNamespace(points=body)),
                           hands_frame=hf, alignment="its own")


def test_blend_maps_takes_each_stretch_from_the_map_right_there():
    """Three maps of one swinging hand (the hands take at twice the rate, the truth 2 t): one right
    up to frame 90 and 3 body frames late from 110, one late up to 90 and right from 110, one late
    throughout.  The combination is right in both stretches; outside the frames every map covers it
    is the first pair's, NaN included; so it is where the body's hand rests."""
    n = 200
    t, body = _swinging(n)
    ramp = np.clip((t - 90.0) / 20.0, 0.0, 1.0)
    early = 2.0 * t + 6.0 * ramp  # right, then late
    late_then_right = 2.0 * t + 6.0 * (1.0 - ramp)
    late = 2.0 * t + 6.0
    first = np.where(t < 5, np.nan, early)
    pairs = [{"left": _blend_side(body, hf)} for hf in (first, late_then_right, late)]
    frames = np.arange(5, 195)
    out = R.blend_maps(pairs, "left", frames, window_s=1.0, tau=0.1)
    assert np.isnan(out[:5]).all() and out[195:] == pytest.approx(early[195:])
    assert np.all(np.diff(out[5:]) >= 0)
    err = np.abs(out - 2.0 * t)
    assert err[20:75].max() < 0.5 and err[125:180].max() < 0.5  # hands frames (each map alone: 6 off in one)
    assert err[90:110].max() < 6.0  # where the maps cross: between them
    # where the body's hand rests (frames 130-174; the windows of 15 frames each side wholly in it),
    # the mismatch is not read: the first map alone, late as it is there
    rest = body.copy()
    rest[130:175, 3] = body[130, 3]
    held = R.blend_maps([{"left": _blend_side(rest, p["left"].hands_frame)} for p in pairs], "left", frames,
                        window_s=1.0, tau=0.1)
    assert held[140:158] == pytest.approx(early[140:158]) and np.abs(held - 2.0 * t)[20:75].max() < 0.5
    # a larger tau leans less on the better map: the late ones pull
    soft = R.blend_maps(pairs, "left", frames, window_s=1.0, tau=100.0)
    assert np.abs(soft - 2.0 * t)[20:75].min() > 3.0
    with pytest.raises(ValueError, match="tau"):
        R.blend_maps(pairs, "left", frames, window_s=1.0, tau=0.0)


def _follow_by_brute_force(maps, cost, cap):
    """The slow reference for R._follow: every path through the maps, the cheapest allowed one (a
    tie: the first in lexicographic order, the lower index first)."""
    import itertools

    k, n = cost.shape
    c = np.where(np.isfinite(cost), np.minimum(cost, cap), 0.0)
    best, best_path = np.inf, None
    for path in itertools.product(range(k), repeat=n):
        if any(path[t] != path[t - 1] and maps[path[t], t] < maps[path[t - 1], t - 1] for t in range(1, n)):
            continue
        total = sum(c[path[t], t] for t in range(n))
        if total < best - 1e-12:
            best, best_path = total, path
    return list(best_path), best


@pytest.mark.parametrize("seed", range(12))
def test_follow_against_its_slow_reference(seed):
    """Random non-decreasing maps crossing one another, random costs with unread frames (NaN) and
    some over the cap: the same path as trying every one, or one as cheap."""
    rng = np.random.default_rng(seed)
    k, n = (3, 7) if seed % 2 else (2, 10)
    maps = np.cumsum(rng.uniform(0.0, 2.0, (k, n)), axis=1) + rng.uniform(-3.0, 3.0, (k, 1))
    cost = rng.uniform(0.0, 1.0, (k, n))
    cost[:, rng.random(n) < 0.2] = np.nan
    got = R._follow(maps, cost, cap=0.6)
    want, least = _follow_by_brute_force(maps, cost, 0.6)
    c = np.where(np.isfinite(cost), np.minimum(cost, 0.6), 0.0)
    assert sum(c[got[t], t] for t in range(n)) == pytest.approx(least, abs=1e-6)
    assert all(got[t] == got[t - 1] or maps[got[t], t] >= maps[got[t - 1], t - 1] for t in range(1, n))
    assert got.tolist() == want


def _stub_reads(monkeypatch, reads):
    """blend_maps' mismatch stubbed: each map's reading chosen by its first frame's hands frame."""
    def along(markers, frames, hands_frame, window_s):
        return np.asarray(reads[float(hands_frame[0])], dtype=float)

    monkeypatch.setattr(R, "_mismatch_along", along)


def test_blend_maps_does_not_jump_to_a_far_map_at_an_edge(monkeypatch):
    """Worked on stubbed readings (hands frame 2 t is body frame t, 30 fps: 1 s is 60 hands frames).
    The first map is right throughout but reads badly over its first 10 frames (2.0, its window
    clipped at the edge), where a map 4 s ahead reads 0.3 and a map 1 hands frame late 1.5; from
    frame 10 on they read 0.05, 1.0 and 0.1.  Weighed frame by frame, the map ahead would win the
    first 10 frames and, made non-decreasing, hold the combination 4 s ahead for 120 frames.  The
    path followed is the first map's (10 x 0.5 + 90 x 0.05 = 9.5, against 10 x 0.3 + 90 x 0.5 =
    48 ahead and 10 x 0.5 + 90 x 0.1 = 14 late); the map ahead lies over 1 s from it and is left
    out; the first and the late one are weighed as before: 2 t + 1.5 / (1 + e^-5) ~ 2 t + 1.0 over
    the first 10 frames, 2 t + 1.0 / (1 + e^0.5) ~ 2 t + 0.38 after."""
    n = 100
    t, body = _swinging(n)
    first, ahead, late = 2.0 * t, 2.0 * t + 240.0, 2.0 * t + 1.0
    edge = t < 10
    _stub_reads(monkeypatch, {0.0: np.where(edge, 2.0, 0.05), 240.0: np.where(edge, 0.3, 1.0),
                              1.0: np.where(edge, 1.5, 0.1)})
    pairs = [{"left": _blend_side(body, hf)} for hf in (first, ahead, late)]
    out = R.blend_maps(pairs, "left", np.arange(n), window_s=1.0, tau=0.1)
    np.testing.assert_allclose(out[1:10] - first[1:10], 1.0 / (1.0 + np.exp(-5.0)), atol=1e-9)
    np.testing.assert_allclose(out[10:] - first[10:], 1.0 / (1.0 + np.exp(0.5)), atol=1e-9)


def test_blend_maps_follows_the_others_past_a_stuck_first_map(monkeypatch):
    """The first map sticks at hands frame 40 over body frames 20-79 and then goes on right; two
    others are right throughout (2 t and 2 t + 1).  Readings: the first 1.0 while stuck, 0.05
    elsewhere; the others 0.1; over frames 60-79 nothing can be read (the body's hand rests).  The
    path steps forward to the right map at frame 20 (the first would cost 60 x 0.5 more) and stays
    there (stepping back to the stuck map is not allowed) until the first rejoins it at frame 80.
    Over the unread frames the first map lies over 1 s (30 body frames) from the followed one, so
    the followed one alone is used there, not the first (which, made non-decreasing, would hold the
    combination at hands frame 118 over frames 60-79)."""
    n = 120
    t, body = _swinging(n)
    first = np.where((t >= 20) & (t < 80), 40.0, 2.0 * t)
    right, late = 2.0 * t, 2.0 * t + 1.0
    stuck = (t >= 20) & (t < 80)
    unread = (t >= 60) & (t < 80)
    read = lambda r: np.where(unread, np.nan, r)  # noqa: E731
    _stub_reads(monkeypatch, {0.0: read(np.where(stuck, 1.0, 0.05)), 1.0: read(np.full(n, 0.1)),
                              0.5: read(np.full(n, 0.1))})
    right[0] = 0.5  # its own key for the stub (the first frame only)
    pairs = [{"left": _blend_side(body, hf)} for hf in (first, right, late)]
    out = R.blend_maps(pairs, "left", np.arange(n), window_s=1.0, tau=0.1)
    assert np.all(np.diff(out) >= 0)
    assert np.abs(out - 2.0 * t)[20:80].max() < 1.0  # the stuck first map (up to 118 frames off) left alone
    assert np.abs(out - 2.0 * t)[80:].max() < 1.0


def test_the_pair_kept_is_combined_with_the_others(stand_ins, monkeypatch):
    """With the combination on (the default), the kept pair keeps its other fields and a note says
    so.  The stand-ins' hand swings round a circle at one speed, which looks the same at any shift:
    the three maps (0, 1 and 2 hands frames late) weigh alike, so the combination is their mean,
    1 frame late (away from the ends, where the late maps reach past the hands take).  The median
    merge is left alone: its fingers come from the path."""
    monkeypatch.setattr(D, "SECOND_OPINION_BLEND_S", 1.0)
    monkeypatch.setattr(R, "replace", lambda obj, **kw: SimpleNamespace(**{**vars(obj), **kw}))  # stand-in sides
    stand_ins.mismatch.update({"first": 0.6, "second": 0.4, "tempo": 0.5})
    first = _pair()
    log = Log()
    out = R.position_second_opinion(first, SpliceOptions(), log, realign=stand_ins.realign, finish=stand_ins.finish,
                                    since=0)
    truth = 2.0 * np.arange(N)
    for s in ("left", "right"):
        assert out[s].alignment is stand_ins.second[s].alignment  # the kept pair's
        off = out[s].hands_frame - truth
        assert off[17:42] == pytest.approx(np.ones(25), abs=1e-3)  # within 15 frames of an end, the shifted maps clip
    assert "kept as the frame-by-frame combination's base" in log.warnings[-2]
    assert "3 alignments' time maps are combined frame by frame over body frames 0-59" in log.warnings[-1]
    median = R.position_second_opinion(first, SpliceOptions(merge="median"), Log(), realign=stand_ins.realign,
                                       finish=stand_ins.finish, since=0)
    assert median is stand_ins.second


def test_map_distance_is_the_median_over_the_frames_both_cover():
    """Worked: hands at twice the body's rate (the stand-ins' spaces), body at 30 fps.  Left maps 60
    hands frames apart (1 s) on frames 0-39; right 0 apart on 0-19, frames 20-59 not covered by the
    other: the median of 40 values of 1 s and 20 of 0 s is 1 s.  Nothing shared: NaN."""
    a, b = _pair(), _pair()
    b["left"].hands_frame = a["left"].hands_frame + 60.0
    b["left"].hands_frame[40:] = np.nan
    b["right"].hands_frame = a["right"].hands_frame.copy()
    b["right"].hands_frame[20:] = np.nan
    assert R.map_distance_s(a, b) == pytest.approx(1.0)
    b["right"].hands_frame[:20] += 600.0  # 10 s: 40 of 1 s, 20 of 10 s
    assert R.map_distance_s(a, b) == pytest.approx(1.0)
    b["left"].hands_frame[:] = np.nan
    b["right"].hands_frame[:] = np.nan
    assert np.isnan(R.map_distance_s(a, b))


@pytest.mark.parametrize("blend", [0.0, 1.0])
def test_a_second_opinion_that_moves_the_overlap_is_judged_on_its_own_frames(stand_ins, monkeypatch, blend):
    """The positions-weighed pair lies 2 s from the first (120 hands frames at 60 fps): the frames
    both cover cannot judge it, so each pair is judged along its own (here the stand-ins' table:
    the same numbers).  Matching worse there (0.7 against 0.6) it is left out with a note and the
    tempo-matched pair (2 hands frames late, 0.5) is kept as usual; matching better (0.1) it is kept
    whole, never combined with maps 2 s away; with both moved and worse, the first pair stays."""
    monkeypatch.setattr(D, "SECOND_OPINION_BLEND_S", blend)
    monkeypatch.setattr(R, "replace", lambda obj, **kw: SimpleNamespace(**{**vars(obj), **kw}))  # stand-in sides
    for r in stand_ins.second.values():
        r.hands_frame = r.hands_frame + 119.0  # shift 1 + 119 = 120 hands frames: 2 s
    first = _pair()
    run = lambda log: R.position_second_opinion(first, SpliceOptions(), log, realign=stand_ins.realign,  # noqa: E731
                                                finish=stand_ins.finish, since=0)
    stand_ins.mismatch.update({"first": 0.6, "second": 0.7, "tempo": 0.5})
    log = Log()
    out = run(log)
    moved = [w for w in log.warnings if "placed the hands' material elsewhere" in w]
    assert len(moved) == 1 and "(its time maps 2.0 s from the first's" in moved[0] and "weighed 30;" in moved[0]
    assert "(mismatch 0.700 against 0.600, frame by frame" in moved[0] and moved[0].endswith("it is left out")
    assert log.warnings[0] == "tempo run"  # the kept alignment's own notes, then the one left out
    for s in ("left", "right"):
        assert out[s].alignment is stand_ins.tempo[s].alignment
        if blend:  # the first and the tempo-matched maps combined: between 0 and 2 frames late, never 120
            off = out[s].hands_frame - 2.0 * np.arange(N)
            assert np.nanmax(np.abs(off)) <= 2.0 + 1e-9

    stand_ins.mismatch.update({"first": 0.6, "second": 0.1, "tempo": 0.5})
    log = Log()
    out = run(log)
    assert out is stand_ins.second  # whole: its own maps, its own notes
    assert log.warnings[0] == "second run" and len(log.warnings) == 2
    assert "(mismatch 0.100 against 0.600, frame by frame" in log.warnings[1]
    assert "it is kept whole (it placed the hands' material elsewhere: its time maps 2.0 s" in log.warnings[1]

    stand_ins.mismatch.update({"first": 0.6, "second": 0.7, "tempo": 0.8})
    for r in stand_ins.tempo.values():
        r.hands_frame = r.hands_frame + 300.0
    log = Log()
    log.note("first run")
    assert run(log) is first
    assert len(log.warnings) == 3 and log.warnings[0] == "first run"
    assert "tempo-matched" in log.warnings[2] and "(its time maps 5.0 s" in log.warnings[2]


def test_a_second_opinion_on_other_frames_altogether_is_judged_on_its_own(stand_ins, monkeypatch):
    """No body frame covered by both the first pair and a second opinion (the distance is NaN):
    the second opinion lies elsewhere as surely as one seconds away, and is judged on its own frames."""
    monkeypatch.setattr(R, "replace", lambda obj, **kw: SimpleNamespace(**{**vars(obj), **kw}))  # stand-in sides
    first = _pair()
    for r in first.values():
        r.hands_frame[30:] = np.nan
    for r in stand_ins.second.values():
        r.hands_frame[:30] = np.nan
    assert np.isnan(R.map_distance_s(first, stand_ins.second))
    stand_ins.mismatch.update({"first": 0.6, "second": 0.1, "tempo": 0.5})
    log = Log()
    out = R.position_second_opinion(first, SpliceOptions(), log, realign=stand_ins.realign, finish=stand_ins.finish,
                                    since=0)
    assert out is stand_ins.second
    assert "on body frames the first's maps do not cover" in log.warnings[-1] and "kept whole" in log.warnings[-1]


def test_covered_frames():
    sides = _pair()
    sides["left"].hands_frame[:7] = np.nan
    assert R.covered_frames(sides) == 2 * N - 7


def test_a_located_overlap_gets_a_shorter_second_opinion(stand_ins, monkeypatch):
    """Open ends (0.32.0): the pair aligned once more with a cheaper uncovered penalty; a candidate
    only when it leaves SHORTER_OPINION_LESS_S more of each side uncovered (here 20 frames a side,
    0.67 s), and kept whole or not at all."""
    W = D.POSITION_WEIGHT_RECHECK
    stand_ins.mismatch.update({"first": 0.6, "second": 0.5, "tempo": 0.55, "shorter": 0.3})
    # the takes start and end together (fixed ends): nothing to re-decide, no third run
    out = R.position_second_opinion(_pair(), SpliceOptions(), Log(), realign=stand_ins.realign,
                                    finish=stand_ins.finish, since=0)
    assert out is stand_ins.second and stand_ins.calls == [(W, False), (W, True)]
    # located: the third run, kept where it matches best
    stand_ins.calls.clear()
    monkeypatch.setattr(D, "SHORTER_OPINION_LESS_S", 0.5)  # 15 frames a side at 30 fps
    log = Log()
    out = R.position_second_opinion(_pair(ends="open"), SpliceOptions(), log, realign=stand_ins.realign,
                                    finish=stand_ins.finish, since=0)
    assert stand_ins.calls == [(W, False), (W, True), (W, False, "shorter")]
    assert out is stand_ins.shorter and log.warnings[0] == "shorter run"
    assert "a shorter overlap" in log.warnings[1] and "mismatch 0.300 against 0.600" in log.warnings[1]
    assert "shorter-overlap second opinion" in log.timings
    # not clearly shorter (20 frames a side, under 1 s): not a candidate
    monkeypatch.setattr(D, "SHORTER_OPINION_LESS_S", 1.0)
    out = R.position_second_opinion(_pair(ends="open"), SpliceOptions(), Log(), realign=stand_ins.realign,
                                    finish=stand_ins.finish, since=0)
    assert out is stand_ins.second
    monkeypatch.setattr(D, "SHORTER_OPINION_QUANTILE", 0.0)  # switched off: no third run
    stand_ins.calls.clear()
    R.position_second_opinion(_pair(ends="open"), SpliceOptions(), Log(), realign=stand_ins.realign,
                              finish=stand_ins.finish, since=0)
    assert stand_ins.calls == [(W, False), (W, True)]


def test_a_shorter_overlap_not_kept_leaves_the_combination_alone(stand_ins, monkeypatch):
    """Not the best: the combination of the others is what it would be without the third run (its
    shorter cover does not narrow the frames combined)."""
    monkeypatch.setattr(D, "SECOND_OPINION_BLEND_S", 1.0)
    monkeypatch.setattr(D, "SHORTER_OPINION_LESS_S", 0.5)
    monkeypatch.setattr(R, "replace", lambda obj, **kw: SimpleNamespace(**{**vars(obj), **kw}))  # stand-in sides
    stand_ins.mismatch.update({"first": 0.6, "second": 0.4, "tempo": 0.5, "shorter": 0.45})
    log = Log()
    out = R.position_second_opinion(_pair(ends="open"), SpliceOptions(), log, realign=stand_ins.realign,
                                    finish=stand_ins.finish, since=0)
    assert "3 alignments' time maps are combined frame by frame over body frames 0-59" in log.warnings[-1]
    monkeypatch.setattr(D, "SHORTER_OPINION_QUANTILE", 0.0)
    without = R.position_second_opinion(_pair(ends="open"), SpliceOptions(), Log(), realign=stand_ins.realign,
                                        finish=stand_ins.finish, since=0)
    for s in ("left", "right"):
        np.testing.assert_array_equal(out[s].hands_frame, without[s].hands_frame)


def test_the_judge_on_the_protocol():
    """Synthetic *all*, tuning seed 28: the hands' genuine material covers body frames 20-869 and
    ends slowly, then 7.6 s of extra material.  Judged along the frames each covered (0.33.0),
    every alignment stretched the hands' last genuine seconds and the extra material over body
    frames up to 1403 (0.21 s mean error, 1.8 s 95th percentile).  Judged frame by frame over the
    frames any of them covers, a frame left uncovered at a price (0.34.0), the shorter overlap's
    second opinion is kept: each side's hands material ends within a second of the truth's."""
    from splicer import splice
    from splicer.evaluation.scenario_types import alignment_error_s, scenario
    from splicer.evaluation.scenarios import make_scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(28))
    last = np.flatnonzero(sep.covered)[-1]
    assert last == 869
    res = splice(sep.body, sep.hands)
    assert any("a shorter overlap" in w and "it is kept" in w and "frame by frame" in w for w in res.report.warnings)
    errs = []
    for s, r in res.sides.items():
        hf = np.asarray(r.hands_frame, dtype=np.float64)
        assert abs(np.flatnonzero(np.isfinite(hf))[-1] - last) < 30  # within a second (30 fps)
        e = alignment_error_s(sep, hf)
        errs.append(np.abs(e[np.isfinite(e)]))
    errs = np.concatenate(errs)
    assert errs.mean() < 0.05 and np.percentile(errs, 95) < 0.1  # measured 0.025 (0.081)


def test_the_combination_on_the_protocol():
    """Synthetic *all*, seed 409 (drawn after 0.34.0's choices): the hands' genuine material starts
    at body frame 750.  The position-weighed second opinion is kept (0.054 s mean, 0.105 s 95th
    percentile on the left), but weighed frame by frame (0.28.0-0.34.0) the first alignment's map,
    2-3 s ahead, won body frames 783-794, where the kept map's window covered the hands' extra
    material and read 2-3; made non-decreasing the combination then stayed up to 2.4 s ahead for
    two seconds (0.228 s mean, 2.19 s 95th percentile); the spliced result erred 0.109 (0.80) s on
    the left, 0.142 (1.18) s on the right.  Following the path of least mismatch that never steps
    back (0.35.0), that map is not taken there: measured 0.019 (0.068) and 0.025 (0.092) s."""
    from splicer import splice
    from splicer.evaluation.scenario_types import alignment_error_s, scenario
    from splicer.evaluation.scenarios import make_scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(409))
    res = splice(sep.body, sep.hands)
    assert any("combined frame by frame" in w for w in res.report.warnings)
    for r in res.sides.values():
        e = np.abs(alignment_error_s(sep, np.asarray(r.hands_frame, dtype=np.float64)))
        e = e[np.isfinite(e)]
        assert e.mean() < 0.05 and np.percentile(e, 95) < 0.2
