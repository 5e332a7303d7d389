"""Coverage edges: covered frames next to an uncovered range are low confidence (worked answers,
and a splice of the sample whose hands take covers only the middle half of the body)."""

from pathlib import Path

import numpy as np
import pytest

from splicer.align.confidence import Confidence
from splicer.defaults import COVERAGE_EDGE_S
from splicer.stages.coverage import coverage_edges

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


def test_edges_each_side_of_every_uncovered_range():
    nan = np.nan
    # uncovered 0-1, 6, 11: two frames each side at 10 fps and 0.2 s
    hf = np.array([nan, nan, 2, 3, 4, 5, nan, 7, 8, 9, 10, nan, 12, 13, 14, 15, 16, 17])
    got = coverage_edges(hf, 10.0, 0.2)
    want = np.zeros(len(hf), dtype=bool)
    want[[2, 3, 4, 5, 7, 8, 9, 10, 12, 13]] = True
    np.testing.assert_array_equal(got, want)
    # rounding to whole frames: 0.14 s at 10 fps is 1 frame, 0.04 s none
    np.testing.assert_array_equal(np.flatnonzero(coverage_edges(hf, 10.0, 0.14)), [2, 5, 7, 10, 12])
    assert not coverage_edges(hf, 10.0, 0.04).any()
    # nothing uncovered, or nothing covered: no edges
    assert not coverage_edges(np.arange(8.0), 10.0, 0.5).any()
    assert not coverage_edges(np.full(8, nan), 10.0, 0.5).any()
    for bad in ((hf, 0.0, 0.2), (hf, 10.0, -1.0), (hf, np.inf, 0.2), (hf.reshape(2, -1), 10.0, 0.2)):
        with pytest.raises(ValueError):
            coverage_edges(*bad)


def test_with_floor_where_raises_only_the_masked_covered_frames():
    est = np.array([np.nan, 0.02, 0.5, 0.03, np.nan])
    c = Confidence(spread_frames=np.zeros(5), est_error_s=est, confidence=np.zeros(5), threshold=1.0,
                   error_scale_s=0.1)
    f = c.with_floor(0.25, where=np.array([True, True, True, False, False]))
    np.testing.assert_array_equal(f.est_error_s, [np.nan, 0.25, 0.5, 0.03, np.nan])  # uncovered stay NaN
    np.testing.assert_allclose(f.confidence, [0.0, 1 / (1 + 2.5 ** 2), 1 / (1 + 5.0 ** 2), 1 / (1 + 0.3 ** 2), 0.0])
    with pytest.raises(ValueError, match="boolean mask"):
        c.with_floor(0.25, where=np.ones(4, dtype=bool))
    with pytest.raises(ValueError, match="boolean mask"):
        c.with_floor(0.25, where=np.ones(5))


@pytest.mark.slow
def test_hands_covering_the_middle_half_flag_the_edges_of_their_coverage():
    """The sample's hands take cut to the stretch that shows body frames 150-450 (of 601): the
    body frames outside are uncovered, and the covered frames within COVERAGE_EDGE_S of them are
    low confidence whatever the alignment's own spread says; the time map is not changed."""
    from splicer import splice
    from splicer.io.bvh import read_bvh

    body, hands = read_bvh(MOTIONS / "sample_body.bvh"), read_bvh(MOTIONS / "sample_hands.bvh")
    truth = np.loadtxt(MOTIONS / "sample_truth.csv", delimiter=",", skiprows=1)[:, 1]
    j0, j1 = int(round(truth[150])), int(round(truth[450]))
    r = splice(body, hands.slice(j0, j1 + 1), side="left")
    s = r.report["sides"]["left"]
    unc = s["uncovered"]
    assert len(unc) == 2 and unc[0][0] == 0 and unc[1][1] == body.n_frames - 1
    a, b = unc[0][1] + 1, unc[1][0] - 1  # the covered stretch
    assert abs(a - 150) <= 15 and abs(b - 450) <= 15  # located to within half a second
    w = int(round(COVERAGE_EDGE_S * body.fps))
    est = np.array([np.nan if e is None else e for e in s["est_error_s"]])
    assert np.all(est[a:a + w] >= COVERAGE_EDGE_S - 1e-4) and np.all(est[b - w + 1:b + 1] >= COVERAGE_EDGE_S - 1e-4)
    low = np.zeros(body.n_frames, dtype=bool)
    for x, y in s["low_confidence"]:
        low[x:y + 1] = True
    assert low[a:a + w].all() and low[b - w + 1:b + 1].all()
    assert np.isnan(est[:a]).all() and np.isnan(est[b + 1:]).all()
    assert any("within 0.33 s of them count as low confidence" in n for n in r.report["warnings"])
    # the stage's edges on the final time map: exactly the w frames at each end of the covered stretch
    hf = np.asarray(r.sides["left"].hands_frame, dtype=np.float64)
    e = coverage_edges(hf, body.fps)
    assert e.sum() == 2 * w and e[a:a + w].all() and e[b - w + 1:b + 1].all()


# ---------------------------------------------------------------- unsure stretches next to uncovered frames

def test_unsure_edges_both_ends_and_the_body_ends():
    from splicer.stages.coverage import unsure_edges

    nan = np.nan
    hf = np.array([nan, nan, 0, 1, 2, 3, 4, 5, 6, 7, nan])
    est = np.array([nan, nan, 0.3, 0.3, 0.1, 0.1, 0.1, 0.1, 0.25, 0.21, nan])
    # start: frames 2-3 (2 frames); end: frames 8-9 (2 frames), both next to uncovered frames
    assert unsure_edges(hf, est, 10.0, min_s=0.2).astype(int).tolist() == [0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0]
    # a higher error bar leaves the end's 0.21-0.25 s frames alone
    assert unsure_edges(hf, est, 10.0, min_s=0.2, error_s=0.26).astype(int).tolist() == [0, 0, 1, 1] + [0] * 7
    assert not unsure_edges(hf, est, 10.0, min_s=0.0).any()  # switched off
    # the covered span reaching the body's first and last frames: nothing is taken
    full = np.arange(11.0)
    assert not unsure_edges(full, np.full(11, 0.5), 10.0, min_s=0.2).any()
    # unsure from end to end (the synthetic *all* scenario's held-out seed 103 had such a side):
    # nothing to lead to, nothing taken
    assert not unsure_edges(hf, np.where(np.isfinite(hf), 0.5, nan), 10.0, min_s=0.2).any()
    # a pin says the material there is the body's: a run reaching it is left alone
    assert not unsure_edges(hf, np.where(np.isfinite(hf), 0.5, nan), 10.0, min_s=0.2, pinned=[5]).any()
    assert unsure_edges(hf, est, 10.0, min_s=0.2, pinned=[3]).astype(int).tolist() == [0] * 8 + [1, 1, 0]
    with pytest.raises(ValueError):
        unsure_edges(hf, est[:-1], 10.0)


def test_unmatched_edges_worked():
    from splicer.stages.coverage import unmatched_edges

    nan = np.nan
    hf = np.array([nan, 0, 1, 2, 3, 4, 5, 6, 7, nan, nan])
    ratio = np.array([nan, 0.9, 0.95, 0.5, 0.2, 0.9, 0.86, 1.2, 0.9, nan, nan])
    # start: frames 1-2; end: frames 5-8 (four frames over 0.85), both next to uncovered frames
    assert unmatched_edges(hf, ratio, 10.0, beyond_s=0.0, min_s=0.2).astype(int).tolist() == [0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 0]
    assert unmatched_edges(hf, ratio, 10.0, beyond_s=0.0, min_s=0.3).astype(int).tolist() == [0] * 5 + [1, 1, 1, 1, 0, 0]
    # a higher bar stops the end's run at 0.86: three frames
    assert unmatched_edges(hf, ratio, 10.0, beyond_s=0.0, min_s=0.3, ratio_above=0.87).astype(int).tolist() == [0] * 11
    assert unmatched_edges(hf, ratio, 10.0, beyond_s=0.0, min_s=0.2, ratio_above=0.87).astype(int).tolist() == \
        [0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0]
    # an unknown ratio (NaN) is never taken; a pin stops a run; 0 s switches it off
    assert unmatched_edges(hf, np.where(np.arange(11) == 6, nan, ratio), 10.0, beyond_s=0.0, min_s=0.3).sum() == 0
    assert unmatched_edges(hf, ratio, 10.0, beyond_s=0.0, min_s=0.2, pinned=[7]).astype(int).tolist() == [0, 1, 1] + [0] * 8
    assert not unmatched_edges(hf, ratio, 10.0, beyond_s=0.0, min_s=0.0).any()
    # everything unmatched: nothing kept to lead to, nothing taken; the body's own ends are left alone
    assert not unmatched_edges(hf, np.full(11, 2.0), 10.0, beyond_s=0.0, min_s=0.1).any()
    assert not unmatched_edges(np.arange(11.0), np.full(11, 2.0), 10.0, beyond_s=0.0, min_s=0.1).any()
    # by default more than a third of a second must lie uncovered past an end: here the start has
    # 0.1 s and the end 0.2 s, both within the open ends' precision (the takes start and stop together)
    assert not unmatched_edges(hf, ratio, 10.0, min_s=0.2).any()
    assert unmatched_edges(hf, ratio, 10.0, min_s=0.2, beyond_s=0.15).astype(int).tolist() == [0] * 5 + [1] * 4 + [0, 0]
    with pytest.raises(ValueError):
        unmatched_edges(hf, ratio[:-1], 10.0)
    with pytest.raises(ValueError):
        unmatched_edges(hf, ratio, 10.0, beyond_s=-1.0)


def test_unmatched_body_ends_worked():
    """Worked answers: from each end at the body's own first or last frame, the stretch whose
    ratio exceeds the bound on the whole (the prefix with the largest summed excess)."""
    from splicer.stages.coverage import unmatched_body_ends

    nan = np.nan
    hf = np.arange(12.0)
    #                 0    1    2    3    4    5    6    7    8    9    10   11
    ratio = np.array([1.5, 1.2, 0.8, 1.3, 0.4, 0.5, 0.3, 0.6, 1.1, 1.3, 1.2, 1.4])
    # start: excess 0.5, 0.2, -0.2, 0.3 -> sums 0.5, 0.7, 0.5, 0.8 (best: 4 frames), then falls;
    # end (walking in from 11): 0.4, 0.2, 0.3, 0.1 -> 1.0 over 4 frames, then -0.4 ...
    got = unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, ratio_above=1.0, margin_s=0.05)
    assert got.astype(int).tolist() == [1, 1, 1, 1, 0, 0, 0, 0, 1, 1, 1, 1]
    # the margin: the start's 0.8 of excess is under 0.9 frames' worth, the end's 1.0 is over
    got = unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, ratio_above=1.0, margin_s=0.09)
    assert got.astype(int).tolist() == [0] * 8 + [1] * 4
    # too short: 5 frames needed
    assert not unmatched_body_ends(hf, ratio, 10.0, min_s=0.5, ratio_above=1.0, margin_s=0.05).any()
    # a lower bound (0.7) carries both walks across the span (sums 2.5 and 2.4 at their far ends):
    # together they would leave nothing, so nothing is taken
    assert not unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, ratio_above=0.7, margin_s=0.05).any()
    # an unknown ratio counts as no excess; a pin stops the walk before it
    got = unmatched_body_ends(hf, np.where(np.arange(12) == 1, nan, ratio), 10.0, min_s=0.3, ratio_above=1.0,
                              margin_s=0.05)
    assert got.astype(int).tolist()[:4] == [1, 1, 1, 1]  # 0.5, 0.5, 0.3, 0.6
    got = unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, ratio_above=1.0, margin_s=0.05, pinned=[10])
    assert got.astype(int).tolist() == [1, 1, 1, 1] + [0] * 8  # the end's walk: frame 11 alone, too short
    # ends inside the body (more than beyond_s uncovered past them) are unmatched_edges' business
    inner = np.where(np.arange(12) < 3, nan, hf)
    got = unmatched_body_ends(inner, ratio, 10.0, min_s=0.3, ratio_above=1.0, margin_s=0.05, beyond_s=0.2)
    assert got.astype(int).tolist() == [0] * 8 + [1] * 4
    got = unmatched_body_ends(inner, ratio, 10.0, min_s=0.1, ratio_above=1.0, margin_s=0.0, beyond_s=0.3)
    assert got[3]  # three uncovered frames, 0.3 s: still the body's own start
    # a span worse than backwards everywhere: the two ends would take it all, so nothing is taken
    # (nothing left that the stretches lead to); likewise when they leave under min_s between them
    assert not unmatched_body_ends(hf, np.full(12, 2.0), 10.0, min_s=0.3, margin_s=0.05).any()
    four = np.array([1.5] * 4 + [0.2] * 4 + [1.5] * 4)  # 4 frames each end, 4 left between: kept
    assert unmatched_body_ends(hf, four, 10.0, min_s=0.4, margin_s=0.05).astype(int).tolist() == [1] * 4 + [0] * 4 + [1] * 4
    three = np.array([1.5] * 4 + [0.2] * 3 + [1.5] * 4)  # 3 left between, under min_s: nothing taken
    assert not unmatched_body_ends(np.arange(11.0), three, 10.0, min_s=0.4, margin_s=0.05).any()
    assert not unmatched_body_ends(hf, ratio, 10.0, min_s=0.0).any()
    assert not unmatched_body_ends(np.full(12, nan), ratio, 10.0).any()
    for bad in (dict(min_s=-1.0), dict(ratio_above=nan), dict(margin_s=-0.1), dict(beyond_s=np.inf)):
        with pytest.raises(ValueError):
            unmatched_body_ends(hf, ratio, 10.0, **bad)
    with pytest.raises(ValueError):
        unmatched_body_ends(hf, ratio[:-1], 10.0)


def _random_span(rng):
    """A body of 1-39 frames with one covered span (hands frames 0, 1, ... there), NaN around it."""
    n = int(rng.integers(1, 40))
    hf = np.arange(n, dtype=np.float64)
    a, b = sorted(rng.integers(0, n, size=2))
    hf[:a] = np.nan
    hf[b + 1:] = np.nan
    return n, hf


def _body_ends_reference(hf, ratio, fps, min_s, ratio_above, margin_s, beyond_s, pinned):
    """Slow reference of unmatched_body_ends: every prefix of the walk from each body end summed anew."""
    n = len(hf)
    out = np.zeros(n, dtype=bool)
    cov = [i for i in range(n) if np.isfinite(hf[i])]
    if not cov or min_s == 0:
        return out
    a, b = cov[0], cov[-1]
    need = max(1, int(round(min_s * fps)))
    for past, walk in ((a, list(range(a, b + 1))), (n - 1 - b, list(range(b, a - 1, -1)))):
        if past > beyond_s * fps:
            continue
        walk = walk[:-1]
        for j, i in enumerate(walk):
            if i in pinned:
                walk = walk[:j]
                break
        best_k, best = 0, -np.inf
        for k in range(1, len(walk) + 1):
            total = sum((ratio[i] - ratio_above) if np.isfinite(ratio[i]) else 0.0 for i in walk[:k])
            if total > best + 1e-12:
                best_k, best = k, total
        if best_k >= need and best > margin_s * fps:
            out[walk[:best_k]] = True
    if sum(1 for i in range(a, b + 1) if not out[i]) < need:
        out[:] = False
    return out


def test_unmatched_body_ends_against_a_slow_reference():
    """Random spans, ratios and pins: the rule equals summing every prefix of each walk anew."""
    from splicer.stages.coverage import unmatched_body_ends

    rng = np.random.default_rng(1)
    for _ in range(2000):
        n, hf = _random_span(rng)
        ratio = np.round(rng.uniform(0.3, 1.6, n), 2)  # two decimals: ties between prefixes are exact
        ratio[rng.random(n) < 0.05] = np.nan
        pinned = set(rng.integers(0, n, size=int(rng.integers(0, 3))).tolist())
        fps, min_s = 10.0, float(rng.choice([0.0, 0.1, 0.3, 0.5]))
        margin_s, beyond_s = float(rng.choice([0.0, 0.05, 0.2])), float(rng.choice([0.0, 0.15, 0.35]))
        got = unmatched_body_ends(hf, ratio, fps, min_s=min_s, ratio_above=1.0, margin_s=margin_s, beyond_s=beyond_s,
                                  pinned=sorted(pinned))
        want = _body_ends_reference(hf, ratio, fps, min_s, 1.0, margin_s, beyond_s, pinned)
        np.testing.assert_array_equal(got, want)


@pytest.mark.slow
def test_hands_worse_than_backwards_at_the_body_start_are_uncovered(monkeypatch):
    """*all* on the synthetic speaker (tuning seed 0): the hands take starts 4.2 s early and covers
    the body from frame 145 only, but the path covered the body's start with the calibration
    pose and other gestures, matching worse than the hands take played backwards (local ratio
    1.2-1.5; measured).  The body's own start is left alone by the rule for ends inside the body;
    the body-end rule takes frames 0-130 (every one truly uncovered), which keep the body's
    fingers, with a note; ``unmatched_edge_s=0`` switches it off.  Since 0.34.0 the second
    opinions' judge finds this start itself (frame 139, the rule then has nothing to take), so the
    rule is tested on the first alignment alone (second opinions off: ``POSITION_WEIGHT_RECHECK`` 0)."""
    import splicer.defaults as D
    from splicer import splice

    monkeypatch.setattr(D, "POSITION_WEIGHT_RECHECK", 0.0)
    from splicer.evaluation.scenarios import make_scenario, scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(0))
    on = splice(sep.body, sep.hands)
    off = splice(sep.body, sep.hands, unmatched_edge_s=0.0)
    truly = ~np.asarray(sep.covered)
    assert truly[:145].all() and not truly[145]
    for s in on.sides:
        h_on = np.isfinite(np.asarray(on.sides[s].hands_frame, dtype=np.float64))
        h_off = np.isfinite(np.asarray(off.sides[s].hands_frame, dtype=np.float64))
        assert h_off[0]  # without the rule the path's start stands: body frame 0 gets hands material
        taken = np.flatnonzero(h_off[:200] & ~h_on[:200])
        assert taken[0] == 0 and len(taken) >= 100, taken  # measured 0-130
        assert truly[taken].all()
        assert [0, int(taken[-1])] in on.report["sides"][s]["uncovered"]
        joints = [on.motion.skeleton.names.index(j) for j in on.sides[s].joints]
        far = taken[taken < taken[-1] - int(0.25 * 30) - 1]
        np.testing.assert_allclose(on.motion.joint_rotations(joints)[far], sep.body.joint_rotations(joints)[far],
                                   atol=1e-9)
    assert any("at the body's own start or end" in w and "worse than the hands take played backwards" in w
               for w in on.report["warnings"])


def test_uncover_unmatched_edges_stage_on_the_sample(monkeypatch):
    """The stage with the check's rows saying the hands' material next to an uncovered start is
    no better than the hands played backwards: taken, with its own note, where the hand's motion
    relative to the forearm reads unalike there too (stubbed at 1.5, unrelated material's level);
    kept, with a note, where it reads alike (the sample's own material: it is genuine); off with
    ``unmatched_edge_s=0``, and never without the check's rows."""
    from dataclasses import replace

    import splicer.stages.recheck as R

    from splicer import splice
    from splicer.align.evidence import Evidence
    from splicer.options import SpliceOptions
    from splicer.stages.coverage import uncover_unsure_edges
    from splicer.stages.log import Log

    r = splice(MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh", side="left").sides["left"]
    n, fps = len(r.hands_frame), r.markers.spaces.body_fps  # 601 frames at 30 fps
    hf = np.asarray(r.hands_frame, dtype=np.float64).copy()
    hf[:40] = np.nan
    est = np.where(np.arange(n) < 40, np.nan, 0.01)
    conf = replace(r.alignment.confidence, est_error_s=est, confidence=np.where(np.isfinite(est), 0.9, np.nan))
    rows = np.full(201, 1.0)  # the check at 10 fps: (601 - 1) / 3 + 1 rows
    rows[:50] = 9.0  # body frames 0-149 cost 90 % of the backwards pass (9 over 10)
    ev = Evidence(float(rows.sum()), 2010.0, 10.0, rows=rows, backwards_rows=np.full(201, 10.0))
    side = replace(r, hands_frame=hf, alignment=replace(r.alignment, covered=(40, n - 1), confidence=conf, evidence=ev))
    log = Log()
    alike = uncover_unsure_edges({"left": side}, SpliceOptions(), log)["left"]  # the sample's own mismatch
    assert alike is side
    assert any("40-" in w and "it stays covered" in w for w in log.warnings)
    monkeypatch.setattr(R, "side_mismatch", lambda r, **kw: np.where(np.isfinite(r.hands_frame), 1.5, np.nan))
    log = Log()
    out = uncover_unsure_edges({"left": side}, SpliceOptions(), log)["left"]
    first = int(np.flatnonzero(np.isfinite(out.hands_frame))[0])
    # over the 2 s window (20 rows) the ratio exceeds 0.85 while 19 rows or more cost 9: up to row ~41,
    # body frame ~125, short of the change at body frame 150
    assert 120 <= first <= 130 and out.alignment.covered == (first, n - 1)
    assert np.isnan(out.alignment.confidence.est_error_s[:first]).all()
    assert any(f"40-{first - 1}" in w and "played backwards" in w for w in log.warnings)
    assert uncover_unsure_edges({"left": side}, SpliceOptions(unmatched_edge_s=0.0))["left"] is side
    no_rows = replace(side, alignment=replace(side.alignment, evidence=Evidence(1.0, 2.0, 10.0)))
    assert uncover_unsure_edges({"left": no_rows}, SpliceOptions())["left"] is no_rows


def test_uncover_unsure_edges_stage_on_the_sample():
    """The stage on a real side: frames taken get NaN hands frames, the covered span narrows, the
    confidence is uncovered there, a pin stops it, and ``unsure_edge_s=0`` switches it off."""
    from dataclasses import replace

    from splicer import splice
    from splicer.align.frames import Pin
    from splicer.options import SpliceOptions
    from splicer.stages.coverage import uncover_unsure_edges
    from splicer.stages.log import Log

    r = splice(MOTIONS / "sample_body.bvh", MOTIONS / "sample_hands.bvh", side="left").sides["left"]
    n, fps = len(r.hands_frame), r.markers.spaces.body_fps
    hf = np.asarray(r.hands_frame, dtype=np.float64).copy()
    hf[:40] = np.nan  # uncovered start
    conf = r.alignment.confidence
    est = np.where(np.arange(n) < 40, np.nan, 0.01)
    est[40:90] = 0.5  # 50 frames (1.7 s) unsure next to it
    conf = replace(conf, est_error_s=est, confidence=np.where(np.isfinite(est), 0.5, np.nan),
                   spread_frames=np.where(np.isfinite(est), 1.0, np.nan))
    side = replace(r, hands_frame=hf, alignment=replace(r.alignment, covered=(40, n - 1), confidence=conf))
    log = Log()
    out = uncover_unsure_edges({"left": side}, SpliceOptions(), log)["left"]
    assert np.isnan(out.hands_frame[:90]).all() and np.isfinite(out.hands_frame[90:]).all()
    assert out.alignment.covered == (90, n - 1)
    c = out.alignment.confidence
    for k in ("est_error_s", "confidence", "spread_frames"):
        assert np.isnan(getattr(c, k)[:90]).all() and np.isfinite(getattr(c, k)[90:]).all()
    assert any("40-89 (1.7 s)" in w and "taken as uncovered" in w for w in log.warnings)
    # a pin at body frame 60, inside the unsure stretch: nothing taken
    pinned = replace(side, markers=replace(side.markers, pins=(Pin(60, int(hf[100]), 2, "test"),)))
    assert uncover_unsure_edges({"left": pinned}, SpliceOptions())["left"] is pinned
    assert uncover_unsure_edges({"left": side}, SpliceOptions(unsure_edge_s=0.0))["left"] is side


@pytest.mark.slow
def test_unsure_start_of_an_all_scenario_keeps_the_body_fingers():
    """The protocol's *all* scenario on the synthetic speaker (tuning seed 1): the hands take
    holds other material before its genuine span and covers part of the body; the path matches
    body frames the hands never show to that material, and is unsure there.  With the stage
    those frames are reported uncovered (all of them truly so) and keep the body's own fingers.
    Open ends on one take's first and last frames (``both_skip="off"``): since 0.33.0 the open
    ends skip both takes' heads here and start on the genuine material, leaving the rule nothing."""
    from splicer import splice
    from splicer.evaluation.scenarios import make_scenario, scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(1))
    on = splice(sep.body, sep.hands, unmatched_edge_s=0.0, both_skip="off")  # the unsure rule alone (the other: below)
    off = splice(sep.body, sep.hands, unsure_edge_s=0.0, unmatched_edge_s=0.0, both_skip="off")
    for s in on.sides:
        h_on = np.isfinite(np.asarray(on.sides[s].hands_frame, dtype=np.float64))
        h_off = np.isfinite(np.asarray(off.sides[s].hands_frame, dtype=np.float64))
        taken = h_off & ~h_on
        assert not (h_on & ~h_off).any()  # only ever takes frames away
        assert taken.sum() >= 30, taken.sum()
        assert np.mean(~np.asarray(sep.covered)[taken]) >= 0.9  # truly uncovered
        assert any("taken as uncovered" in w for w in on.report["warnings"])
        # away from the blend window, the output's finger rotations there are the body's own
        joints = [on.motion.skeleton.names.index(j) for j in on.sides[s].joints]
        idx = np.flatnonzero(taken)
        a, b = on.sides[s].alignment.covered
        far = idx[(idx < a - int(0.25 * 30) - 1) | (idx > b + int(0.25 * 30) + 1)]  # 0.18.0: the left's at its end
        assert len(far) > 0
        np.testing.assert_allclose(on.motion.joint_rotations(joints)[far], sep.body.joint_rotations(joints)[far],
                                   atol=1e-9)


@pytest.mark.slow
def test_unmatched_end_of_hands_covering_part_of_the_body_keeps_the_body_fingers():
    """*extra* + *short* on the synthetic speaker (seed 1): the hands take covers part of the body
    and holds other material before and after; the path matches body frames past the genuine
    span to that material.  The check against the hands played backwards finds it no better
    than unrelated there: those frames are reported uncovered (all truly so) and keep the body's
    fingers; with the rule off they get the other material.  The rule for unsure stretches next
    to uncovered frames (``unsure_edge_s``) is off in both runs: since 0.18.0 it takes most of
    these frames itself (928 -> 425 frames given material on the left, measured; 0.17.0: 889),
    and both rules together leave 287, as before."""
    from splicer import splice
    from splicer.evaluation.scenarios import make_scenario, scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("extra+short"), rng=np.random.default_rng(1))
    on = splice(sep.body, sep.hands, unsure_edge_s=0.0)
    off = splice(sep.body, sep.hands, unmatched_edge_s=0.0, unsure_edge_s=0.0)
    truly = ~np.asarray(sep.covered)
    for s in on.sides:
        h_on = np.isfinite(np.asarray(on.sides[s].hands_frame, dtype=np.float64))
        h_off = np.isfinite(np.asarray(off.sides[s].hands_frame, dtype=np.float64))
        taken = h_off & ~h_on
        assert not (h_on & ~h_off).any()
        assert taken.sum() >= 300, taken.sum()  # measured 641 of the 928 truly uncovered frames off gave material
        assert truly[taken].all()
        assert any("played backwards" in w and "taken as uncovered" in w for w in on.report["warnings"])
        joints = [on.motion.skeleton.names.index(j) for j in on.sides[s].joints]
        idx = np.flatnonzero(taken)
        far = idx[np.abs(idx[:, None] - np.flatnonzero(h_on)[None, :]).min(axis=1) > int(0.25 * 30) + 1]
        assert len(far) > 0
        np.testing.assert_allclose(on.motion.joint_rotations(joints)[far], sep.body.joint_rotations(joints)[far],
                                   atol=1e-9)


def _edges_reference(hf, flag, fps, min_s, pinned, beyond_s):
    """Slow reference of the edge rules: walk in from each end of the covered span."""
    n = len(hf)
    out = np.zeros(n, dtype=bool)
    cov = np.flatnonzero(np.isfinite(hf))
    if len(cov) == 0 or min_s == 0:
        return out
    need = max(1, int(round(min_s * fps)))
    a, b = int(cov[0]), int(cov[-1])
    for end, step, past in ((a, 1, a), (b, -1, n - 1 - b)):
        if past <= beyond_s * fps:
            continue
        i, k = end, 0
        while a <= i <= b and flag[i] and i not in pinned:
            i, k = i + step, k + 1
        if k >= need and a <= i <= b and i not in pinned:  # stopped inside the span by a kept frame
            lo, hi = (end, end + k) if step == 1 else (end - k + 1, end + 1)
            out[lo:hi] = True
    return out


def test_edge_rules_against_a_slow_reference():
    """Random spans, ratios, estimates and pins: both rules equal a walk in from each end."""
    from splicer.stages.coverage import unmatched_edges, unsure_edges

    rng = np.random.default_rng(0)
    for _ in range(3000):
        n, hf = _random_span(rng)
        if rng.random() < 0.05:
            hf[:] = np.nan
        ratio = np.where(rng.random(n) < 0.7, rng.uniform(0.86, 1.2, n), rng.uniform(0.0, 0.85, n))
        ratio[rng.random(n) < 0.05] = np.nan
        est = rng.uniform(0.0, 0.5, n)
        pinned = set(rng.integers(0, n, size=int(rng.integers(0, 3))).tolist())
        fps, min_s, beyond_s = 10.0, float(rng.choice([0.0, 0.1, 0.3, 0.5])), float(rng.choice([0.0, 0.15, 0.35]))
        got = unmatched_edges(hf, ratio, fps, min_s=min_s, ratio_above=0.85, beyond_s=beyond_s, pinned=sorted(pinned))
        want = _edges_reference(hf, np.nan_to_num(ratio, nan=-1.0) > 0.85, fps, min_s, pinned, beyond_s)
        np.testing.assert_array_equal(got, want)
        got = unsure_edges(hf, est, fps, min_s=min_s, error_s=0.2, pinned=sorted(pinned))
        want = _edges_reference(hf, est > 0.2, fps, min_s, pinned, 0.0)
        np.testing.assert_array_equal(got, want)


def test_alike_material_stays_covered_on_the_protocol():
    """Synthetic *all*, seed 101: the hands' genuine material covers body frames 20-1403.  Over
    body frames 0-334 the path cost more than with the hands take played backwards (the second
    performance's arm noise at a slow start), and 0.25.0-0.35.0 took them as uncovered, although
    aligned within 0.01 s: 7.5 degrees of finger error.  Along them the hand moves relative to the
    forearm alike in both takes (median mismatch 0.02-0.06), so since 0.36.0 they stay covered,
    with a note."""
    from splicer import splice
    from splicer.evaluation.scenario_types import alignment_error_s, scenario
    from splicer.evaluation.scenarios import make_scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(101))
    assert np.flatnonzero(sep.covered)[0] == 20
    res = splice(sep.body, sep.hands)
    assert sum("it stays covered" in w for w in res.report.warnings) == 2  # one per side
    for r in res.sides.values():
        hf = np.asarray(r.hands_frame, dtype=np.float64)
        assert np.isfinite(hf[20:335]).all()
        e = np.abs(alignment_error_s(sep, hf)[20:335])
        assert np.median(e) < 0.05
