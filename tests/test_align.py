"""Pass composition helpers and the coarse-guided band for long, drifting takes."""

import numpy as np
import pytest

from splicer.align import compose, guided_band, path_median, remap_constraints
from splicer.dtw import Constraint, dtw
from splicer.errors import BandError
from splicer.separate import separate
from splicer import splice
from splicer.synth import make_gesture_take


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

    plain = splice(sep.body, sep.hands, side="right", band1=band, coarse="off")
    guided = splice(sep.body, sep.hands, side="right", band1=band, coarse="on")
    assert err(guided) < 0.5 * err(plain)
    assert err(guided) < 3.0
