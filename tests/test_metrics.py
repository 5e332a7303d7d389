"""The D1 and D2 kernels against slow plain references, and theta's sign against a known turn."""

import numpy as np
import pytest

from splicer.align.dtw import make_band
from splicer.rig.markers import Markers
from references import d1_reference, d2_reference
from splicer.align.costs import d1_cost, d2_cost, kgp_theta, palm_features, phase_features, window_points
from splicer.model.rotations import quat_rotate, yaw_quat_deg


def _markers(rng, T, up=1, fps=30.0):
    t = np.arange(T)[:, None, None] / fps
    pts = np.cumsum(rng.normal(size=(T, 4, 3)), axis=0) + 10 * np.sin(t * rng.uniform(1, 3, size=(1, 4, 3)))
    return Markers(pts, rng.normal(size=(T, 3)) * 0.1, np.cumsum(rng.normal(size=T)) * 0.05, up, fps, "left")


@pytest.mark.parametrize("theta", ["window", "heading"])
@pytest.mark.parametrize("up", [1, 2])
def test_d1_kernel_matches_reference(rng, theta, up):
    body = phase_features(_markers(rng, 40, up))
    hands = phase_features(_markers(rng, 55, up))
    band = make_band(40, 55, 20.0)
    rows = d1_cost(body, hands, theta=theta)(band, 0, 40)
    for i in range(40):
        for c in range(band.hi[i] - band.lo[i] + 1):
            j = band.lo[i] + c
            assert rows[i, c] == pytest.approx(d1_reference(body, hands, i, j, theta), abs=1e-9), (i, j)
        assert np.all(np.isinf(rows[i, band.hi[i] - band.lo[i] + 1:]))


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
    assert np.all(diag == 0)
