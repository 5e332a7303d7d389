"""The D1 and D2 kernels against slow plain references, and theta's sign against a known turn."""

import numpy as np
import pytest

from splicer.align.dtw import make_band
from splicer.rig.markers import Markers
from references import d1_reference, d2_reference, position_reference, sgn_branching
from splicer.align.costs import (d1_cost, d2_cost, kgp_theta, palm_features, phase_features, position_features,
                                 window_points)
from splicer.align.noise import matched_smoothing, sign_change_rate, swing_rate
from splicer.model.rotations import quat_rotate, yaw_quat_deg


def _markers(rng, T, up=1, fps=30.0):
    t = np.arange(T)[:, None, None] / fps
    pts = np.cumsum(rng.normal(size=(T, 4, 3)), axis=0) + 10 * np.sin(t * rng.uniform(1, 3, size=(1, 4, 3)))
    return Markers(pts, rng.normal(size=(T, 3)) * 0.1, np.cumsum(rng.normal(size=T)) * 0.05, up, fps, "left")


@pytest.mark.parametrize("ramp", [0.0, 0.03, 0.5])
@pytest.mark.parametrize("theta", ["window", "heading"])
@pytest.mark.parametrize("up", [1, 2])
def test_d1_kernel_matches_reference(rng, theta, up, ramp):
    body = phase_features(_markers(rng, 40, up), sign_ramp=ramp)
    hands = phase_features(_markers(rng, 55, up), sign_ramp=ramp)
    band = make_band(40, 55, 20.0)
    rows = d1_cost(body, hands, theta=theta)(band, 0, 40)
    for i in range(40):
        for c in range(band.hi[i] - band.lo[i] + 1):
            j = band.lo[i] + c
            assert rows[i, c] == pytest.approx(d1_reference(body, hands, i, j, theta), abs=1e-9), (i, j)
        assert np.all(np.isinf(rows[i, band.hi[i] - band.lo[i] + 1:]))


@pytest.mark.parametrize("eps, ramp", [(0.01, 0.0), (0.01, 0.03), (0.2, 0.5), (0.0, 0.0), (0.0, 0.1)])
def test_dead_zoned_sign_is_the_branching_form_bit_for_bit(rng, eps, ramp):
    from splicer.align.costs import _signs
    edges = [eps, eps + ramp, np.nextafter(eps, 1), np.nextafter(eps, -1), np.nextafter(eps + ramp, 0),
             np.nextafter(eps + ramp, 2), 0.5 * eps + 0.5 * (eps + ramp), 1e-300, 0.0, 3.0, np.inf]
    x = np.array(edges + [-e for e in edges] + [np.nan, -0.0] + list(rng.normal(scale=2 * (eps + ramp) + 1e-3, size=300)))
    x = x[: x.size // 3 * 3].reshape(-1, 1, 3)
    out = np.empty_like(x)
    _signs(x, eps, ramp, out)
    want = np.array([sgn_branching(float(v), eps, ramp) for v in x.ravel()]).reshape(x.shape)
    assert np.array_equal(out, want)
    assert np.array_equal(out == 0, want == 0)  # the same zeros (a -0.0 squares to the same cost)


def test_d2_kernel_matches_reference(rng):
    b = palm_features(rng.normal(size=(30, 4, 3)))
    h = palm_features(rng.normal(size=(33, 4, 3)))
    band = make_band(30, 33, 12.0)
    rows = d2_cost(b, h)(band, 5, 25)
    for r, i in enumerate(range(5, 25)):
        for c in range(band.hi[i] - band.lo[i] + 1):
            assert rows[r, c] == pytest.approx(d2_reference(b, h, i, band.lo[i] + c), abs=1e-9)


@pytest.mark.parametrize("up", [0, 1, 2])
@pytest.mark.parametrize("angle", [35.0, -70.0, 150.0])
def test_theta_undoes_a_known_turn(rng, up, angle):
    """Turning the hands by +angle about the up axis: theta is -angle, so R(theta) turns them back."""
    pts = rng.normal(size=(9, 4, 3))
    q = yaw_quat_deg(angle, up)
    turned = quat_rotate(q, pts) + np.array([3.0, -2.0, 5.0])  # and moved
    wb, wh = window_points(pts, up), window_points(turned, up)
    assert np.degrees(kgp_theta(wb[4], wh[4])) == pytest.approx(-angle, abs=1e-9)


def test_sign_ramp_worked_answer():
    """One marker moving along the up axis only: velocity 0.5 (body) against 2.0 (hands), dead
    zone 0.2, ramp 1.0.  The body's sign is (0.5 - 0.2) / 1.0 = 0.3, the hands' 1: D1 sums
    (0.3 - 1)^2 = 0.49 over the velocity; the accelerations are 0 (below their dead zone).
    With the step (ramp 0) both signs are 1 and D1 is 0."""
    from splicer.align.costs import PhaseFeatures

    def feats(v, ramp):
        vel = np.zeros((1, 1, 3))
        vel[0, 0, 1] = v
        win = np.zeros((1, 2, 5))
        win[0, 0, 0] = 1.0  # any non-degenerate window: theta = 0 between identical windows
        return PhaseFeatures(vel, np.zeros((1, 1, 3)), 0.2, 0.2, win, np.zeros(1), 1, ramp, ramp)

    band = make_band(1, 1, 5.0)
    assert d1_cost(feats(0.5, 1.0), feats(2.0, 1.0))(band, 0, 1)[0, 0] == pytest.approx(0.49)
    assert d1_cost(feats(0.5, 0.0), feats(2.0, 0.0))(band, 0, 1)[0, 0] == 0.0
    assert d1_cost(feats(-0.5, 1.0), feats(0.1, 1.0))(band, 0, 1)[0, 0] == pytest.approx(0.09)  # -0.3 vs 0


def test_d1_is_continuous_in_the_input(rng):
    """With the ramp, a change of 1e-9 in the input moves D1 by at most ~1e-6 (the step jumps by 1)."""
    mk = _markers(rng, 60)
    body = phase_features(_markers(rng, 50))
    band = make_band(50, 60, 30.0)
    a = d1_cost(body, phase_features(mk))(band, 0, 50)
    moved = Markers(mk.points + rng.normal(0, 1e-9, mk.points.shape), mk.shoulder, mk.heading, 1, 30.0, "left")
    b = d1_cost(body, phase_features(moved))(band, 0, 50)
    ok = np.isfinite(a)
    assert np.max(np.abs(a[ok] - b[ok])) < 1e-5


def test_d1_invariant_to_turning_the_hands(rng):
    mk = _markers(rng, 60)
    q = yaw_quat_deg(40.0, 1)
    turned = Markers(quat_rotate(q, mk.points), quat_rotate(q, mk.shoulder), mk.heading + np.radians(40.0), 1, 30.0, "left")
    body = phase_features(_markers(rng, 50))
    band = make_band(50, 60, 30.0)
    for theta in ("window", "heading"):
        a = d1_cost(body, phase_features(mk), theta=theta)(band, 0, 50)
        b = d1_cost(body, phase_features(turned), theta=theta)(band, 0, 50)
        # signs flip only where a rotated component sits exactly on the dead-zone edge
        assert np.mean(np.isclose(a, b)) > 0.99


def test_d1_is_zero_on_itself_and_amplitude_invariant(rng):
    mk = _markers(rng, 50)
    small = Markers(mk.points * 0.3, mk.shoulder * 0.3, mk.heading, 1, 30.0, "left")
    fa, fb = phase_features(mk), phase_features(small)
    band = make_band(50, 50, 100.0)
    rows = d1_cost(fa, fb)(band, 0, 50)
    diag = np.array([rows[i, i - band.lo[i]] for i in range(50)])
    assert np.all(diag < 1e-20)  # the ramp's share of 0.3x the RMS: equal up to rounding
    rows = d1_cost(phase_features(mk, sign_ramp=0.0), phase_features(small, sign_ramp=0.0))(band, 0, 50)
    assert np.all(np.array([rows[i, i - band.lo[i]] for i in range(50)]) == 0)


# --- noise matching: the phase metric's smoothing follows the noisier take ------------------

def _swinging(t: np.ndarray, *, noise_deg: float = 0.0, seed: int = 0) -> Markers:
    """An arm swinging at 0.4 and 0.9 Hz about the shoulder at 30 fps, optionally with arm noise
    (Gaussian, smoothed over 0.05 s, in radians of swing angle on a 0.3-0.6 m arm)."""
    from splicer.filters import gaussian_filter1d

    ang = 0.6 * np.sin(2 * np.pi * 0.4 * t) + 0.3 * np.sin(2 * np.pi * 0.9 * t + 1.0)
    nz = gaussian_filter1d(np.random.default_rng(seed).standard_normal((len(t), 4)), 1.5, axis=0, mode="nearest")
    ang = ang[:, None] + np.radians(noise_deg) * nz / nz.std()  # each marker its own noise (as on separate segments)
    pts = np.zeros((len(t), 4, 3))
    for k, r in enumerate((0.3, 0.45, 0.5, 0.6)):
        pts[:, k, 0] = r * np.sin(ang[:, k])
        pts[:, k, 1] = -r * np.cos(ang[:, k])
    return Markers(pts, np.zeros((len(t), 3)), np.zeros(len(t)), 1, 30.0, "left")


def test_sign_change_rate_counts_reversals_per_second():
    t = np.arange(600) / 30.0
    pts = np.zeros((600, 4, 3))
    pts[:, :, 1] = np.sin(2 * np.pi * 1.0 * t + 0.3)[:, None]  # every marker's height: 2 reversals a second
    mk = Markers(pts, np.zeros((600, 3)), np.zeros(600), 1, 30.0, "left")
    assert sign_change_rate(mk) == pytest.approx(2.0 / 3.0, abs=0.02)  # the vertical: a third of the weight
    pts = np.zeros((600, 4, 3))
    pts[:, :, 2] = np.sin(2 * np.pi * 1.0 * t + 0.3)[:, None]  # horizontal (z): one principal axis
    assert sign_change_rate(Markers(pts, np.zeros((600, 3)), np.zeros(600), 1, 30.0, "left")) == pytest.approx(
        2.0 / 3.0, abs=0.02)


def test_sign_change_rate_does_not_depend_on_facing():
    t = np.arange(900) / 30.0
    mk = _swinging(t, noise_deg=1.0, seed=2)
    rates = []
    for deg in (0.0, 30.0, 47.0, 90.0):
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # about y, the up axis
        rates.append(sign_change_rate(Markers(mk.points @ turn.T, mk.shoulder, mk.heading, 1, 30.0, "left")))
    assert max(rates) - min(rates) < 1e-9 * rates[0], rates


def test_swing_rate_follows_tempo_not_noise():
    t = np.arange(900) / 30.0
    body = swing_rate(_swinging(t))
    assert swing_rate(_swinging(t / 2.0)) == pytest.approx(body / 2.0, rel=0.15)  # half the tempo
    assert swing_rate(_swinging(t, noise_deg=3.0, seed=3)) == pytest.approx(body, rel=0.1)


def test_matched_smoothing_keeps_clean_pairs_and_tempo_differences():
    t = np.arange(900) / 30.0
    body = _swinging(t)
    assert matched_smoothing(body, _swinging(t), ratio=1.2) == (0.025, pytest.approx(1.0))
    # the hands performer 30 % slower: fewer changes a second, explained by the tempo
    s, excess = matched_smoothing(body, _swinging(t / 1.3), ratio=1.2)
    assert s == 0.025 and excess < 1.2
    assert sign_change_rate(body) > 1.1 * sign_change_rate(_swinging(t / 1.3))


def test_matched_smoothing_smooths_a_noisy_take_more_when_asked():
    t = np.arange(900) / 30.0
    body, noisy = _swinging(t), _swinging(t, noise_deg=2.0, seed=3)
    s, excess = matched_smoothing(body, noisy, ratio=1.2, trigger=None)
    assert excess > 1.2 and s == pytest.approx(0.05)
    assert matched_smoothing(noisy, body, ratio=1.2, trigger=None)[0] == pytest.approx(0.05)  # either take
    assert matched_smoothing(body, noisy, ratio=None) == (0.025, pytest.approx(excess))  # off: the excess measured
    assert excess < 1.7 and matched_smoothing(body, noisy)[0] == 0.025  # the default: only over the 1.7 trigger


def test_matched_smoothing_of_a_take_smoothed_flat():
    """12 frames: at a wider smoothing one take shows no direction changes at all (found by the
    fuzz campaign as a division by zero); the widths go on, and a width is returned."""
    t = np.arange(12) / 30.0
    s, excess = matched_smoothing(_swinging(t), _swinging(t, noise_deg=4.0, seed=3), ratio=1.2, trigger=None)
    assert excess > 1.2 and 0.025 < s <= 0.2


def test_phase_smoothing_decides_once_for_both_hands():
    """Both hands come from one hands take: one side over the 1.7x trigger smooths both."""
    from types import SimpleNamespace

    from splicer.options import SpliceOptions
    from splicer.stages.align import phase_smoothing
    from splicer.stages.log import Log

    t = np.arange(900) / 30.0
    body = _swinging(t)
    # excess 1.26 (2 degrees of arm noise) and 1.86 (8 degrees), measured
    left = SimpleNamespace(body=body, hands=_swinging(t, noise_deg=2.0, seed=3))
    right = SimpleNamespace(body=body, hands=_swinging(t, noise_deg=8.0, seed=3))
    log = Log()
    assert phase_smoothing({"left": left, "right": right}, SpliceOptions(), log) == {
        "left": pytest.approx(0.05), "right": pytest.approx(0.1)}
    assert sum("markers smoothed over" in n for n in log.warnings) == 2
    assert phase_smoothing({"left": left}, SpliceOptions()) == {"left": 0.025}  # alone: under the trigger
    log = Log()
    assert phase_smoothing({"left": left, "right": right}, SpliceOptions(noise_ratio=None), log) == {
        "left": 0.025, "right": 0.025}
    assert [n.startswith("right side: one take's arm looks noisier") for n in log.warnings] == [True]
    # a number: each side on its own, whenever over it, until within it (right: 1.86x, then under 1.5x at 0.05 s)
    assert phase_smoothing({"left": left, "right": right}, SpliceOptions(noise_ratio=1.5)) == {
        "left": 0.025, "right": pytest.approx(0.05)}


# ---------------------------------------------------------------- the position term (pass 1, beyond the paper)

@pytest.mark.parametrize("weight", [0.5, 3.0])
def test_position_term_matches_reference(rng, weight):
    """D1 with a position weight is D1 plus the weight times the plain mean squared difference."""
    body = phase_features(_markers(rng, 40), position=True)
    hands = phase_features(_markers(rng, 55), position=True)
    band = make_band(40, 55, 20.0)
    plain = d1_cost(body, hands)(band, 3, 37)
    rows = d1_cost(body, hands, position_weight=weight)(band, 3, 37)
    for r, i in enumerate(range(3, 37)):
        k = band.hi[i] - band.lo[i] + 1
        for c in range(k):
            j = band.lo[i] + c
            assert rows[r, c] == pytest.approx(plain[r, c] + weight * position_reference(body, hands, i, j), abs=1e-9)
        assert np.all(np.isinf(rows[r, k:]))


def test_position_features_worked_answer():
    """Shoulder at the origin, heading 0, up = y; the wrist and hand markers move along x only,
    through 0, 1, 2, 3, 4 (p1), 0, 2, 4, 6, 8 (p2: twice as far) and 5, 5, 5, 5, 5 (p4: still).
    Each coordinate: minus its median, over 1.4826 x its MAD, the MAD floored at a tenth of the
    widest: p1.x -> (-2, -1, 0, 1, 2) / 1.4826, p2.x -> the same (scale removed), p4.x and every
    y, z -> 0 (no spread; floored, not divided by zero)."""
    x = np.arange(5.0)
    pts = np.zeros((5, 4, 3))
    pts[:, 0, 0], pts[:, 1, 0], pts[:, 3, 0] = x, 2 * x, 5.0
    mk = Markers(pts, np.zeros((5, 3)), np.zeros(5), 1, 30.0, "left")
    f = position_features(mk)
    want = np.zeros((5, 9))
    want[:, 0] = want[:, 3] = (x - 2.0) / 1.4826
    np.testing.assert_allclose(f, want, atol=1e-12)
    # no motion at all: zeros (no division by zero)
    still = Markers(np.ones((4, 4, 3)), np.zeros((4, 3)), np.zeros(4), 1, 30.0, "left")
    np.testing.assert_array_equal(position_features(still), np.zeros((4, 9)))


@pytest.mark.parametrize("up", [0, 1, 2])
def test_position_features_ignore_facing_scale_and_place(rng, up):
    """The same arm motion performed facing elsewhere (root heading turned with it), confined to
    half the reach, and elsewhere in the room: the same features."""
    mk = _markers(rng, 60, up)
    q = yaw_quat_deg(41.0, up)
    shift = np.array([30.0, -4.0, 12.0])
    rel = mk.points - mk.shoulder[:, None, :]
    sh = quat_rotate(q, mk.shoulder) + shift
    moved = Markers(quat_rotate(q, 0.5 * rel) + sh[:, None, :], sh, mk.heading + np.radians(41.0), up, mk.fps, "left")
    np.testing.assert_allclose(position_features(moved), position_features(mk), atol=1e-9)


def test_position_weight_needs_position_features(rng):
    body, hands = phase_features(_markers(rng, 10)), phase_features(_markers(rng, 12))
    with pytest.raises(ValueError, match="position=True"):
        d1_cost(body, hands, position_weight=1.0)
    with pytest.raises(ValueError, match="position_weight"):
        d1_cost(body, hands, position_weight=-1.0)


def test_position_weight_policy():
    """auto: (3, 0) on a clean pair (fixed ends, open ends), (10, 10) where noise matching
    smoothed it (either side: one decision for the pair), (0, 0) for a hand-only file or optical
    markers against virtual ones across the palm (placed differently: the hand-in-forearm signs, the
    only term they have, do not compare; the others: tests/test_wrist_signs.py); a number is used for both."""
    from types import SimpleNamespace

    from splicer import defaults as D
    from splicer.options import SpliceOptions
    from splicer.align.wrist import ANATOMICAL
    from splicer.stages.align import position_weights

    arm = SimpleNamespace(hand_only=False, real={})
    auto = SpliceOptions()
    assert position_weights(auto, arm, False) == (D.POSITION_WEIGHT, 0.0) == (3.0, 0.0)
    assert position_weights(auto, arm, True) == (D.POSITION_WEIGHT_NOISY,) * 2 == (10.0, 10.0)
    assert position_weights(auto, SimpleNamespace(hand_only=True, real={}), False) == (0.0, 0.0)
    optical = SimpleNamespace(hand_only=False, real={"hands": {}}, placed=(ANATOMICAL, "optical"))
    assert position_weights(auto, optical, True) == (0.0, 0.0)
    assert position_weights(SpliceOptions(position_weight=7.5), optical, True) == (0.0, 0.0)
    assert position_weights(SpliceOptions(position_weight=0), arm, True) == (0.0, 0.0)
    assert position_weights(SpliceOptions(position_weight=7.5), SimpleNamespace(hand_only=True, real={}), False) == (7.5, 7.5)


def test_open_ended_pass_weighs_positions_in_locating_and_penalty():
    """Open ends: the locating pass and the uncovered penalty use the pass's own cost."""
    from splicer.align.passes import pass1

    rng = np.random.default_rng(5)
    body, hands = _markers(rng, 120), _markers(rng, 150)
    p = pass1(body, hands, width=30.0, ends="open", position_weight=3.0)
    assert p.position_weight == p.located.position_weight == 3.0
    d1_only = pass1(body, hands, width=30.0, ends="open")
    assert d1_only.located.position_weight == 0.0 and p.uncovered_cost > d1_only.uncovered_cost
