"""Worked examples for the time map's small helpers (splicer.transfer.timemap): the coverage
ramp of an open-ended splice, uncovered frame ranges, and pins held on a finished map.

Every expectation is computed by hand in the comment next to it.  These functions were
reached only through end-to-end splices and doctests, so the mutation run had no unit test
for them ("no tests" mutants)."""

from __future__ import annotations

import numpy as np
import pytest

from splicer.transfer.timemap import coverage_weights, frame_ranges, hold_pins


# ---------------------------------------------------------------- coverage_weights

def test_coverage_weights_ramp_inside_the_covered_range():
    # covered 2..7 of 10, window 2: half = (7 - 2) // 2 = 2, so k = 2; ramps 1/3, 2/3 at rows 2, 3
    # and 2/3, 1/3 at rows 6, 7; zero outside, one in between
    w = coverage_weights(10, (2, 7), window=2)
    assert w.dtype == np.float64 and w.shape == (10,)
    np.testing.assert_allclose(w, [0, 0, 1 / 3, 2 / 3, 1, 1, 2 / 3, 1 / 3, 0, 0], rtol=0, atol=1e-15)


def test_coverage_weights_ramp_never_passes_the_middle():
    # covered 3..6 of 12, window 5: half = (6 - 3) // 2 = 1, so k = 1: one frame of 1/2 at each end
    np.testing.assert_allclose(coverage_weights(12, (3, 6), window=5),
                               [0, 0, 0, 0.5, 1, 1, 0.5, 0, 0, 0, 0, 0], rtol=0, atol=1e-15)
    # a single covered frame: half = 0, no ramp at all
    assert coverage_weights(5, (2, 2), window=3).tolist() == [0.0, 0.0, 1.0, 0.0, 0.0]


def test_coverage_weights_no_ramp_at_a_covered_end_of_the_take():
    # covered from frame 0: no left ramp; right end 3 < 5: half = 1, k = 1, row 3 gets 1/2
    assert coverage_weights(6, (0, 3), window=2).tolist() == [1.0, 1.0, 1.0, 0.5, 0.0, 0.0]
    # covered to the last frame: no right ramp; left: half = 1, k = 1, row 2 gets 1/2
    assert coverage_weights(6, (2, 5), window=2).tolist() == [0.0, 0.0, 0.5, 1.0, 1.0, 1.0]
    # both ends covered: all ones, whatever the window
    assert coverage_weights(4, (0, 3), window=2).tolist() == [1.0, 1.0, 1.0, 1.0]


def test_coverage_weights_one_frame_ramps_next_to_the_ends():
    # covered 1..4 of 6, window 1: half = 1, k = 1; the ramp frames are row 1 (uncovered row 0
    # before it) and row 4 (uncovered row 5 after it), each 1/2
    assert coverage_weights(6, (1, 4), window=1).tolist() == [0.0, 0.5, 1.0, 1.0, 0.5, 0.0]


def test_coverage_weights_window_zero_and_none():
    assert coverage_weights(5, (1, 3), window=0).tolist() == [0.0, 1.0, 1.0, 1.0, 0.0]
    w = coverage_weights(3, None, window=4)
    assert w.dtype == np.float64 and w.tolist() == [1.0, 1.0, 1.0]


def test_coverage_weights_long_ramp():
    # covered 4..15 of 20, window 3: half = 5 >= 3, so k = 3: quarters at rows 4..6 and 13..15
    w = coverage_weights(20, (4, 15), window=3)
    np.testing.assert_allclose(w[:8], [0, 0, 0, 0, 0.25, 0.5, 0.75, 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(w[12:], [1, 0.75, 0.5, 0.25, 0, 0, 0, 0], rtol=0, atol=1e-15)


# ---------------------------------------------------------------- frame_ranges

def test_frame_ranges_runs_inclusive():
    assert frame_ranges(np.zeros(4, bool)) == []
    assert frame_ranges(np.ones(3, bool)) == [[0, 2]]
    assert frame_ranges(np.array([0, 1, 1, 0, 0, 1, 0, 1], bool)) == [[1, 2], [5, 5], [7, 7]]
    # a run at the very start and one at the very end
    assert frame_ranges(np.array([1, 0, 0, 1], bool)) == [[0, 0], [3, 3]]
    # any non-zero counts as True
    assert frame_ranges(np.array([0, 2, 0])) == [[1, 1]]


def test_frame_ranges_min_gap_joins_runs():
    m = np.array([0, 1, 1, 0, 0, 1, 0, 1], bool)
    # gaps: 2 frames (3, 4) between the first two runs, 1 frame (6) between the last two
    assert frame_ranges(m, min_gap=0) == [[1, 2], [5, 5], [7, 7]]
    assert frame_ranges(m, min_gap=1) == [[1, 2], [5, 7]]
    assert frame_ranges(m, min_gap=2) == [[1, 7]]


def test_frame_ranges_are_plain_ints():
    out = frame_ranges(np.array([0, 1, 1, 0, 1], bool), min_gap=1)
    assert out == [[1, 4]]
    assert all(type(v) is int for r in out for v in r)


# ---------------------------------------------------------------- hold_pins

def test_hold_pins_lifts_from_the_pin_on():
    # pin (2, 4, T=1): the map is at least 3 from row 2 on and at most 5 up to row 2
    assert hold_pins(np.array([0.0, 1, 2, 3, 4, 5]), [(2, 4.0, 1.0)], last=10).tolist() == [0, 1, 3, 3, 4, 5]


def test_hold_pins_lowers_up_to_the_pin():
    # pin (3, 4, T=0.5): at most 4.5 up to row 3, at least 3.5 from row 3 on
    out = hold_pins(np.array([0.0, 5, 6, 7, 8]), [(3, 4.0, 0.5)], last=10)
    assert out.tolist() == [0.0, 4.5, 4.5, 4.5, 8.0]


def test_hold_pins_two_pins_and_a_window_held_exactly():
    # pins (1, 0.5, 0) and (3, 6, 0): rows <= 1 at most 0.5, row 1 at least 0.5; rows <= 3 at
    # most 6, rows >= 3 at least 6
    out = hold_pins(np.array([0.0, 1, 2, 3, 4]), [(1, 0.5, 0.0), (3, 6.0, 0.0)], last=10)
    assert out.tolist() == [0.0, 0.5, 2.0, 6.0, 6.0]


def test_hold_pins_monotone_first_then_clipped_to_the_take():
    # the running maximum makes [0, 2, 1, 3] into [0, 2, 2, 3]
    assert hold_pins(np.array([0.0, 2, 1, 3]), [], last=10).tolist() == [0.0, 2.0, 2.0, 3.0]
    # then [0, last]: -1 -> 0 and 30 -> 20 (the running maximum keeps 30 for the last row)
    assert hold_pins(np.array([-1.0, 30.0, 5.0]), [], last=20).tolist() == [0.0, 20.0, 20.0]


def test_hold_pins_leaves_its_input_alone():
    tm = np.array([0.0, 3.0, 1.0, 4.0])
    before = tm.copy()
    out = hold_pins(tm, [(1, 1.0, 0.0)], last=5)
    assert np.array_equal(tm, before) and out is not tm
    assert out.tolist() == [0.0, 1.0, 3.0, 4.0]


@pytest.mark.parametrize("tol", [0.0, 0.5, 2.0])
def test_hold_pins_every_pin_holds(tol, rng):
    tm = np.sort(rng.uniform(0, 50, 40))
    pins = [(5, 30.0, tol), (20, 31.0, tol), (35, 10.0 + 40.0, tol)]
    out = hold_pins(tm, pins, last=60)
    assert np.all(np.diff(out) >= 0)
    for x, y, t in pins:
        assert y - t - 1e-12 <= out[x] <= y + t + 1e-12


# ---------------------------------------------------------------- smooth_time_map

def test_smooth_time_map_of_integer_frames_equals_the_float_one():
    from splicer.transfer.timemap import smooth_time_map

    steps = np.array([0, 0, 0, 5, 5, 5, 10, 10, 10, 10])
    as_int = smooth_time_map(steps, sigma_frames=1.0, last=10)
    as_float = smooth_time_map(steps.astype(np.float64), sigma_frames=1.0, last=10)
    assert as_int.dtype == np.float64
    np.testing.assert_array_equal(as_int, as_float)
    # the smoothing really made fractional frames (an integer filter would truncate them)
    assert np.any(np.abs(as_float - np.round(as_float)) > 0.1)


def test_smooth_time_map_keeps_a_straight_map():
    from splicer.transfer.timemap import smooth_time_map

    # reflection through the end points continues a straight line, and a Gaussian leaves a
    # straight line as it is: 0.5 hands frames per body frame stays exactly that
    tm = 0.5 * np.arange(30)
    np.testing.assert_allclose(smooth_time_map(tm, sigma_frames=2.0, last=20), tm, rtol=0, atol=1e-9)


def test_smooth_time_map_of_no_frames_and_of_one_frame():
    from splicer.transfer.timemap import smooth_time_map

    assert smooth_time_map(np.array([]), sigma_frames=2.0, last=5).shape == (0,)
    assert smooth_time_map(np.array([3.0]), sigma_frames=2.0, last=5).tolist() == [3.0]


def _smooth_reference(tm, sigma):
    # plain Python: reflect through the end points by pad = min(ceil(4 sigma), n - 1) frames,
    # then a Gaussian of radius round(4 sigma) (scipy's truncate=4) that repeats the extended
    # sequence's end values beyond it ("nearest"), then keep the original frames
    import math

    n = len(tm)
    pad = min(math.ceil(4 * sigma), n - 1)
    ext = [2 * tm[0] - tm[k] for k in range(pad, 0, -1)] + list(tm) + [2 * tm[-1] - tm[n - 1 - k]
                                                                       for k in range(1, pad + 1)]
    r = int(4 * sigma + 0.5)
    w = [math.exp(-0.5 * (k / sigma) ** 2) for k in range(-r, r + 1)]
    s = sum(w)
    out = []
    for i in range(pad, pad + n):
        out.append(sum(wk * ext[min(max(i + k, 0), len(ext) - 1)] for wk, k in zip(w, range(-r, r + 1))) / s)
    return out


@pytest.mark.parametrize("tm", [[0.0, 4.0, 5.0], [0.0, 0.0, 3.0, 9.0, 10.0], list(np.linspace(0, 7, 12) ** 1.5)])
def test_smooth_time_map_against_a_plain_reference(tm):
    from splicer.transfer.timemap import smooth_time_map

    # sigma 2: radius 8, longer than the short maps' reflection, so the edge rule matters
    out = smooth_time_map(np.array(tm), sigma_frames=2.0, last=100)
    np.testing.assert_allclose(out, np.maximum.accumulate(_smooth_reference(tm, 2.0)), rtol=0, atol=1e-12)
