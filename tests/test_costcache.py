"""Pass 1's kept local costs (splicer.align.costcache): the readers get exactly what they would compute."""

import numpy as np
import pytest

from splicer.align.band import Band
from splicer.align.confidence import pass_confidence
from splicer.align.costcache import CachedBandCost
from splicer.align.dtw import dtw, make_band
from splicer.align.posterior import path_posterior, tube_band


class _Counting:
    """A band-chunk cost over a full matrix ``C`` that counts the cells it computes."""

    def __init__(self, C):
        self.C = C
        self.cells = 0

    def __call__(self, band, i0, i1):
        out = np.full((i1 - i0, band.max_row_width), np.inf)
        for r, i in enumerate(range(i0, i1)):
            w = band.hi[i] - band.lo[i] + 1
            out[r, :w] = self.C[i, band.lo[i]:band.hi[i] + 1]
            self.cells += w
        return out


def test_worked_answer_small_band():
    """A 3 x 4 band with rows [0, 1], [0, 2], [2, 3]: 7 cells.  A budget of 20 bytes keeps the
    first 2 rows (5 cells, 20 bytes; 3 rows would be 28); their costs come back as float32."""
    C = np.array([[0.1, 1.0, 9.0, 9.0],
                  [2.0, 0.3, 1.5, 9.0],
                  [9.0, 9.0, 0.7, 0.2]])
    band = Band(n=3, m=4, width=2.0, lo=np.array([0, 0, 2]), hi=np.array([1, 2, 3]))
    base = _Counting(C)
    cost = CachedBandCost(base, band, budget_bytes=20)
    first = cost(band, 0, 3)                   # what the DTW sees: the fresh float64 values
    assert first[0, :2].tolist() == [0.1, 1.0] and first[0, 2] == np.inf
    assert base.cells == 7 and cost.kept_rows == 2 and cost.kept_bytes == 20
    again = cost(band, 0, 2)                    # kept: no new cells computed
    assert base.cells == 7
    f = np.float32
    assert again.tolist() == [[f(0.1), f(1.0), np.inf], [f(2.0), f(0.3), f(1.5)]]
    assert again.dtype == np.float64
    cost(band, 1, 3)                            # row 2 is past the budget: computed again
    assert base.cells == 7 + 5
    # a band inside the pass's band (the expected path's tube): served from the copy
    tube = Band(n=3, m=4, width=1.0, lo=np.array([0, 1, 2]), hi=np.array([0, 2, 3]))
    got = cost(tube, 0, 2)
    assert base.cells == 12
    assert got.tolist() == [[np.float32(0.1), np.inf], [np.float32(0.3), np.float32(1.5)]]
    cost.release()
    cost(band, 0, 2)
    assert base.cells == 12 + 5 and cost.kept_rows == 0 and cost.kept_bytes == 0


def test_served_rows_equal_fresh_float32(rng):
    n, m = 60, 75
    C = rng.random((n, m)) * 10
    band = make_band(n, m, 12.0)
    cost = CachedBandCost(_Counting(C), band, budget_bytes=1 << 20)
    res = dtw(lambda i0, i1: cost(band, i0, i1), band)
    assert cost.kept_rows == n
    ref = dtw(lambda i0, i1: _Counting(C)(band, i0, i1), band)
    assert np.array_equal(res.path, ref.path) and res.cost == ref.cost
    fresh = _Counting(C)(band, 0, n)
    assert np.array_equal(cost(band, 0, n), np.where(np.isfinite(fresh), fresh.astype(np.float32), np.inf))
    tube = tube_band(band, res.path, 3)
    for i0, i1 in ((0, n), (5, 17)):
        fresh_t = _Counting(C)(tube, i0, i1)
        assert np.array_equal(cost(tube, i0, i1), np.where(np.isfinite(fresh_t), fresh_t.astype(np.float32), np.inf))


@pytest.mark.parametrize("budget", [0, 600, 1 << 30])
def test_confidence_and_expected_path_unchanged(rng, budget):
    """With all, some or none of the rows kept, the confidence and the expected path are the
    ones computed from scratch (bit for bit)."""
    from splicer.align.passes import PassResult

    n, m = 80, 96
    C = rng.random((n, m)) * 5 + (np.abs(np.arange(n)[:, None] * (m - 1) / (n - 1) - np.arange(m)[None, :]) / 10)
    band = make_band(n, m, 20.0)
    plain = _Counting(C)
    res = dtw(lambda i0, i1: plain(band, i0, i1), band)
    kept = CachedBandCost(_Counting(C), band, budget_bytes=budget)
    dtw(lambda i0, i1: kept(band, i0, i1), band)
    fits = int(np.searchsorted(np.cumsum(band.hi - band.lo + 1), budget // 4, side="right"))
    assert kept.kept_rows == min(n, fits)
    a = pass_confidence(PassResult(res.path, res.cost, band, "pass1", plain), 30.0)
    b = pass_confidence(PassResult(res.path, res.cost, band, "pass1", plain, kept_cost=kept), 30.0)
    for f in ("spread_frames", "est_error_s", "confidence", "row_excess"):
        assert np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True), f
    assert a.threshold == b.threshold
    pa = path_posterior(plain, band, res.path, temperature=2.0, radius=4)
    pb = path_posterior(kept, band, res.path, temperature=2.0, radius=4)
    assert np.array_equal(pa.mean, pb.mean, equal_nan=True) and np.array_equal(pa.std, pb.std, equal_nan=True)


def test_pass1_keeps_its_costs_and_the_splice_releases_them():
    """pass1 keeps D1 in the cache beside its plain local cost; after the confidence the splice frees it."""
    from pathlib import Path

    from splicer.io.bvh import read_bvh
    from splicer.pipeline import splice

    root = Path(__file__).resolve().parents[1] / "motions"
    body, hands = read_bvh(root / "sample_body.bvh"), read_bvh(root / "sample_hands.bvh")
    r = splice(body, hands, side="left")
    p1 = r.sides["left"].pass1
    assert isinstance(p1.kept_cost, CachedBandCost) and p1.kept_cost.band is p1.band
    assert p1.kept_cost.cost is p1.local_cost  # local_cost itself computes afresh (float64)
    assert p1.kept_cost.kept_rows == 0  # released
