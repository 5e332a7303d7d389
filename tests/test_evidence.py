"""The same-performance check: pass 1 against the hands take played backwards (splicer.align.evidence)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import splicer
from splicer import defaults as D
from splicer.align.evidence import Evidence, match_evidence, played_backwards
from splicer.evaluation.scenarios import make_scenario
from splicer.evaluation.synth import make_gesture_take
from splicer.rig.markers import Markers


def test_played_backwards_reverses_every_array_and_undoes_itself():
    pts = np.arange(3 * 4 * 3, dtype=float).reshape(3, 4, 3)
    m = Markers(pts, pts[:, 0] * 2, np.array([0.1, 0.2, 0.3]), 1, 60.0, "left")
    b = played_backwards(m)
    np.testing.assert_array_equal(b.points[0], pts[2])
    np.testing.assert_array_equal(b.shoulder[:, 0], [48.0, 24.0, 0.0])
    np.testing.assert_array_equal(b.heading, [0.3, 0.2, 0.1])
    assert (b.up, b.fps, b.side) == (1, 60.0, "left")
    back = played_backwards(b)
    np.testing.assert_array_equal(back.points, m.points)


def test_ratio_is_the_cost_over_the_backwards_cost():
    assert Evidence(30.0, 120.0, 10.0).ratio == 0.25
    assert math.isnan(Evidence(3.0, 0.0, 10.0).ratio)


def test_match_evidence_checks_its_end_condition():
    pts = np.random.default_rng(0).normal(size=(50, 4, 3))
    m = Markers(pts, np.zeros((50, 3)), np.zeros(50), 1, 30.0, "right")
    with pytest.raises(ValueError, match="ends"):
        match_evidence(m, m, ends="both")


@pytest.fixture(scope="module")
def takes():
    a = make_gesture_take(20.0, 30.0, np.random.default_rng(5))
    b = make_gesture_take(20.0, 30.0, np.random.default_rng(6))
    sep = make_scenario(a, "base", rng=np.random.default_rng(1))
    other = make_scenario(b, "base", rng=np.random.default_rng(2))
    return sep, other


def test_a_genuine_pair_is_far_cheaper_than_its_hands_played_backwards(takes):
    sep, _ = takes
    r = splicer.splice(sep.body, sep.hands, side="right")
    ev = r.sides["right"].alignment.evidence
    assert ev.fps == 10.0 and ev.ratio < 0.7 * D.BACKWARDS_RATIO
    assert r.report.to_dict()["sides"]["right"]["pass1"]["backwards_ratio"] == pytest.approx(ev.ratio, abs=1e-4)
    assert not any("same performance" in w for w in r.report.warnings)


def test_another_performance_is_no_cheaper_and_every_frame_is_low_confidence(takes):
    sep, other = takes
    r = splicer.splice(sep.body, other.hands, side="right")
    ev = r.sides["right"].alignment.evidence
    assert ev.ratio >= D.BACKWARDS_RATIO
    warn = [w for w in r.report.warnings if "may not show the same performance" in w]
    assert len(warn) == 1 and "played backwards" in warn[0]
    conf = r.sides["right"].alignment.confidence
    covered = np.isfinite(conf.est_error_s)
    assert covered.any()
    # nothing says where in the 20 s hands take a frame belongs: at least length / sqrt(12)
    m = r.sides["right"].markers.hands
    assert np.all(conf.est_error_s[covered] >= (m.n_frames - 1) / m.fps / math.sqrt(12.0) - 1e-9)
    d = r.report.to_dict()["sides"]["right"]
    low = sum(b - a + 1 for a, b in d["low_confidence"])
    assert low == int(covered.sum())


def test_a_check_that_cannot_run_is_said_and_never_fails_the_splice(takes, monkeypatch):
    import splicer.align.evidence as ev
    from splicer.errors import BandError

    def refuse(*a, **k):
        raise BandError("too short at 10 fps")

    monkeypatch.setattr(ev, "match_evidence", refuse)
    sep, _ = takes
    r = splicer.splice(sep.body, sep.hands, side="right")
    assert r.sides["right"].alignment.evidence is None
    assert "backwards_ratio" not in r.report.to_dict()["sides"]["right"]["pass1"]
    assert any("could not run (too short at 10 fps)" in w for w in r.report.warnings)


def test_path_row_costs_are_the_mean_local_cost_on_the_path_against_a_loop():
    """A real open-ended pass 1: each row's mean cost over its path cells, computed cell by cell;
    rows the path leaves uncovered get the pass's penalty."""
    from splicer.align.evidence import path_row_costs
    from splicer.align.passes import pass1

    rng = np.random.default_rng(4)

    def walk(k):
        x = np.cumsum(np.cumsum(rng.normal(size=(k, 4, 3)), axis=0), axis=0)
        return x / np.abs(x).max()

    body = walk(200)
    hands = np.concatenate([body[40:], walk(60)])  # the hands start at body frame 40
    mk = lambda x: Markers(x, np.zeros((len(x), 3)), np.zeros(len(x)), 1, 30.0, "right")  # noqa: E731
    p = pass1(mk(body), mk(hands), width=90.0, ends="open")
    got = path_row_costs(p)
    want = np.full(p.band.n, float(p.uncovered_cost))
    for i in np.unique(p.path[:, 0]):
        row = p.local_cost(p.band, int(i), int(i) + 1)[0]
        js = p.path[p.path[:, 0] == i, 1]
        want[i] = np.mean([row[j - p.band.lo[i]] for j in js])
    assert (~np.isin(np.arange(p.band.n), p.path[:, 0])).any()  # the case has uncovered rows
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_local_ratio_is_low_on_the_genuine_span_and_near_one_on_other_material(takes):
    """The check's per-frame costs: a genuine pair's ratio stays well below 1 nearly everywhere;
    against another performance it is near 1 (the check's rows, recorded by the splice)."""
    sep, other = takes
    for hands, lo, hi in ((sep.hands, 0.0, 0.75), (other.hands, 0.75, 1.5)):
        r = splicer.splice(sep.body, hands, side="right")
        ev = r.sides["right"].alignment.evidence
        assert ev.rows is not None and len(ev.rows) == len(ev.backwards_rows) == round((sep.body.n_frames - 1) * ev.fps / sep.body.fps) + 1
        ratio = ev.local_ratio(sep.body.n_frames, sep.body.fps, D.UNMATCHED_WINDOW_S)
        assert ratio.shape == (sep.body.n_frames,)
        assert lo <= np.median(ratio) <= hi, np.median(ratio)


def test_local_ratio_without_rows_is_none_and_checks_its_arguments():
    assert Evidence(1.0, 2.0, 10.0).local_ratio(5, 30.0, 2.0) is None
    ev = Evidence(1.0, 2.0, 10.0, rows=np.ones(3), backwards_rows=np.zeros(3))
    assert np.isnan(ev.local_ratio(3, 10.0, 1.0)).all()  # the backwards pass cost nothing: no verdict
    with pytest.raises(ValueError):
        ev.local_ratio(3, 0.0, 1.0)
    assert Evidence(1.0, 2.0, 10.0) == Evidence(1.0, 2.0, 10.0, rows=np.ones(2))  # the rows do not compare
