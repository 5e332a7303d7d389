"""D1's soft sign: known values, and continuity (issue 13: a hard dead zone made the alignment jump
by frames for 1e-5 degrees of input noise)."""

import numpy as np
import pytest

from splicer.align.costs import PhaseFeatures, _sgn, d1_cost
from splicer.align.dtw import make_band
from references import d1_reference


@pytest.mark.parametrize("x, eps, want", [(3.0, 4.0, 0.6), (-4.0, 3.0, -0.8), (0.0, 2.0, 0.0),
                                          (2.5, 0.0, 1.0), (-1e-300, 0.0, -1.0), (0.0, 0.0, 0.0)])
def test_soft_sign_known_values(x, eps, want):
    """x / sqrt(x^2 + eps^2); eps = 0 is the hard sign."""
    assert _sgn(x, eps) == pytest.approx(want, abs=1e-15)


def _features(vel, acc, eps):
    T = vel.shape[0]
    return PhaseFeatures(vel, acc, eps, eps, np.zeros((T, 2, 20)), np.zeros(T), 1)


def test_one_cell_by_hand():
    """Body and hands one frame, one marker moving along x only; heading theta = 0.
    body vel x = 3 (eps 4: sign 0.6), hands vel x = -4 (eps 3: sign -0.8): (0.6 + 0.8)^2 = 1.96;
    no acceleration: 0."""
    vb = np.zeros((1, 4, 3))
    vh = np.zeros((1, 4, 3))
    vb[0, 0, 0], vh[0, 0, 0] = 3.0, -4.0
    acc = np.zeros((1, 4, 3))
    body, hands = _features(vb, acc, 4.0), _features(vh, acc, 3.0)
    rows = d1_cost(body, hands, theta="heading")(make_band(1, 1, 1.0), 0, 1)
    assert rows[0, 0] == pytest.approx(1.96, abs=1e-12)
    assert d1_reference(body, hands, 0, 0, "heading") == pytest.approx(1.96, abs=1e-12)


def test_d1_is_continuous_at_the_dead_zone_edge(rng):
    """A hands component sitting exactly on the dead-zone edge, nudged by 1e-9: the hard sign
    jumped there by 1 (a cost change of 1 or more); the soft sign moves the cost by about 1e-9."""
    T = 30
    vb, ab = rng.normal(size=(T, 4, 3)), rng.normal(size=(T, 4, 3))
    vh, ah = rng.normal(size=(T, 4, 3)), rng.normal(size=(T, 4, 3))
    eps = 0.3
    vh[:, 0, 1] = eps  # the up component of marker 0, on the edge in every frame
    body = _features(vb, ab, eps)
    band = make_band(T, T, float(T))
    a = d1_cost(body, _features(vh, ah, eps), theta="heading")(band, 0, T)
    vh2 = vh.copy()
    vh2[:, 0, 1] += 1e-9
    b = d1_cost(body, _features(vh2, ah, eps), theta="heading")(band, 0, T)
    ok = np.isfinite(a)
    assert np.abs(a[ok] - b[ok]).max() < 1e-8
    assert np.abs(a[ok] - b[ok]).max() > 0  # and the nudge is seen
