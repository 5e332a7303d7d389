"""Band geometry for open ends: full_band, offset_band, guided_band with open ends, Band invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from splicer.align.passes import guided_band
from splicer.align.band import Band, Constraint, full_band
from splicer.errors import BandError, ConstraintError
from splicer.align.openend import coarse_rate, offset_band, uncovered_penalty


def test_open_band_invariants():
    b = Band(n=3, m=6, width=2.0, lo=np.array([2, 2, 3]), hi=np.array([3, 4, 4]), open_begin=True, open_end=True)
    assert b.open_begin and b.open_end and "open_begin" in repr(b)
    with pytest.raises(BandError, match="hi\\[2\\]"):
        Band(n=3, m=6, width=2.0, lo=np.array([0, 2, 3]), hi=np.array([3, 4, 4]), open_begin=True)
    with pytest.raises(BandError, match="connect"):       # rows must still connect
        Band(n=3, m=6, width=2.0, lo=np.array([0, 5, 5]), hi=np.array([1, 5, 5]), open_begin=True, open_end=True)


def test_full_band_and_pins():
    b = full_band(5, 7)
    assert b.n_cells == 35 and math.isinf(b.width) and b.open_begin and b.open_end
    b = full_band(5, 7, [Constraint(2, 3, 1)], open_end=False)
    np.testing.assert_array_equal(b.lo, [0, 0, 2, 2, 2])
    np.testing.assert_array_equal(b.hi, [4, 4, 4, 6, 6])
    assert not b.open_end
    with pytest.raises(ConstraintError):
        full_band(5, 7, [Constraint(4, 3)])


def test_offset_band_geometry():
    b = offset_band(10, 30, 5.0, math.sqrt(2) * 2)          # |j - i - 5| <= 2
    for i in range(10):
        assert (b.lo[i], b.hi[i]) == (i + 3, i + 7)
    b = offset_band(10, 8, -3.0, math.sqrt(2))             # the hands start 3 frames after the body
    assert b.lo[0] == 0 and b.hi[0] == 0 and b.hi[-1] == 7
    b = offset_band(10, 30, 5.0, 4 * math.sqrt(2), [Constraint(4, 8, 0)])
    assert b.lo[4] == b.hi[4] == 8
    with pytest.raises(BandError, match="outside the band"):
        offset_band(10, 30, 5.0, 2.0, [Constraint(4, 20, 0)])
    with pytest.raises(BandError, match="outside the hands take"):
        offset_band(10, 30, 50.0, 2.0)


def test_guided_band_open_ends_follow_a_partial_coarse_path():
    # coarse path (factor 4) covering coarse rows 10..30 from coarse column 0
    I = np.arange(10, 31)
    coarse = np.stack([I, I - 10], axis=1)
    b = guided_band(coarse, 4.0, 200, 120, 8.0, open_begin=True, open_end=True)
    assert b.open_begin and b.open_end
    assert b.hi[-1] < 119                                    # the band need not reach (n-1, m-1)
    for i in range(40, 121, 10):
        assert b.lo[i] <= 4 * (round(i / 4) - 10) <= b.hi[i]
    fixed = guided_band(coarse, 4.0, 200, 120, 8.0)
    assert fixed.lo[0] == 0 and fixed.hi[-1] == 119


def test_uncovered_penalty_and_coarse_rate():
    c = np.array([[0.0, 1.0, 2.0, 3.0], [4.0, 5.0, np.inf, 6.0]])
    assert uncovered_penalty(c, 0.5) == pytest.approx(3.0)   # inf ignored: median of 0..6
    sub = uncovered_penalty(np.arange(100.0), 0.5, max_samples=10, seed=1)   # a seeded subset
    assert sub != 49.5 and sub == uncovered_penalty(np.arange(100.0), 0.5, max_samples=10, seed=1)
    with pytest.raises(ValueError, match="quantile"):
        uncovered_penalty(c, 1.0)
    with pytest.raises(ValueError, match="finite"):
        uncovered_penalty(np.full(3, np.inf))
    assert coarse_rate(36000, 45000, 30.0, 5.0) == 5.0       # 6000 x 7500 = 45 M cells fit
    r = coarse_rate(360000, 450000, 30.0, 5.0)               # 200 minutes: lowered to fit 64 Mi cells
    assert (360000 * r / 30) * (450000 * r / 30) == pytest.approx(1 << 26)
    assert coarse_rate(100, 100, 2.0, 5.0) == 2.0
