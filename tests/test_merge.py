"""Worked answers for splicer.transfer.timemap: pins on a time map, the smoothed time map, the rotation
median over matched frames and the blend over jumps (ALGORITHM.md section 6)."""

import numpy as np
import pytest

from splicer.transfer.timemap import blend_jumps, median_rotations, pin_constraints, smooth_time_map
from splicer.model.rotations import quat_angle, quat_from_euler


def _about_x(deg):
    """(T, 1, 4) rotations about X by ``deg`` degrees."""
    deg = np.asarray(deg, dtype=float)
    return quat_from_euler(np.stack([deg, 0 * deg, 0 * deg], axis=-1), "XYZ")[:, None, :]


def _angles_x(q):
    """Signed angle about X (degrees) of (T, 1, 4) rotations about X."""
    return np.degrees(2 * np.arctan2(q[:, 0, 1], q[:, 0, 0]))


# -- pin_constraints ---------------------------------------------------------------------------

def test_pin_below_its_window_is_lifted_to_the_lower_edge():
    # tm = 0..10, pin (body 5 -> hands 8 +- 1): tm[5] = 5 < 7, so d = +2 at x = 5,
    # 0 at both ends; the correction is 2 i / 5 up to 5, then 2 (10 - i) / 5:
    # i:   0  1    2    3    4    5  6    7    8    9    10
    # tm:  0  1.4  2.8  4.2  5.6  7  7.6  8.2  8.8  9.4  10
    out = pin_constraints(np.arange(11.0), [(5, 8.0, 1.0)])
    np.testing.assert_allclose(out, [0, 1.4, 2.8, 4.2, 5.6, 7, 7.6, 8.2, 8.8, 9.4, 10], atol=1e-12)


def test_pin_above_its_window_is_lowered_to_the_upper_edge():
    # pin (5 -> 2 +- 1): tm[5] = 5 > 3, d = -2:
    # tm: 0 0.6 1.2 1.8 2.4 3 4.4 5.8 7.2 8.6 10
    out = pin_constraints(np.arange(11.0), [(5, 2.0, 1.0)])
    np.testing.assert_allclose(out, [0, 0.6, 1.2, 1.8, 2.4, 3, 4.4, 5.8, 7.2, 8.6, 10], atol=1e-12)


def test_pin_within_tolerance_changes_nothing_and_input_is_not_modified():
    tm = np.arange(11.0)
    out = pin_constraints(tm, [(5, 5.5, 1.0), (8, 7.0, 1.0)])  # |5 - 5.5| <= 1, |8 - 7| <= 1
    np.testing.assert_array_equal(out, np.arange(11.0))
    np.testing.assert_array_equal(tm, np.arange(11.0))
    assert out is not tm
    np.testing.assert_array_equal(pin_constraints(tm, []), tm)


def test_pin_exactly_on_the_window_edge_is_not_moved():
    # tm[5] = 5 = y - t and = y + t: both edges count as inside
    np.testing.assert_array_equal(pin_constraints(np.arange(11.0), [(5, 6.0, 1.0)]), np.arange(11.0))
    np.testing.assert_array_equal(pin_constraints(np.arange(11.0), [(5, 4.0, 1.0)]), np.arange(11.0))


def test_two_pins_unsorted_give_the_sorted_answer():
    # pins (2 -> 4 +- 0) and (6 -> 5 +- 0) on tm = 0..8:
    # d = 2 at x=2, d = -1 at x=6; correction: 0 1 2 1.25 0.5 -0.25 -1 -0.5 0
    # tm + c: 0 2 4 4.25 4.5 4.75 5 6.5 8
    want = [0, 2, 4, 4.25, 4.5, 4.75, 5, 6.5, 8]
    np.testing.assert_allclose(pin_constraints(np.arange(9.0), [(6, 5.0, 0.0), (2, 4.0, 0.0)]), want, atol=1e-12)
    np.testing.assert_allclose(pin_constraints(np.arange(9.0), [(2, 4.0, 0.0), (6, 5.0, 0.0)]), want, atol=1e-12)


def test_correction_that_would_fold_the_map_is_made_monotone_within_the_window():
    # tm = [0, 0, 10, 10, 10], pin (3 -> 5 +- 1): d = (5 + 1) - 10 = -4 at x = 3;
    # correction 0 -4/3 -8/3 -4 0 -> [0, -1.33, 7.33, 6, 10]; running maximum
    # [0, 0, 7.33, 7.33, 10] leaves frame 3 above the window [4, 6]; frames up to the pin are
    # capped at its upper edge 6: [0, 0, 6, 6, 10]
    out = pin_constraints(np.array([0.0, 0, 10, 10, 10]), [(3, 5.0, 1.0)])
    np.testing.assert_allclose(out, [0, 0, 6, 6, 10], atol=1e-12)


def test_zero_tolerance_pin_is_exact_even_where_the_fold_would_lift_it():
    # tm = [0, 0, 10, 10, 10], pin (3 -> 5 exactly): d = -5 at x = 3;
    # correction 0 -5/3 -10/3 -5 0 -> [0, -1.67, 6.67, 5, 10], whose running maximum lifts
    # frame 3 to 6.67: the pin holds only if frames before it are capped at 5 as well.
    out = pin_constraints(np.array([0.0, 0, 10, 10, 10]), [(3, 5.0, 0.0)])
    assert out[3] == 5.0
    np.testing.assert_allclose(out, [0, 0, 5, 5, 10], atol=1e-12)


def test_every_pin_window_holds_after_the_monotone_fix_up(rng):
    for _ in range(200):
        n = int(rng.integers(5, 40))
        tm = np.cumsum(rng.exponential(1.0, n) * (rng.random(n) < 0.5) * 5)
        k = int(rng.integers(1, 4))
        xs = np.sort(rng.choice(np.arange(1, n - 1), size=min(k, n - 2), replace=False))
        ys = np.sort(rng.uniform(0, tm[-1] + 5, len(xs)))
        ts = rng.choice([0.0, 0.5, 2.0], len(xs))
        pins = list(zip(xs.tolist(), ys.tolist(), ts.tolist()))
        out = pin_constraints(tm, pins)
        assert np.all(np.diff(out) >= -1e-12)
        for x, y, t in pins:
            assert y - t - 1e-9 <= out[x] <= y + t + 1e-9, (tm, pins, out)


# -- smooth_time_map ---------------------------------------------------------------------------

def test_a_straight_map_survives_smoothing_ends_included():
    # reflection through the end points keeps a ramp a ramp (a plain 'nearest' pad would
    # bend both ends towards the middle); 20 frames, sigma 3: the padding (12 frames) is
    # exactly the kernel's reach (4 sigma)
    ramp = 5.0 + 2.0 * np.arange(20)
    np.testing.assert_allclose(smooth_time_map(ramp, sigma_frames=3.0, last=100.0), ramp, atol=1e-9)


def test_a_two_frame_map_is_padded_by_one_frame_and_then_held():
    # [0, 10], sigma 1: pad = min(4, 1) = 1 -> ext = [-10, 0, 10, 20], and the filter holds the
    # ends beyond ('nearest').  Weights w0..w4 = .398942 .241971 .053991 .004432 .000134:
    # frame 0 = -10 (w1 + w2 + w3 + w4) + 10 w1 + 20 (w2 + w3 + w4) = 0.585567; frame 1 the mirror
    out = smooth_time_map(np.array([0.0, 10.0]), sigma_frames=1.0, last=10.0)
    np.testing.assert_allclose(out, [0.585567, 9.414433], atol=2e-6)


def test_a_short_map_stays_symmetric():
    # 5 frames, sigma 2: the padding is cut to 4 frames; a ramp comes out antisymmetric about
    # its middle frame, which stays at 2
    out = smooth_time_map(np.arange(5.0), sigma_frames=2.0, last=10.0)
    assert out[2] == pytest.approx(2.0, abs=1e-12)
    np.testing.assert_allclose(out + out[::-1], 4.0, atol=1e-12)
    assert out[0] > 0.0


def test_clipping_to_the_hands_take_before_and_after_the_pins():
    # above the take (last = 10): clipped first to [0, 10, 10, 10, 10]; the pin (2 -> 5 exactly)
    # gives d = -5: correction 0 -2.5 -5 -2.5 0 -> [0, 7.5, 5, 7.5, 10], running maximum
    # [0, 7.5, 7.5, 7.5, 10], frames up to the pin capped at 5: [0, 5, 5, 7.5, 10]
    out = smooth_time_map(np.array([0.0, 20, 20, 20, 20]), sigma_frames=0.0, last=10.0, pins=[(2, 5.0, 0.0)])
    np.testing.assert_allclose(out, [0, 5, 5, 7.5, 10], atol=1e-12)
    # below it: [-10, -10, -10, -10, 10] is clipped to [0, 0, 0, 0, 10] first; d = +5:
    # [0, 2.5, 5, 2.5, 10] -> [0, 2.5, 5, 5, 10]
    out = smooth_time_map(np.array([-10.0, -10, -10, -10, 10]), sigma_frames=0.0, last=10.0, pins=[(2, 5.0, 0.0)])
    np.testing.assert_allclose(out, [0, 2.5, 5, 5, 10], atol=1e-12)
    # a pin that lifts the frames after it past the end: [0, 0, 10, 10], last 10, pin (1 -> 5):
    # correction 0 5 2.5 0 -> [0, 5, 12.5, 10] -> [0, 5, 12.5, 12.5] -> clipped [0, 5, 10, 10]
    out = smooth_time_map(np.array([0.0, 0, 10, 10]), sigma_frames=0.0, last=10.0, pins=[(1, 5.0, 0.0)])
    np.testing.assert_allclose(out, [0, 5, 10, 10], atol=1e-12)


def test_smoothed_step_has_the_gaussian_weights():
    # a 0 -> 10 step between frames 9 and 10, sigma 1 (kernel truncated at 4 sigma, normalised):
    # weights exp(-k^2 / 2): k=0: 1, 1: 0.6065307, 2: 0.1353353, 3: 0.0111090, 4: 0.0003355;
    # total 2.5066210; frame 9 gets 10 x (0.6065307 + 0.1353353 + 0.0111090 + 0.0003355)
    # / 2.5066210 = 3.005283, frame 10 the mirror 6.994717
    step = np.r_[np.zeros(10, dtype=int), np.full(10, 10)]  # integers: the map is fractional all the same
    out = smooth_time_map(step, sigma_frames=1.0, last=10.0)
    assert out[9] == pytest.approx(3.005283, abs=2e-6)
    assert out[10] == pytest.approx(6.994717, abs=2e-6)
    assert out[0] == pytest.approx(0.0, abs=1e-12) and out[-1] == pytest.approx(10.0, abs=1e-12)


def test_sigma_zero_only_makes_monotone_and_clips():
    # running maximum [0, 2, 2, 3, 3], then clipped to [0, last = 2.5]
    out = smooth_time_map(np.array([0.0, 2, 1, 3, 3]), sigma_frames=0.0, last=2.5)
    np.testing.assert_array_equal(out, [0, 2, 2, 2.5, 2.5])


def test_smooth_time_map_clips_below_zero_and_honours_pins():
    # a ramp from -2: clipped at 0; the pin (4 -> 1 exactly) pulls frame 4 from 2 to 1
    out = smooth_time_map(np.arange(-2.0, 8.0), sigma_frames=0.0, last=100.0, pins=[(4, 1.0, 0.0)])
    assert out[0] == 0.0 and out[4] == 1.0
    assert np.all(np.diff(out) >= 0)
    assert out[-1] == 7.0


def test_a_single_frame_map_is_left_alone():
    np.testing.assert_array_equal(smooth_time_map(np.array([3.0]), sigma_frames=5.0, last=10.0), [3.0])


# -- median_rotations --------------------------------------------------------------------------

def test_median_over_matched_frames():
    # hands frames at 0, 10, 20, 30, 40 degrees about X; body frame 0 is matched to hands
    # 0, 1, 2 (median 10 degrees), body 1 to hands 3 (30), body 2 to hands 3.5 and 4:
    # slerp at 3.5 is 35, and the median of two is their normalised mean, 37.5 degrees
    q = _about_x([0, 10, 20, 30, 40])
    rows = np.array([0, 0, 0, 1, 2, 2])
    frames = np.array([0.0, 1, 2, 3, 3.5, 4])
    out = median_rotations(q, frames, rows, 3)
    np.testing.assert_allclose(_angles_x(out), [10, 30, 37.5], atol=1e-9)


def test_median_of_an_even_count_is_the_midway_rotation():
    # median of 0, 10, 20, 30 degrees: the mean of the middle two quaternions, normalised,
    # is the 15-degree rotation exactly
    q = _about_x([0, 10, 20, 30])
    out = median_rotations(q, np.arange(4.0), np.zeros(4, dtype=int), 1)
    assert _angles_x(out)[0] == pytest.approx(15.0, abs=1e-9)


def test_median_rotations_output_is_hemisphere_continuous():
    # hands rotations 170 and -170 degrees about X (20 degrees apart across the flip): their
    # quaternions (cos 85, sin 85, 0, 0) and (cos 85, -sin 85, 0, 0) have a negative dot
    # product; the output must not flip between frames
    q = _about_x([170.0, -170.0])
    assert np.sum(q[0, 0] * q[1, 0]) < 0
    out = median_rotations(q, np.array([0.0, 1.0]), np.array([0, 1]), 2)
    assert np.sum(out[0, 0] * out[1, 0]) > 0
    assert quat_angle(out[0, 0], out[1, 0]) == pytest.approx(20.0, abs=1e-9)


# -- blend_jumps -------------------------------------------------------------------------------

def test_blend_replaces_the_window_around_a_jump_with_a_slerp():
    # rotations step from 0 to 90 degrees at frame 5; the time map jumps by 10 between
    # frames 4 and 5 (> jump = 5).  window 2: a = 2, b = 7, t = (3..6 - 2) / 5 = .2 .4 .6 .8,
    # so frames 3..6 become 18, 36, 54, 72 degrees; frames 0..2 and 7..9 are kept
    q = _about_x([0, 0, 0, 0, 0, 90, 90, 90, 90, 90])
    tm = np.array([0, 1, 2, 3, 4, 14, 15, 16, 17, 18.0])
    out = blend_jumps(q, tm, jump=5.0, window=2)
    np.testing.assert_allclose(_angles_x(out), [0, 0, 0, 18, 36, 54, 72, 90, 90, 90], atol=1e-9)
    np.testing.assert_allclose(_angles_x(q), [0] * 5 + [90] * 5, atol=1e-12)  # input untouched


def test_blend_window_is_cut_at_the_ends():
    # jump between frames 0 and 1, window 2, n = 4: a = max(0 - 2, 0) = 0,
    # b = min(0 + 1 + 2, 3) = 3; frames 1, 2 become 1/3 and 2/3 of the way: 30, 60 degrees
    q = _about_x([0, 90, 90, 90])
    out = blend_jumps(q, np.array([0, 10, 11, 12.0]), jump=5.0, window=2)
    np.testing.assert_allclose(_angles_x(out), [0, 30, 60, 90], atol=1e-9)
    # backwards jumps count too (|step|), and a window over the last frame is cut there
    out = blend_jumps(_about_x([0, 0, 0, 90]), np.array([12, 11, 10, 0.0]), jump=5.0, window=1)
    # jump at i = 2: a = 1, b = min(4, 3) = 3, frame 2 -> halfway between 0 and 90
    np.testing.assert_allclose(_angles_x(out), [0, 0, 45, 90], atol=1e-9)


def test_no_blend_for_steps_up_to_the_threshold_or_too_short_windows():
    q = _about_x([0, 0, 90, 90])
    # steps of exactly 5 are not jumps (strictly larger is)
    np.testing.assert_array_equal(blend_jumps(q, np.array([0, 5, 10, 15.0]), jump=5.0, window=2), q)
    # two frames: the window a = 0, b = 1 has nothing between its ends
    q2 = _about_x([0, 90])
    np.testing.assert_array_equal(blend_jumps(q2, np.array([0, 10.0]), jump=5.0, window=3), q2)
    # window 0 around a jump at i = 1: a = 1, b = 2, nothing in between
    np.testing.assert_array_equal(blend_jumps(q, np.array([0, 1, 11, 12.0]), jump=5.0, window=0), q)
