"""Scenario generators of real sessions (splicer.evaluation.scenarios) and their scoring (splicer.evaluation.scenario_eval)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from splicer.evaluation.baselines import generic_dtw_frames
from splicer.errors import SplicerError
from splicer.rig.roles import find_roles
from splicer.model.rotations import quat_angle
from splicer.evaluation.scenario_eval import (SCENARIO_METHODS, alignment_scores, confidence_auc, evaluate_scenario_pair,
                                   flag_scores, pause_scores,
                                   ranges_mask, report_flags, summarize_scenarios, uncovered_scores)
from splicer.evaluation.scenarios import (SCENARIOS, Scenario, _wrist_speed, alignment_error_s, hands_take_time, invert_time,
                               make_scenario, scenario)
from splicer.evaluation.separate import finger_joints, separate
from splicer.evaluation.synth import make_gesture_take

STILL = dict(warp_speed=(1.0, 1.0))  # no re-timing: truth = 2 x body frame at 2x the rate


@pytest.fixture(scope="module")
def take():
    return make_gesture_take(12.0, 30.0, np.random.default_rng(4))


def _make(take, seed=1, **kw):
    return make_scenario(take, Scenario("test", **kw), rng=np.random.default_rng(seed))


def test_base_equals_separate(take):
    s = make_scenario(take, "base", rng=np.random.default_rng(8))
    ref = separate(take, rng=np.random.default_rng(8))
    # the same draws and the same arithmetic; numpy's SIMD loops may round the last bit
    # differently with the arrays' memory alignment (CI saw 1 ulp), so equal to 1e-12 relative
    np.testing.assert_allclose(s.hands.channels, ref.hands.channels, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(s.body.channels, ref.body.channels, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(s.truth, ref.truth, atol=0.02)  # exact inverse of the content vs the warp
    assert s.genuine == (0, s.hands.n_frames - 1)
    np.testing.assert_allclose(alignment_error_s(s, s.truth), 0.0, atol=1e-12)


def test_no_warp_truth_is_twice_the_frame(take):
    s = _make(take, **STILL)
    np.testing.assert_allclose(s.truth, 2.0 * np.arange(take.n_frames), atol=1e-9)
    # a method 3 hands frames late is 3 / 60 s off
    np.testing.assert_allclose(alignment_error_s(s, s.truth + 3.0)[:-2], 0.05, atol=1e-9)


def test_pause_body_gives_flat_truth_of_k_frames(take):
    s = _make(take, pause_body_s=(1.0, 1.0), **STILL)
    p, k = s.params["pause_body"]
    assert k == 30  # 1 s at 30 fps
    assert s.body.n_frames == take.n_frames + 30
    d = np.diff(s.truth)
    flat = np.flatnonzero(d == 0)
    np.testing.assert_array_equal(flat, np.arange(p, p + 30))  # exactly k zero steps, consecutive
    np.testing.assert_allclose(np.delete(d, flat), 2.0, atol=1e-9)
    np.testing.assert_allclose(s.truth[p:p + 31], 2.0 * p, atol=1e-9)
    assert s.params["pause_windows"] == [(p, min(p + 30 + 90, s.body.n_frames - 1))]
    # placed where the take moves slowly: wrist speed at most the median of the middle 60 %
    sp = _wrist_speed(take, find_roles(take.skeleton))
    n = take.n_frames
    assert sp[p] <= np.median(sp[int(0.2 * n):int(0.8 * n)]) + 1e-12
    # the body holds: its frames in the pause are the same pose
    held = s.body.channels[p + 1:p + 31]
    np.testing.assert_allclose(held, np.broadcast_to(s.body.channels[p], held.shape))
    # a method that walks on through the pause is off by up to 1 s at its end
    walk = 2.0 * np.arange(s.body.n_frames, dtype=float)
    walk[p + 31:] = s.truth[p + 31:]
    assert alignment_error_s(s, walk)[p + 30] == pytest.approx(1.0)


def test_pause_hands_gives_a_step_of_K_frames(take):
    s = _make(take, pause_hands_s=(1.0, 1.0), **STILL)
    q, kh = s.params["pause_hands"]
    assert kh == 60  # 1 s at 60 fps
    assert s.hands.n_frames == 2 * (take.n_frames - 1) + 1 + 60
    d = np.diff(s.truth)
    big = np.flatnonzero(d > 2.0 + 1e-9)
    assert len(big) == 1 and d[big[0]] == pytest.approx(2.0 + 60)
    assert big[0] == q // 2  # the body frame before the held instant (hands frame q = take frame q / 2)
    assert s.params["pause_windows"] == [(q // 2, min(q // 2 + 90, take.n_frames - 1))]
    # every held frame shows the same instant: any of them is right for that instant
    held = np.arange(q, q + 61, dtype=float)
    np.testing.assert_allclose(hands_take_time(s, held), q / 2.0)


def test_extra_material_shifts_truth_by_s_fps(take):
    base = _make(take, seed=3)
    s = _make(take, seed=3, extra_begin_s=(3.0, 3.0), extra_end_s=(2.0, 2.0))
    assert s.params["extra_begin_frames"] == 180 and s.params["extra_end_frames"] == 120  # 3 s, 2 s at 60 fps
    np.testing.assert_allclose(s.truth, base.truth + 180.0, atol=1e-9)
    assert s.hands.n_frames == base.hands.n_frames + 300
    assert s.genuine == (180, 180 + base.hands.n_frames - 1)
    assert np.isnan(s.hands_time[:180]).all() and np.isnan(s.hands_time[-120:]).all()
    # the still part shows one take frame; the moving part advances at the hands rate
    eb = s.params["extra_begin"]
    assert eb["still_frames"] + eb["move_frames"] == 180
    assert 0.3 * 180 - 1 <= eb["still_frames"] <= 0.7 * 180 + 1
    # a body frame matched 60 hands frames before the genuine span is 1 s off (plus its own time)
    hf = np.full(take.n_frames, 180.0 - 60.0)
    assert alignment_error_s(s, hf)[0] == pytest.approx(1.0)


def test_extra_material_is_other_material(take):
    s = _make(take, seed=2, extra_begin_s=(4.0, 4.0), **STILL)
    eb = s.params["extra_begin"]
    st = eb["still_frames"]
    fj = finger_joints(take)
    # fingers hold during the still part (only the 0.5 deg capture noise moves them)
    q = s.hands.rotations[:st - 1, fj]
    assert quat_angle(q, q[:1]).max() < 5.0
    # the genuine span starts where the body starts: same fingers as the take's frame 0
    g0 = s.genuine[0]
    assert quat_angle(s.hands.rotations[g0, fj], take.rotations[0, fj]).mean() < 1.5


def test_short_hands_truth_nan_outside(take):
    s = _make(take, cover=(0.5, 0.5), **STILL)
    c, ta, tb = s.params["cover"]
    assert c == 0.5 and tb - ta == pytest.approx(0.5 * (take.n_frames - 1))
    inside = (np.arange(take.n_frames) >= ta) & (np.arange(take.n_frames) <= tb)
    np.testing.assert_array_equal(s.covered, inside)
    first = np.flatnonzero(inside)[0]
    np.testing.assert_allclose(s.truth[inside], 2.0 * (np.arange(take.n_frames)[inside]) - 2.0 * np.ceil(2 * ta) / 2,
                               atol=1e-9)
    assert 0.0 <= s.truth[first] <= 1.0  # the hands start within a body frame (2 hands frames) of the first covered body frame
    assert np.isnan(alignment_error_s(s, np.zeros(take.n_frames))[~inside]).all()


def test_clip_covers_3_to_10_percent(take):
    s = make_scenario(take, "clip", rng=np.random.default_rng(0))
    c = s.params["cover"][0]
    assert 0.03 <= c <= 0.1
    assert s.covered.mean() == pytest.approx(c, abs=2.0 / take.n_frames)


def test_rate_2997_vs_120(take):
    s = _make(take, body_fps=29.97, hands_fps=120.0, **STILL)
    assert s.body.fps == pytest.approx(29.97) and s.hands.fps == pytest.approx(120.0)
    nb = int(np.floor((take.n_frames - 1) * 29.97 / 30.0)) + 1
    assert s.body.n_frames == nb == 360
    # body frame i is at i / 29.97 s; the hands frame at that instant is 120 i / 29.97
    np.testing.assert_allclose(s.truth, np.arange(nb) * 120.0 / 29.97, atol=1e-9)
    np.testing.assert_allclose(s.body_time, np.arange(nb) * 30.0 / 29.97, atol=1e-12)


def test_speed_range(take):
    s = make_scenario(take, "speed", rng=np.random.default_rng(0))
    sp = s.params["speed"]
    assert sp.min() >= 0.33 - 1e-3 and sp.max() <= 3.0 + 1e-3
    assert sp.max() / sp.min() > 2.0


def test_imitation_changes_arms_not_fingers(take):
    base = _make(take, seed=5, **STILL)
    s = _make(take, seed=5, imitation=True, **STILL)
    r = find_roles(take.skeleton)
    fj = finger_joints(take, r)
    np.testing.assert_allclose(quat_angle(s.hands.rotations[:, fj], base.hands.rotations[:, fj]), 0.0, atol=1e-4)
    arm = r.sides["right"]
    d_elbow = quat_angle(s.hands.rotations[:, arm.elbow], base.hands.rotations[:, arm.elbow])
    d_wrist = quat_angle(s.hands.rotations[:, arm.wrist], base.hands.rotations[:, arm.wrist])
    assert 0.5 < d_elbow.mean() < 20.0
    assert 0.5 < d_wrist.mean() < 20.0
    f = s.params["imitation"]["right_gesture_factors"]
    assert len(f) >= 3 and f.min() >= 0.7 and f.max() <= 1.3
    np.testing.assert_array_equal(s.truth, base.truth)


def test_all_and_names(take):
    assert scenario("all") == scenario("extra+short+pause-hands+pause-body+speed+rate+imitation").__class__(
        **{**scenario("extra+short+pause-hands+pause-body+speed+rate+imitation").__dict__, "name": "all"})
    s = make_scenario(take, "all", rng=np.random.default_rng(0))
    assert np.isnan(s.truth).any() and np.isfinite(s.truth).sum() > 50
    assert s.hands.fps == 120.0
    np.testing.assert_allclose(alignment_error_s(s, s.truth)[s.covered], 0.0, atol=1e-9)
    with pytest.raises(SplicerError, match="unknown scenario"):
        scenario("extra+nope")
    assert "all" in SCENARIOS and "base" in SCENARIOS


def test_invert_time():
    np.testing.assert_allclose(invert_time(np.array([0.0, 1.0, 1.0, 2.0]), np.array([0.5, 1.0, 1.5, 3.0])),
                               [0.5, 2.0, 2.5, np.nan])


def test_ranges_mask_and_report_flags():
    np.testing.assert_array_equal(ranges_mask([[1, 2], [4, 9]], 6), [0, 1, 1, 0, 1, 1])
    unc, low = report_flags({"uncovered": [[0, 1]], "hands_frame": []}, 4)
    np.testing.assert_array_equal(unc, [1, 1, 0, 0])
    assert low is None
    assert report_flags({}, 3) == (None, None)
    with pytest.raises(ValueError):
        ranges_mask([[3, 1]], 5)


def test_flag_scores_worked_example():
    # 10 frames; 0-1 truly uncovered; errors of covered frames:
    err = np.array([np.nan, np.nan, 0.01, 0.02, 0.2, 0.3, 0.01, 0.5, 0.07, np.nan])
    covered = np.array([0, 0, 1, 1, 1, 1, 1, 1, 1, 1], bool)
    unc = ranges_mask([[0, 0]], 10)            # frame 1 is missed (uncovered, not reported): bad
    low = ranges_mask([[3, 5]], 10)           # flags 3 (good), 4, 5 (bad)
    f = flag_scores(err, covered, unc, low)
    # bad (> 0.1 s): frame 1 (uncovered, unreported), 4, 5, 7, 9 (covered, no hands frame) -> 5; flagged: 4, 5
    assert f["n_bad"] == 5 and f["flag_bad"] == pytest.approx(40.0)
    # good (< 0.05 s): frames 2, 3, 6 -> flagged: 3
    assert f["n_good"] == 3 and f["flag_good"] == pytest.approx(100.0 / 3)
    assert np.isnan(flag_scores(err, covered, None, None)["flag_bad"])
    u = uncovered_scores(covered, unc)
    assert u["unc_found"] == 50.0 and u["unc_false"] == 0.0


def test_pause_scores_worked_example(take):
    s = _make(take, pause_body_s=(1.0, 1.0), **STILL)
    (a, b), = s.params["pause_windows"]
    err = np.zeros(2 * s.body.n_frames)
    err[a] = 0.3                       # left side, in the window
    err[s.body.n_frames + b] = 0.6     # right side, last frame of the window
    err[0] = 5.0                       # outside
    ps = pause_scores(err, s, 2)
    assert ps["pause_max_s"] == 0.6 and ps["pause_mean_s"] == pytest.approx(0.9 / (2 * (b - a + 1)))
    assert np.isnan(pause_scores(np.zeros(2 * take.n_frames), _make(take, **STILL), 2)["pause_mean_s"])


def test_confidence_auc_worked_example():
    conf = np.array([0.9, 0.8, 0.2, 0.8, 0.1, 0.5])
    err = np.array([0.0, 0.01, 0.5, 0.3, np.nan, 0.07])  # NaN: left out; 0.07: neither class
    # good {0.9, 0.8} vs bad {0.2, 0.8}: 3 wins and one tie of 4 pairs
    assert confidence_auc(conf, err) == pytest.approx(0.875)
    assert np.isnan(confidence_auc(conf, np.zeros(6)))
    assert confidence_auc(np.array([0.0, 1.0]), np.array([0.0, np.inf])) == 0.0  # confident where wrong


def test_alignment_scores_worked_example():
    err = np.array([0.0, 0.04, 0.1, 0.2, np.nan, np.nan])
    covered = np.array([1, 1, 1, 1, 1, 0], bool)
    a = alignment_scores(err, covered, 30.0)
    assert a["align_mean_s"] == pytest.approx(0.085) and a["align_mean_f"] == pytest.approx(2.55)
    assert a["align_max_s"] == 0.2 and a["within_50ms"] == 50.0 and a["within_100ms"] == 75.0
    assert a["missing"] == pytest.approx(20.0)
    assert a["align_p95_s"] == pytest.approx(np.percentile([0, 0.04, 0.1, 0.2], 95))


def test_generic_dtw_open_ends_locates_a_subsequence():
    t = make_gesture_take(20, 30, np.random.default_rng(7))
    roles = find_roles(t.skeleton)
    body = t.slice(150, 450)
    true = np.arange(300) + 150.0
    fixed = generic_dtw_frames(body, t, roles["right"], roles["right"], roles.up)
    open_ = generic_dtw_frames(body, t, roles["right"], roles["right"], roles.up, open_ends=True)
    assert np.abs(open_ - true).mean() < 0.5 * np.abs(fixed - true).mean()
    assert abs(open_[0] - 150) < 15 and abs(open_[-1] - 449) < 15


def test_evaluate_scenario_pair(take):
    s = make_scenario(take, "extra+short", rng=np.random.default_rng(2))
    recs = evaluate_scenario_pair(take, s, methods=("oracle", "uniform scaling", "splice (smooth time map)"))
    by = {r["method"]: r for r in recs}
    assert by["oracle"]["align_mean_s"] < 1e-9 and by["oracle"]["finger_deg"] < 1.5
    assert by["uniform scaling"]["align_mean_s"] > 0.1
    assert 0 < by["oracle"]["covered"] < 100
    for m in ("oracle", "uniform scaling"):  # no report: no uncovered / low-confidence ranges to score
        assert np.isnan(by[m]["flag_bad"]) and np.isnan(by[m]["unc_found"]) and np.isnan(by[m]["conf_auc"])
    # the splice (open ends by default) reports uncovered and low-confidence ranges and a per-frame
    # confidence, so all are scored.  Measured here: unc_found 0.0 %, unc_false 0.0 % (it covers body
    # frames 0-360 on both sides while the truth covers 82-325: the hands' extra material is matched
    # to the body frames the hands do not show), flag_bad 16.0 %, flag_good 3.2 %, AUC 0.52
    sp = by["splice (smooth time map)"]
    for k in ("unc_found", "unc_false", "flag_bad", "flag_good"):
        assert 0.0 <= sp[k] <= 100.0
    assert 0.0 <= sp["conf_auc"] <= 1.0
    runs = pd.DataFrame([{"take": "t", "scenario": "x", "seed": 0, **r} for r in recs])
    t = summarize_scenarios(runs)
    assert list(t.index.get_level_values("method")) == ["oracle", "uniform scaling", "splice (smooth time map)"]
    assert set(SCENARIO_METHODS) >= set(by)


def test_known_answer_layouts(take):
    """The issue's known-answer inputs: [3 s still] + body + [3 s other motion]; hands on the middle half."""
    s = _make(take, extra_begin_s=(3.0, 3.0), extra_end_s=(3.0, 3.0), still_share=(1.0, 1.0),
              still_share_end=(0.0, 0.0), **STILL)
    assert s.params["extra_begin"]["move_frames"] == 0 and s.params["extra_end"]["still_frames"] == 0
    np.testing.assert_allclose(s.truth, 180.0 + 2.0 * np.arange(take.n_frames), atol=1e-9)
    m = _make(take, cover=(0.5, 0.5), cover_start=0.25, **STILL)
    cov = np.flatnonzero(m.covered)
    assert cov[0] == 90 and cov[-1] == 270  # (n - 1) = 360: frames 90..270


def _runs_of(frames):
    """Inclusive [first, last] ranges of the True runs of a boolean mask."""
    idx = np.flatnonzero(frames)
    if len(idx) == 0:
        return []
    cuts = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([[idx[0]], idx[cuts + 1]])
    ends = np.concatenate([idx[cuts], [idx[-1]]])
    return [[int(a), int(b)] for a, b in zip(starts, ends)]


def test_report_ranges_are_scored(take, monkeypatch):
    """The real splice's result, with the ranges a future splice reports added to its report
    (uncovered: exactly the truly uncovered frames; low confidence: where its error > 0.1 s)."""
    import splicer.evaluation.scenario_eval as se

    s = make_scenario(take, Scenario("t", cover=(0.6, 0.6), cover_start=0.2), rng=np.random.default_rng(3))
    real = se.splice

    missing = []  # covered body frames the splice itself leaves without a hands frame (open ends)
    n_bad = []

    def reporting_splice(body, hands, **kw):
        res = real(body, hands, **kw)
        sides = {}
        for side, r in res.sides.items():
            err = alignment_error_s(s, r.hands_frame)  # NaN: not covered, or no hands frame
            bad = s.covered & ~(err <= 0.1)  # a covered frame without a hands frame is wrong
            missing.append(s.covered & ~np.isfinite(r.hands_frame))
            n_bad.append(int(bad.sum()))
            sr = res.report.sides[side]  # the report is read-only: replace the side with the ranges added
            sides[side] = replace(sr, extra={**sr.extra, "uncovered": _runs_of(~s.covered),
                                             "low_confidence": _runs_of(bad),
                                             "confidence": np.where(bad, 0.0, 1.0).tolist()})
        return replace(res, report=replace(res.report, sides=sides))

    monkeypatch.setattr(se, "splice", reporting_splice)
    rec, = evaluate_scenario_pair(take, s, methods=("splice (smooth time map)",))
    assert rec["unc_found"] == 100.0 and rec["unc_false"] == 0.0
    assert rec["flag_bad"] == 100.0 and rec["flag_good"] == 0.0
    assert rec["n_bad"] == sum(n_bad) > 0 and rec["n_good"] > 0  # both sides' judged frames
    miss = np.concatenate(missing)
    assert rec["missing"] == pytest.approx(100.0 * miss.sum() / (len(missing) * s.covered.sum()))
    assert rec["conf_auc"] == 1.0


def test_write_scenario_round_trip(take, tmp_path):
    from splicer.io.bvh import read_bvh
    from splicer.evaluation.scenarios import write_scenario

    s = make_scenario(take, "extra+rate", rng=np.random.default_rng(0))
    body_f, hands_f, truth_f = write_scenario(s, tmp_path / "x")
    b, h = read_bvh(body_f), read_bvh(hands_f)
    assert b.n_frames == s.body.n_frames and b.fps == pytest.approx(29.97, abs=1e-3)
    assert h.n_frames == s.hands.n_frames and h.fps == pytest.approx(120.0, abs=1e-3)
    t = pd.read_csv(truth_f)
    np.testing.assert_allclose(t["hands_frame"], s.truth, atol=1e-6)
    np.testing.assert_allclose(t["body_time_s"], s.body_time / 30.0, atol=1e-6)


def test_position_term_keeps_a_second_performance_on_track():
    """A second performance (imitation: per-gesture arm amplitudes, wrist drift, 1-2 degrees of
    arm noise) of a 20-s synthetic take, seed 3: D1 alone (``position_weight=0``, the paper)
    loses the performance for seconds (3.5 s mean error, measured); with the position term
    (the default) the mean error is 0.15 s."""
    from splicer import splice

    take = make_gesture_take(20.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("imitation"), rng=np.random.default_rng(3))

    def mean_error(**kw):
        r = splice(sep.body, sep.hands, **kw)
        e = np.concatenate([np.abs(alignment_error_s(sep, np.asarray(sd.hands_frame, float)))[sep.covered]
                            for sd in r.sides.values()])
        return float(np.nanmean(e))

    assert mean_error(position_weight=0) > 1.0
    assert mean_error() < 0.25


def test_a_noisy_pair_gets_a_second_opinion_on_the_position_weight(monkeypatch):
    """The synthetic speaker, *speed* + *imitation*, seed 0: a second performance whose hands slow
    to a third of the body's pace.  Without the hand-in-forearm signs in pass 1 (0.29.0; switched
    off here to isolate the second opinion), with the arms' positions weighed 10 (noise matching's
    weight) pass 1 runs about 1.7 s ahead through the slow gesture (mean error 0.17 s, measured);
    aligned again at 30, the hand's motion relative to the forearm matches better along the map,
    that alignment is kept, and the mean error is 0.026 s (measured).  With the signs (the
    default) the first alignment is already within 0.019 s and is kept."""
    import splicer.defaults as D
    from splicer import splice
    from splicer.evaluation.scenarios import make_scenario, scenario

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("speed+imitation"), rng=np.random.default_rng(0))

    def mean_error(res):
        e = []
        for r in res.sides.values():
            err = alignment_error_s(sep, np.asarray(r.hands_frame, dtype=np.float64))
            e.append(np.nanmean(err[np.asarray(sep.covered)]))
        return float(np.mean(e))

    signs = splice(sep.body, sep.hands)
    assert signs.report.to_dict()["sides"]["left"]["pass1"]["wrist_signs"] and mean_error(signs) < 0.03
    monkeypatch.setattr(D, "WRIST_SIGN_SCALE", 0.0)
    on = splice(sep.body, sep.hands)
    rep = on.report.to_dict()
    assert rep["sides"]["left"]["pass1"]["position_weight"] == D.POSITION_WEIGHT_RECHECK
    assert any("weighed 30 instead of 10" in w for w in rep["warnings"])
    assert any("arm is noisier" in w for w in rep["warnings"])  # noise matching's own note kept
    monkeypatch.setattr(D, "POSITION_WEIGHT_RECHECK", 0.0)
    off = splice(sep.body, sep.hands)
    assert off.report.to_dict()["sides"]["left"]["pass1"]["position_weight"] == D.POSITION_WEIGHT_NOISY
    assert mean_error(on) < 0.06 and mean_error(off) > 0.12


def test_a_second_performance_at_another_tempo_is_smoothed_to_it(monkeypatch):
    """The synthetic speaker, *speed* + *imitation*, seed 8 (the seeds 5-9 draw): the hands run three
    times faster than the body for 23 s, then three times slower.  Noise matching smooths both
    takes over 0.2 s, which blurs the fast hands over three times as much of the performance as
    the body; both sides took the slow stretch about 100 body frames early (mean error 0.229 s,
    measured on 0.26.1).  The second opinion smoothed to the first maps' tempo
    (:mod:`splicer.align.tempo`) is kept, and the mean error is 0.042 s (measured), the mechanism
    isolated here from pass 1's hand-in-forearm signs (0.29.0), with which the first alignment
    is within 0.017 s, and is kept."""
    import splicer.defaults as D
    from splicer import splice

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("speed+imitation"), rng=np.random.default_rng(8))

    def mean_error(res):
        return float(np.mean([np.nanmean(alignment_error_s(sep, np.asarray(r.hands_frame, dtype=np.float64))[sep.covered])
                              for r in res.sides.values()]))

    assert mean_error(splice(sep.body, sep.hands)) < 0.025
    monkeypatch.setattr(D, "WRIST_SIGN_SCALE", 0.0)
    on = splice(sep.body, sep.hands)
    notes = on.report.to_dict()["warnings"]
    assert any("smoothed further where one take ran faster" in w for w in notes)
    assert all(d["pass1"]["tempo_matched"] and d["pass1"]["position_weight"] == D.POSITION_WEIGHT_RECHECK
               for d in on.report.to_dict()["sides"].values())
    assert "tempo-matched second opinion" in on.report.to_dict()["timings_s"]
    monkeypatch.setattr(D, "TEMPO_MATCHED", False)
    off = splice(sep.body, sep.hands)
    assert not any("smoothed further" in w for w in off.report.to_dict()["warnings"])
    assert not any(d["pass1"]["tempo_matched"] for d in off.report.to_dict()["sides"].values())
    assert mean_error(on) < 0.06 and mean_error(off) > 0.15


def test_a_second_performance_signs_its_small_motions_softly(monkeypatch):
    """The synthetic speaker, *imitation*, tuning seed 2: noise matching fires, and pass 1 with
    fixed ends then lets a direction sign rise over half the motion's RMS speed
    (``SIGN_RAMP_NOISY``) instead of 3 %, so the arm noise's small velocities in the rests between
    gestures count as little motion.  Mean error 0.0095 s, against 0.0121 s with the clean pairs'
    ramp (measured on 0.29.0, whose pass 1 reads the hand's turns in the forearm too; 0.0113 against
    0.0149 s on 0.26.0, whose wrist rounds until settled mend part of the difference; 0.0127 against
    0.0195 s before; 0.19.0 had the latter).  Open-ended passes keep the clean ramp."""
    import splicer.align.passes as P
    import splicer.defaults as D
    from splicer import splice
    from splicer.evaluation.scenarios import make_scenario, scenario

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("imitation"), rng=np.random.default_rng(2))
    seen = []
    real = P.pass1

    def spy(*a, **kw):
        seen.append((kw.get("ends", "fixed"), kw.get("sign_ramp")))
        return real(*a, **kw)

    monkeypatch.setattr(P, "pass1", spy)

    def mean_error(res):
        e = [np.nanmean(alignment_error_s(sep, np.asarray(r.hands_frame, dtype=np.float64))[np.asarray(sep.covered)])
             for r in res.sides.values()]
        return float(np.mean(e))

    soft = splice(sep.body, sep.hands)
    # noise matching's note, or (0.29.0: the second opinion's pair kept, with its own notes) the second opinion's
    assert any("arm is noisier" in w or "motion looked noisy" in w for w in soft.report.to_dict()["warnings"])
    assert ("fixed", D.SIGN_RAMP_NOISY) in seen and ("open", D.SIGN_RAMP) in seen
    assert all(r == D.SIGN_RAMP for ends, r in seen if ends == "open")
    step = splice(sep.body, sep.hands, sign_ramp_noisy=D.SIGN_RAMP)
    assert mean_error(soft) < 0.0105 and mean_error(step) > 0.0115
