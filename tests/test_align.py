"""Pass composition helpers and the coarse-guided band for long, drifting takes."""

import numpy as np
import pytest

from splicer.align.passes import compose, guided_band, path_median, remap_constraints
from splicer.align.dtw import Constraint, dtw, make_band
from splicer.errors import BandError
from splicer.evaluation.separate import separate
from splicer import splice
from splicer.evaluation.synth import make_gesture_take


def test_path_median_and_compose():
    path = np.array([[0, 0], [0, 1], [1, 2], [2, 2], [2, 3], [2, 4], [3, 5]])
    np.testing.assert_allclose(path_median(path, 4), [0.5, 2, 3, 5])
    map1 = np.array([0.0, 2.0, 4.0, 6.0])
    p2 = np.array([[0, 0], [1, 1], [2, 1], [2, 2], [3, 3]])
    np.testing.assert_allclose(compose(map1, p2, 4), [0, 2, 3, 6])
    assert remap_constraints([Constraint(2, 4, 1)], map1) == [Constraint(2, 2, 1)]


def test_guided_band_follows_the_coarse_path_and_constraints():
    n = m = 400
    # a coarse path (factor 4) that bends away from the diagonal
    coarse_j = np.round(99 * (np.arange(100) / 99) ** 2).astype(int)
    coarse = np.stack([np.arange(100), coarse_j], axis=1)
    band = guided_band(coarse, 4.0, n, m, 20.0, [Constraint(200, 100, 2)])
    for i in range(0, n, 37):
        g = 4 * coarse_j[min(round(i / 4), 99)]
        assert band.lo[i] <= g <= band.hi[i]
    assert band.lo[200] >= 98 and band.hi[200] <= 102
    assert band.max_row_width < 120  # a band, not the whole matrix
    rng = np.random.default_rng(0)
    res = dtw(rng.random((n, m)), band)
    assert abs(res.path[res.path[:, 0] == 200, 1] - 100).max() <= 2
    with pytest.raises(BandError):  # a constraint far from the coarse path cannot be reached
        guided_band(coarse, 4.0, n, m, 20.0, [Constraint(200, 390, 0)])


def test_coarse_guide_keeps_a_drifting_take_in_a_narrow_band():
    take = make_gesture_take(90.0, 30.0, np.random.default_rng(11))
    sep = separate(take, rng=np.random.default_rng(12), warp_sigma_s=6.0)
    n = take.n_frames
    diag = np.arange(n) * (sep.hands.n_frames - 1) / (n - 1)
    drift_s = np.abs(sep.truth - diag).max() / sep.hands.fps
    band = "3s"
    assert drift_s > 3.0, "the test needs a take that leaves a 3 s diagonal band"

    def err(r):
        hf = np.asarray(r.report["sides"]["right"]["hands_frame"])
        return np.abs(np.interp(hf, sep.truth, np.arange(n)) - np.arange(n)).mean()

    plain = splice(sep.body, sep.hands, side="right", band1=band, coarse="off", ends="fixed")
    guided = splice(sep.body, sep.hands, side="right", band1=band, coarse="on", ends="fixed")
    assert err(guided) < 0.5 * err(plain)
    assert err(guided) < 3.0



def test_pass_widths_worked_answers():
    """The default band policy: 30 % (the paper) for a short take end to end, 3 s with open ends,
    4 s around the coarse guide for a long take end to end, whose pass 2 keeps a third of 20 s."""
    from splicer.align.band_width import pass_widths

    # a 20-minute take at 60 fps, guided: 4 s = 240 frames, pass 2 a third of 20 s = 400 frames
    assert pass_widths(None, None, n=72000, fps=60.0, open_ends=False, guided=True) == (240.0, 400.0)
    # the same take open-ended: the located overlap's 3 s band and a third of it
    assert pass_widths(None, None, n=72000, fps=60.0, open_ends=True, guided=True) == (180.0, 60.0)
    # 30 s at 30 fps, unguided: 30 % of 900 frames = 270, pass 2 a third: 90
    assert pass_widths(None, None, n=900, fps=30.0, open_ends=False, guided=False) == (270.0, 90.0)
    # the user's band keeps the paper's ratio; the user's band2 is taken as given
    assert pass_widths("20s", None, n=72000, fps=60.0, open_ends=False, guided=True) == (1200.0, 400.0)
    assert pass_widths(None, "2s", n=72000, fps=60.0, open_ends=False, guided=True) == (240.0, 120.0)
    assert pass_widths(120, 30, n=900, fps=30.0, open_ends=False, guided=False) == (120.0, 30.0)


def test_a_guided_long_take_gets_the_narrow_default_band():
    """A 20 s take at 30 fps counts as long when ``coarse_above_s`` is 10 s: pass 1 runs in a
    4 s band (120 body frames) around the coarse path and pass 2 in a third of 20 s (200
    frames); with the coarse guide off the same take gets 30 % of its 601 frames (180.3) and a
    third of it (60.1)."""
    take = make_gesture_take(20.0, 30.0, np.random.default_rng(3))
    sep = separate(take, rng=np.random.default_rng(4))
    assert sep.body.n_frames == 601
    long_ = splice(sep.body, sep.hands, side="right", ends="fixed", coarse_above_s=10.0)
    assert long_.sides["right"].pass1.band.width == 120.0
    assert long_.sides["right"].pass2.band.width == 200.0
    short = splice(sep.body, sep.hands, side="right", ends="fixed", coarse="off")
    assert short.sides["right"].pass1.band.width == pytest.approx(180.3)
    assert short.sides["right"].pass2.band.width == pytest.approx(60.1)
    hf = np.asarray(long_.report["sides"]["right"]["hands_frame"])
    assert np.abs(hf - sep.truth).mean() < 3.0  # and the narrow band still finds the take's timing


# -- markers on another timeline ----------------------------------------------------------------

def _ramp_markers(values, fps=120.0):
    """Markers whose every coordinate is ``values`` (T,), shoulder 2x, heading 0.1x."""
    from splicer.rig.markers import Markers

    v = np.asarray(values, dtype=float)
    return Markers(np.broadcast_to(v[:, None, None], (len(v), 4, 3)).copy(), np.stack([2 * v] * 3, axis=1),
                   0.1 * v, 1, fps, "left")


def test_warp_markers_samples_linearly_and_keeps_the_rate_unless_told():
    from splicer.align.passes import warp_markers

    mk = _ramp_markers([0.0, 10.0, 40.0], fps=30.0)
    out = warp_markers(mk, np.array([0.5, 1.5, 2.0, 0.0]))
    # halfway values: (0 + 10) / 2 = 5, (10 + 40) / 2 = 25
    np.testing.assert_allclose(out.points[:, 0, 0], [5, 25, 40, 0])
    np.testing.assert_allclose(out.shoulder[:, 2], [10, 50, 80, 0])
    np.testing.assert_allclose(out.heading, [0.5, 2.5, 4.0, 0.0])
    assert (out.fps, out.up, out.side) == (30.0, 1, "left")
    assert warp_markers(mk, np.array([1.0]), fps=60.0).fps == 60.0


def test_resample_markers_up_and_down():
    from splicer.align.passes import resample_markers

    mk = _ramp_markers([0.0, 10.0, 40.0], fps=30.0)
    assert resample_markers(mk, 30.0) is mk
    assert resample_markers(mk, 30.0 * (1 + 5e-10)) is mk  # within 1e-9 of the rate: the same rate
    # 30 -> 60 fps: ratio 0.5, floor(2 / 0.5) + 1 = 5 frames at 0, 0.5, 1, 1.5, 2 (no smoothing up)
    up = resample_markers(mk, 60.0)
    np.testing.assert_allclose(up.points[:, 3, 1], [0, 5, 10, 25, 40])
    assert up.fps == 60.0 and up.n_frames == 5
    # 120 -> 50 fps: ratio 2.4, floor(20 / 2.4) + 1 = 9 frames at 0, 2.4, ..., 19.2; a Gaussian of
    # sigma 1.2 first (anti-aliasing).  A ramp stays a ramp where the kernel (4 sigma = 5 frames)
    # does not reach the ends: frames 2.4 x 3 = 7.2 .. 2.4 x 5 = 12.0
    ramp = _ramp_markers(np.arange(21.0), fps=120.0)
    down = resample_markers(ramp, 50.0)
    assert down.n_frames == 9 and down.fps == 50.0 and down.side == "left" and down.up == 1
    np.testing.assert_allclose(down.points[3:6, 0, 0], [7.2, 9.6, 12.0], atol=1e-12)
    np.testing.assert_allclose(down.heading[3:6], [0.72, 0.96, 1.2], atol=1e-12)
    # at the first frame the 'nearest' padding (frames before 0 hold 0) lifts the ramp to
    # sum_k k w_k = 0.44997 for k = 1..5, w_k = exp(-k^2 / 2.88) / sum_{|k|<=5} exp(-k^2 / 2.88)
    k = np.arange(-5, 6)
    w = np.exp(-k ** 2 / (2 * 1.2 ** 2))
    assert down.points[0, 0, 0] == pytest.approx(np.sum(np.maximum(k, 0) * w) / w.sum(), abs=1e-12)
    # a jitter at the source's Nyquist rate (0, 1, 0, 1 ...) is smoothed to its mean before
    # sampling; plain decimation by 4 would keep only the zeros
    jitter = _ramp_markers(np.tile([0.0, 1.0], 50), fps=120.0)
    np.testing.assert_allclose(resample_markers(jitter, 30.0).points[2:-2, 0, 0], 0.5, atol=0.01)
    # 60 -> 40 fps (ratio 1.5, sigma 0.75) is smoothed too: the jitter shrinks to a few percent
    assert np.ptp(resample_markers(_ramp_markers(np.tile([0.0, 1.0], 30), fps=60.0), 40.0).points[3:-3, 0, 0]) < 0.2


# -- the two passes on small known warps (unit tests: fractions of a second) -------------------

def _arm(n, fps=30.0, seed=0):
    """Markers of a smooth made-up arm motion: every coordinate a sinusoid (cm), 30 fps."""
    from splicer.rig.markers import Markers

    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    pts = np.zeros((n, 4, 3))
    for k in range(4):
        for a in range(3):
            f, p, amp = rng.uniform(0.3, 1.2), rng.uniform(0, 6.3), rng.uniform(5, 20)
            pts[:, k, a] = amp * np.sin(2 * np.pi * f * t + p) + 10 * k
    return Markers(pts, np.zeros((n, 3)), np.zeros(n), 1, fps, "left")


def _warped(n=90, m=110):
    """Body markers and hands markers that show body frame w(j) = 89 (j / 109)^1.2 at frame j;
    the true hands frame of each body frame is the inverse of w."""
    from splicer.align.passes import warp_markers

    body = _arm(n)
    w = (n - 1) * (np.arange(m) / (m - 1)) ** 1.2
    return body, warp_markers(body, w), np.interp(np.arange(n), w, np.arange(m))


def _path_cost(pr):
    local = pr.local_cost(pr.band, 0, pr.band.n)
    return sum(local[i, j - pr.band.lo[i]] for i, j in pr.path)


def test_pass1_of_identical_takes_is_the_diagonal_at_zero_cost():
    from splicer.align.passes import pass1

    body = _arm(90)
    pr = pass1(body, body, width=10.0)
    np.testing.assert_array_equal(pr.path, np.stack([np.arange(90)] * 2, axis=1))
    assert pr.cost == 0.0 and pr.name == "pass1" and pr.band.width == 10.0
    assert repr(pr) == ("PassResult(name='pass1', path=90 cells, cost=0, band=Band(n=90, m=90, width=10, "
                        f"cells={pr.band.n_cells}, max_row_width={pr.band.max_row_width}, constraints=0))")


def test_pass1_recovers_a_known_warp_and_honours_a_pin():
    from splicer.align.passes import pass1, path_median

    body, hands, truth = _warped()
    pr = pass1(body, hands, width=20.0)
    err = np.abs(path_median(pr.path, 90) - truth)
    assert err.max() <= 3.0 and err.mean() <= 0.5  # measured 2.54 and 0.37 hands frames
    assert pr.cost == pytest.approx(_path_cost(pr))  # the cost is the path's sum of local costs
    seen = []
    pinned = pass1(body, hands, width=20.0, constraints=[Constraint(45, 60, 0)], progress=seen.append)
    assert pinned.path[pinned.path[:, 0] == 45, 1].tolist() == [60]  # truth 61.7; the pin rules
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)
    # the coarse guide (10 fps, 40-frame band) finds the same path in a band around it
    guided = pass1(body, hands, width=20.0, coarse_fps=10.0, coarse_width=40.0)
    np.testing.assert_array_equal(guided.path, pr.path)
    assert guided.band.max_row_width != pr.band.max_row_width  # not the diagonal band
    # with the pin: the coarse pass gets it at (round(45 / 3), round(60 / 3)) = (15, 20) with
    # tolerance ceil(0 / 3) + 1 = 1, the full-rate pass exactly
    both = pass1(body, hands, width=20.0, constraints=[Constraint(45, 60, 0)], coarse_fps=10.0, coarse_width=40.0)
    assert both.path[both.path[:, 0] == 45, 1].tolist() == [60]
    assert both.band.constraints == (Constraint(45, 60, 0),)
    np.testing.assert_array_equal(both.path, pinned.path)


def test_pass1_features_follow_its_settings_and_coarse_only_below_the_rate():
    from splicer.align.passes import pass1
    from splicer.align.costs import d1_cost, phase_features

    body, hands, _ = _warped()
    pr = pass1(body, hands, width=20.0, smooth_s=0.2, dead_zone=0.3, theta="heading")
    want = d1_cost(phase_features(body, smooth_s=0.2, dead_zone=0.3), phase_features(hands, smooth_s=0.2, dead_zone=0.3),
                   theta="heading")(pr.band, 0, 90)
    np.testing.assert_array_equal(pr.local_cost(pr.band, 0, 90), want)
    # a coarse rate equal to the body's is no coarse pass: the paper's diagonal band
    same = pass1(body, hands, width=20.0, coarse_fps=body.fps, coarse_width=40.0)
    np.testing.assert_array_equal(same.band.lo, make_band(90, 110, 20.0).lo)
    np.testing.assert_array_equal(same.band.hi, make_band(90, 110, 20.0).hi)


def test_pass2_of_identical_takes_and_its_weights():
    from splicer.align.passes import pass2, path_median, warp_markers

    body = _arm(90)
    pr = pass2(body, body, width=5.0)
    np.testing.assert_array_equal(pr.path, np.stack([np.arange(90)] * 2, axis=1))
    assert pr.cost < 1e-5 and pr.name == "pass2"  # palm angles of identical markers: 0 (rounding)
    body, hands, truth = _warped()
    on_truth = warp_markers(hands, truth)  # the hands on the body timeline: pass 2 stays diagonal
    pr = pass2(body, on_truth, width=8.0, diagonal_weight=2.0)
    assert np.abs(path_median(pr.path, 90) - np.arange(90)).max() == 0.0
    assert pr.cost == pytest.approx(_path_cost(pr))
    with_d1 = pass2(body, on_truth, width=8.0, d1_weight=1.0)
    assert with_d1.cost == pytest.approx(_path_cost(with_d1)) and with_d1.cost > pr.cost


def test_pass2_local_costs_are_d2_plus_the_weights_it_is_given():
    from splicer.align.passes import pass2
    from splicer.align.costs import d1_cost, d2_cost, palm_features, phase_features

    body, hands, truth = _warped()
    from splicer.align.passes import warp_markers
    on = warp_markers(hands, truth)
    d2 = d2_cost(palm_features(body.points), palm_features(on.points))
    plain = pass2(body, on, width=1.5)  # the defaults: the paper's literal pass 2, D2 alone
    np.testing.assert_array_equal(plain.local_cost(plain.band, 0, 90), d2(plain.band, 0, 90))
    # weights: 0.7 rad per band width of 1.5 frames, and D1 (heading, own smoothing) / 24 x 2
    seen = []
    pr = pass2(body, on, width=1.5, diagonal_weight=0.7, d1_weight=2.0, smooth_s=0.2, dead_zone=0.3,
               theta="heading", constraints=[Constraint(45, 44, 0)], progress=seen.append)
    d1 = d1_cost(phase_features(body, smooth_s=0.2, dead_zone=0.3), phase_features(on, smooth_s=0.2, dead_zone=0.3),
                 theta="heading")
    band = pr.band
    cols = band.lo[:, None] + np.arange(band.max_row_width)[None, :]
    want = d2(band, 0, 90) + (2.0 / 24.0) * d1(band, 0, 90) + 0.7 * np.abs(cols - np.arange(90)[:, None]) / 1.5
    np.testing.assert_allclose(pr.local_cost(band, 0, 90), want, rtol=1e-12)
    assert pr.path[pr.path[:, 0] == 45, 1].tolist() == [44]  # the pin holds
    assert seen and seen[-1] == 1.0


def test_pass2_cost_adds_the_departure_penalty_and_normalised_d1():
    from splicer.align.passes import _pass2_cost

    band = make_band(5, 9, 4.0)
    d2 = lambda b, i0, i1: np.zeros((i1 - i0, b.max_row_width))  # noqa: E731
    d1 = lambda b, i0, i1: np.full((i1 - i0, b.max_row_width), 24.0)  # noqa: E731
    # weight 2 rad per band width 4: row i, column j costs 2 |j - 2 i| / 4 (centre 8 i / 4 = 2 i);
    # D1 = 24 counts d1_weight x 24 / 24 = 0.5
    out = _pass2_cost(d2, d1, 4.0, 2.0, 0.5)(band, 1, 3)
    for r, i in enumerate((1, 2)):
        cols = band.lo[i] + np.arange(out.shape[1])
        np.testing.assert_allclose(out[r], 0.5 + 2.0 * np.abs(cols - 2 * i) / 4.0)
    # a weight below 1 counts too: 0.5 rad per band width
    out = _pass2_cost(d2, None, 4.0, 0.5, 0.0)(band, 2, 3)
    np.testing.assert_allclose(out[0], 0.5 * np.abs(band.lo[2] + np.arange(out.shape[1]) - 4) / 4.0)
    # two body frames: the centre runs from column 0 to m - 1 = 8 in one step
    b2 = make_band(2, 9, 4.0)
    out = _pass2_cost(d2, None, 1.0, 1.0, 0.0)(b2, 1, 2)
    np.testing.assert_allclose(out[0], np.abs(b2.lo[1] + np.arange(out.shape[1]) - 8.0))
    np.testing.assert_array_equal(_pass2_cost(d2, d1, 4.0, 0.0, 0.0)(band, 0, 5), 0.0)
    np.testing.assert_array_equal(_pass2_cost(d2, None, 4.0, 0.0, 1.0)(band, 0, 5), 0.0)


def test_guided_band_by_hand():
    # coarse path (factor 2) (0,0) (1,1) (2,1) (3,2) (4,4): per coarse row jmin = jmax = 0 1 1 2 4.
    # fine row i -> coarse row rint(i / 2) = 0 0 1 2 2 2 3 4 4 (ties to even); with the
    # neighbouring coarse rows: lo_c = 0 0 0 1 1 1 1 2 2, hi_c = 1 1 1 2 2 2 4 4 4.
    # n = m = 9, W = 1: Delta = sqrt(2) / 2 = 0.707;
    #   lo = floor(2 lo_c - 2 - 0.707) clipped = 0 0 0 0 0 0 0 1 1
    #   hi = ceil(2 hi_c + 2 + 0.707) clipped = 5 5 5 7 7 7 8 8 8
    cp = np.array([(0, 0), (1, 1), (2, 1), (3, 2), (4, 4)])
    b = guided_band(cp, 2.0, 9, 9, 1.0)
    assert b.lo.tolist() == [0, 0, 0, 0, 0, 0, 0, 1, 1] and b.hi.tolist() == [5, 5, 5, 7, 7, 7, 8, 8, 8]
    # the pin (4, 3 +- 1) clips row 4 to [2, 4]; trimming to cells on a path: lo = running max
    # 0 0 0 0 2 2 2 2 2, hi = reversed running min 4 4 4 4 4 7 8 8 8
    b = guided_band(cp, 2.0, 9, 9, 1.0, [Constraint(4, 3, 1)])
    assert b.lo.tolist() == [0, 0, 0, 0, 2, 2, 2, 2, 2] and b.hi.tolist() == [4, 4, 4, 4, 4, 7, 8, 8, 8]
    assert b.constraints == (Constraint(4, 3, 1),) and b.width == 1.0
    # m = 12, W = 3: s = 12 / 9, Delta = 3 sqrt(1 + s^2) / 2 = 3 (5/3) / 2 = 2.5;
    #   lo = floor(2 lo_c - 4.5) -> all 0; hi = ceil(2 hi_c + 4.5) = 7 7 7 9 9 9 13 -> 11
    b = guided_band(cp, 2.0, 9, 12, 3.0)
    assert b.lo.tolist() == [0] * 9 and b.hi.tolist() == [7, 7, 7, 9, 9, 9, 11, 11, 11]


def test_coarse_constraints_by_hand():
    from splicer.align.passes import coarse_constraints

    # factor 3, coarse lengths n = 30, m = 37 (full-rate 90 x 110):
    # (45, 60, T=0) -> (15, 20), T = ceil(0 / 3) + 1 = 1
    # (46, 61, T=4) -> (round(15.33), round(20.33)) = (15, 20): does not follow -> dropped
    # (50, 70, T=7) -> (round(16.67), round(23.33)) = (17, 23), T = ceil(7 / 3) + 1 = 4
    # (88, 80, T=0) -> (29, 27): x on the last coarse frame (n - 1 = 29) -> dropped
    # ( 1, 40, T=0) -> (0, 13): x on the first coarse frame -> dropped
    # (60, 109, T=2) -> (20, 36): y on the last coarse frame (m - 1 = 36) -> dropped
    # (66, 100, T=2) -> (22, 33), T = 2
    cons = [Constraint(45, 60, 0), Constraint(46, 61, 4), Constraint(50, 70, 7), Constraint(88, 80, 0)]
    assert coarse_constraints(cons, 3.0, 30, 37) == [Constraint(15, 20, 1), Constraint(17, 23, 4)]
    assert coarse_constraints([Constraint(1, 40, 0), Constraint(60, 109, 2), Constraint(66, 100, 2)], 3.0, 30, 37) \
        == [Constraint(22, 33, 2)]
    # y must increase too: (57, 63) -> (19, 21) is kept after (15, 20); (60, 63) -> (20, 21) has
    # the same y and (46, 66) -> (15, 22) the same x as the pair before: dropped
    got = coarse_constraints([Constraint(45, 60, 0), Constraint(46, 66, 0), Constraint(57, 63, 0),
                              Constraint(60, 63, 0)], 3.0, 30, 37)
    assert got == [Constraint(15, 20, 1), Constraint(19, 21, 1)]
    # the first and last inner coarse frames are kept: (3, 3) -> (1, 1), (84, 105) -> (28, 35);
    # y on the first coarse frame is not: (30, 1) -> (10, 0)
    assert coarse_constraints([Constraint(3, 3, 0), Constraint(84, 105, 0)], 3.0, 30, 37) \
        == [Constraint(1, 1, 1), Constraint(28, 35, 1)]
    assert coarse_constraints([Constraint(30, 1, 0), Constraint(30, 30, 0)], 3.0, 30, 37) == [Constraint(10, 10, 1)]


def test_guided_band_neighbour_rows_and_delta_by_hand():
    # n = 9, m = 12, W = 1.1: Delta = 1.1 sqrt(1 + (12/9)^2) / 2 = 0.9167.  Coarse path (factor 2)
    # (0,0) (1,3) (2,4) (3,5) (4,5): jmin = 0 3 4 5 5.  Row 2 (coarse row 1) takes the
    # neighbour row 0 too: lo_c = 0 -> lo = 0; row 6 (coarse 3): lo_c = min(5, 4) = 4 ->
    # floor(8 - 2 - 0.9167) = 5 (a Delta of 1 or more would give 4)
    cp = np.array([(0, 0), (1, 3), (2, 4), (3, 5), (4, 5)])
    b = guided_band(cp, 2.0, 9, 12, 1.1)
    assert b.lo.tolist() == [0, 0, 0, 3, 3, 3, 5, 7, 7]
    assert b.hi.tolist() == [9, 9, 11, 11, 11, 11, 11, 11, 11]
    # m = 20: Delta = 1.1 sqrt(1 + (20/9)^2) / 2 = 1.3403; path (0,0) (1,0) (2,1) (3,2) (4,9):
    # rows 0, 1 (coarse 0, neighbour 1): hi_c = 0 -> ceil(0 + 2 + 1.34) = 4; row 2 (coarse 1,
    # neighbour 2): hi_c = 1 -> ceil(2 + 2 + 1.34) = 6
    cp = np.array([(0, 0), (1, 0), (2, 1), (3, 2), (4, 9)])
    b = guided_band(cp, 2.0, 9, 20, 1.1)
    assert b.hi.tolist() == [4, 4, 6, 8, 8, 8, 19, 19, 19] and b.lo.tolist() == [0] * 9


def test_pass1_guide_follows_an_earlier_path():
    """A guide path (e.g. an open-ended pass 1 that ran corner to corner) replaces the diagonal:
    the band of ``width`` is centred on it, the path inside is the same as in the wide band, and
    a guide that misses a pin's window falls back to the diagonal band."""
    from splicer.align.passes import pass1

    body, hands, _ = _warped()
    free = pass1(body, hands, width=20.0)
    guided = pass1(body, hands, width=6.0, guide=free.path)
    np.testing.assert_array_equal(guided.path, free.path)   # the best path lies inside its own neighbourhood
    want = guided_band(free.path, 1.0, 90, 110, 6.0)
    np.testing.assert_array_equal(guided.band.lo, want.lo)
    np.testing.assert_array_equal(guided.band.hi, want.hi)
    assert guided.band.max_row_width < free.band.max_row_width
    # a guide far from a pin's window: the paper's diagonal band
    far = np.stack([np.arange(90), np.minimum(np.arange(90) * 0 + np.arange(90) // 3, 109)], axis=1)
    far[-1] = (89, 109)
    pinned = pass1(body, hands, width=20.0, constraints=[Constraint(45, 60, 0)], guide=far)
    np.testing.assert_array_equal(pinned.band.lo, make_band(90, 110, 20.0, [Constraint(45, 60, 0)]).lo)
    assert pinned.path[pinned.path[:, 0] == 45, 1].tolist() == [60]
