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


def _side(weight=D.POSITION_WEIGHT_NOISY, shift=0.0, ratio=0.5, **mk):
    pts = _swinging_hand()
    markers = dict(spaces=SimpleNamespace(body_fps=30.0, hands_to_common=lambda h: h / 2.0), hand_only=False, real={},
                   body=SimpleNamespace(points=pts), hands=SimpleNamespace(points=pts), placed=(FULL, FULL))
    markers.update(mk)
    return SimpleNamespace(alignment=SimpleNamespace(pass1=SimpleNamespace(position_weight=weight),
                                                     evidence=SimpleNamespace(ratio=ratio)),
                           markers=SimpleNamespace(**markers), hands_frame=2.0 * np.arange(N) + shift)


def _pair(**kw):
    return {"left": _side(**kw), "right": _side(**kw)}


@pytest.fixture
def stand_ins(monkeypatch):
    """``realign`` and ``finish`` that record their calls and return a second pair (shifted by
    one hands frame; the tempo-matched one by two); ``map_mismatch`` read from a table keyed by
    which pair it is given (``"first"``, ``"second"``, ``"tempo"``); ``tempo_markers`` a stand-in."""
    calls, mismatch = [], {}
    second, tempo = _pair(shift=1.0), _pair(shift=2.0)
    blurred = {"left": "blurred", "right": "blurred"}

    def realign(opts, log, markers=None):
        assert markers is None or markers is blurred
        calls.append((opts.position_weight, markers is not None))
        log.note("tempo run" if markers is not None else "second run")
        return "tempo" if markers is not None else "aligned"

    def finish(aligned, log):
        return tempo if aligned == "tempo" else second

    monkeypatch.setattr(R, "map_mismatch", lambda sides, frames: mismatch[
        "second" if sides is second else "tempo" if sides is tempo else "first"])
    monkeypatch.setattr(R, "tempo_markers", lambda sides: blurred)
    return SimpleNamespace(calls=calls, mismatch=mismatch, second=second, tempo=tempo, realign=realign, finish=finish)


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
                                  "still wrist", "one side", "another performance", "switched off"])
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
    elif case == "another performance":  # no better than the hands played backwards: all low confidence anyway
        sides = _pair(ratio=D.BACKWARDS_RATIO)
    else:
        monkeypatch.setattr(D, "POSITION_WEIGHT_RECHECK", 0.0)
    assert not R.wants_second_opinion(sides, opts)
    out = R.position_second_opinion(sides, opts, Log(), realign=stand_ins.realign, finish=stand_ins.finish, since=0)
    assert out is sides and stand_ins.calls == []


def test_map_mismatch_reads_the_frames_both_cover():
    """The real rate_mismatch along each side's map, averaged over the sides (a hand whose
    direction in the forearm's frame swings; the hands take at twice the rate)."""
    from splicer.align.wrist import rate_mismatch

    t = np.arange(200, dtype=float)
    body = np.zeros((200, 4, 3))
    body[:, 0], body[:, 1], body[:, 2] = [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-10.0, 0.0, 0.0]
    a = 0.6 * np.sin(t / 5.0)
    body[:, 3] = np.stack([np.cos(a), np.zeros(200), np.sin(a)], axis=1) * 3.0
    side = SimpleNamespace(markers=SimpleNamespace(spaces=SimpleNamespace(body_fps=30.0, hands_to_common=lambda h: h / 2.0),
                                                   body=SimpleNamespace(points=body), hands=SimpleNamespace(points=body)),
                           hands_frame=2.0 * t)
    late = SimpleNamespace(markers=side.markers, hands_frame=2.0 * t + 4.0)  # two body frames late
    frames = np.arange(20, 180)
    right = R.map_mismatch({"left": side, "right": side}, frames)
    assert right < 0.01
    both = R.map_mismatch({"left": side, "right": late}, frames)
    want = rate_mismatch(body[frames], body, t[frames] + 2.0, fps=30.0, smooth_s=D.WRIST_SMOOTH_S)
    assert both == pytest.approx((right + want) / 2) and want > 10 * right
