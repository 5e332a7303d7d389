"""Body holds (splicer.align.holds): the stillness measure, the holds found, the rows held, the
band widened for them, and the splice of a body that pauses while the hands go on (the
*pause-body* scenario of splicer.evaluation.scenarios), against the same splice without them.
The DTW, posterior and smoother kernels with held rows are checked against their references in
test_openend.py, test_posterior.py and test_trend.py."""

from __future__ import annotations

import numpy as np
import pytest

from splicer.align.band import Band, Constraint, make_band
from splicer.align.holds import arm_stillness, body_holds, held_rows, hold_band


def _arm(x):
    """One marker moving along x (shape (n, 1, 3))."""
    x = np.asarray(x, dtype=np.float64)
    return np.stack([x, 0 * x, 0 * x], axis=1)[:, None, :]


def _move_hold_move(fps=30.0, hold_s=1.0, before_s=1.0, after_s=2.0):
    t = np.arange(int((before_s + hold_s + after_s) * fps)) / fps
    return np.where(t < before_s, t, np.where(t < before_s + hold_s, before_s, t - hold_s))


def test_stillness_is_the_speed_over_its_median():
    r = arm_stillness(_arm(_move_hold_move()), 30.0, smooth_s=0.05)
    assert r[45] < 1e-6  # inside the hold: not moving at all
    np.testing.assert_allclose(r[5:25], 1.0, atol=0.01)  # moving at the median speed
    assert np.all(arm_stillness(_arm(np.zeros(40)), 30.0) == 0.0)  # never moves: 0, not NaN
    with pytest.raises(ValueError, match="shape"):
        arm_stillness(np.zeros((10, 3)), 30.0)


def test_holds_need_every_arm_still_for_long_enough():
    x = _move_hold_move()
    (a, b), = body_holds([_arm(x)], 30.0, smooth_s=0.05)
    assert 30 <= a <= 33 and 57 <= b <= 60  # the hold: frames 30-60, its edges smoothed by 2-3 frames
    assert body_holds([_arm(x), _arm(np.arange(len(x)) / 30.0)], 30.0) == ()  # the other arm keeps moving
    short = _move_hold_move(hold_s=0.3)
    assert body_holds([_arm(short)], 30.0) == ()  # 0.3 s: under HOLD_MIN_S
    assert body_holds([_arm(np.zeros(60))], 30.0) == ()  # a take that never moves: nothing to place
    with pytest.raises(ValueError, match="same number"):
        body_holds([_arm(x), _arm(x[:-1])], 30.0)


def test_held_rows_are_every_row_of_a_hold_but_its_first():
    np.testing.assert_array_equal(held_rows(8, [(1, 3), (5, 6)]), [0, 0, 1, 1, 0, 0, 1, 0])
    assert held_rows(8, ()) is None


def test_hold_band_widens_each_hold_to_every_column_it_gives():
    b = Band(6, 10, 2.0, np.array([0, 1, 3, 5, 6, 7]), np.array([2, 4, 6, 8, 9, 9]))
    w, h = hold_band(b, held_rows(6, [(1, 3)]))
    assert w.lo.tolist() == [0, 1, 1, 1, 6, 7] and w.hi.tolist() == [2, 8, 8, 8, 9, 9]
    np.testing.assert_array_equal(h, [0, 0, 1, 1, 0, 0])
    assert hold_band(b, None) == (b, None)


def test_a_hold_with_a_pin_is_left_to_the_pin():
    band = make_band(40, 40, 6.0, [Constraint(20, 20, 1)])
    w, h = hold_band(band, held_rows(40, [(18, 24), (30, 34)]))
    assert not h[19:25].any() and h[31:35].all()  # the pinned hold is not held, the other is
    assert w.lo[20] == band.lo[20] and w.hi[20] == band.hi[20]  # the pin's window untouched


@pytest.fixture(scope="module")
def paused():
    from splicer.evaluation.scenarios import make_scenario, scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(30.0, 30.0, np.random.default_rng(0))
    return [make_scenario(take, scenario("pause-body"), rng=np.random.default_rng(s)) for s in (0, 1)]


def test_a_body_pause_is_crossed_flat_and_reported(paused):
    """The body holds 1.7-1.9 s while the hands go on.  Measured: with the holds, the map's mean
    error over the pause 0.069 and 0.023 s (seeds 0, 1), without them 0.240 and 0.134 s; the holds
    found lie within 5 frames of the true pause's ends."""
    from splicer import splice
    from splicer.evaluation.scenarios import alignment_error_s

    for sep in paused:
        p, kb = sep.params["pause_body"]
        err = {}
        for bh in ("on", "off"):
            r = splice(sep.body, sep.hands, body_holds=bh)
            err[bh] = np.nanmean(np.concatenate([alignment_error_s(sep, r.sides[s].hands_frame)[p:p + kb + 1]
                                                 for s in r.sides]))
            d = r.report.to_dict()
            holds = d["sides"]["right"]["pass1"]["body_holds"]
            if bh == "off":
                assert holds == [] and not any("holds still" in w for w in d["warnings"])
                continue
            (a, b), = holds
            assert abs(a - p) <= 5 and abs(b - (p + kb)) <= 5
            assert any(f"holds still over frames {a}-{b}" in w for w in d["warnings"])
        assert err["on"] < 0.1 and err["on"] < 0.5 * err["off"], err


def test_the_plot_shades_the_holds(paused):
    """The time map's panel shades each hold (its entry row and its held rows) once, in its own group."""
    from splicer import splice
    from splicer.plot import figure

    sep = paused[0]
    r = splice(sep.body, sep.hands)
    (a, b), = r.report.to_dict()["sides"]["right"]["pass1"]["body_holds"]
    fig = figure(r, dpi=40)
    for ax in (ax for ax in fig.axes if ax.title.endswith("time map")):
        shades = [sp for sp in ax.spans if sp.label == "body holds still"]
        assert len(shades) == 1 and shades[0].ranges == ((a - 0.5, b + 0.5),)
    r = splice(sep.body, sep.hands, body_holds="off")
    assert not [sp for ax in figure(r, dpi=40).axes for sp in ax.spans if sp.label == "body holds still"]
