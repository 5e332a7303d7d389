"""Open-begin / open-end banded DTW (ALGORITHM.md section 9): the kernel against a plain-Python
full-matrix reference, known-answer location of a body inside a longer hands take, partial
coverage, and constraints that hold with open ends."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from splicer.align.band import Band, Constraint, full_band, make_band
from splicer.align.dtw import dtw, dtw_features
from splicer.errors import BandError, SplicerError
from splicer.rig.markers import Markers

from test_dtw import as_callable, random_constraints, ref_mask, sqdist


@pytest.fixture
def rng():
    return np.random.default_rng(90210)


# ------------------------------------------------------------------ slow reference

def ref_open_dtw(C, mask, open_begin, open_end, u, cons=(), pen=0.0, hw=1.0, held=None, b=None):
    """Full-matrix DTW with open ends, straight from the definition.

    Start: (0, 0) at cost 0 (fixed), or (open) any admissible (0, j) at cost 0 or (i, 0) with
    i <= first pin row at cost u * i.  End: (n-1, m-1) (fixed), or (open) the admissible (n-1, j)
    or (i, m-1) with i >= last pin row minimising gamma + u * (n - 1 - i), first in row-major
    order on ties.  Open ends leave body rows beyond the hands take uncovered rather than held:
    no step (i-1, 0) -> (i, 0) out of a start cell, no end on column m-1 entered by a step
    (i-1, m-1) -> (i, m-1).
    Ties between candidates: diagonal, up, left, start (a later one must be strictly smaller).
    ``pen`` is added to the up and left candidates; a cell entered from the left costs
    ``hw * C`` (written ``C + (g + pen + (hw - 1) C)`` as the kernel adds it).  A held row
    (``held[i]``, i > 0: the body holds still) is entered only from the cell above, at ``pen``
    and no local cost, or by a start (at its cell's cost); a +inf cost still forbids a cell.
    ``b`` (both heads / tails skipped at once, not None): a path may also start at any admissible
    (i, j) of a row that is not held, at u * i + b * min(j, i), with no step (i-1, j) -> (i, j)
    out of a start cell but a row-0 one past column 0 (into a row that is not held); it may end
    at any admissible (i, j), at gamma + u * (n - 1 - i) + b * min(m - 1 - j, n - 1 - i), but
    not on a cell entered by a step (i-1, j) unless on the last row before column m-1.
    """
    n, m = C.shape
    last_start = cons[0].x if cons else n - 1
    first_end = cons[-1].x if cons else 0
    g = np.full((n, m), np.inf)
    step = np.full((n, m), -1)
    for i in range(n):
        for j in range(m):
            if not mask[i, j]:
                continue
            up_ok = i > 0 and not (open_begin and j == 0 and step[i - 1, j] == 3)   # no hold out of a start
            is_held = held is not None and i > 0 and held[i]
            if b is not None and not is_held:   # no hold out of any start but a row-0 one past column 0
                up_ok = i > 0 and not (step[i - 1, j] == 3 and (i > 1 or j == 0))
            if is_held:
                cands = [(g[i - 1, j] + pen - C[i, j] if up_ok and C[i, j] < np.inf else np.inf, 1)]
                if open_begin and i <= last_start and j == 0:
                    cands.append((u * i, 3))
                best, s = np.inf, -1
                for v, code in cands:
                    if v < best:
                        best, s = v, code
                if s >= 0:
                    g[i, j] = C[i, j] + best
                    step[i, j] = s
                continue
            cands = [(g[i - 1, j - 1] if i > 0 and j > 0 else np.inf, 0),
                     (g[i - 1, j] + pen if up_ok else np.inf, 1),
                     (g[i, j - 1] + pen + ((hw - 1) * C[i, j] if hw != 1 and C[i, j] < np.inf else 0.0)
                      if j > 0 else np.inf, 2)]
            if open_begin and i <= last_start and b is not None:
                cands.append((u * i + b * min(j, i), 3))
            elif open_begin and i <= last_start and (i == 0 or j == 0):
                cands.append((u * i, 3))
            elif not open_begin and i == 0 and j == 0:
                cands.append((0.0, 3))
            best, s = np.inf, -1
            for v, code in cands:
                if v < best:
                    best, s = v, code
            if s < 0:
                continue
            g[i, j] = C[i, j] + best
            step[i, j] = s
    if open_end:
        cost, end = np.inf, None
        for i in range(first_end, n):
            for j in range(m):
                if b is not None:
                    if step[i, j] == 1 and (i < n - 1 or j == m - 1):   # no end on a hold
                        continue
                    v = g[i, j] + u * (n - 1 - i) + b * min(m - 1 - j, n - 1 - i)
                    if v < cost:
                        cost, end = v, (i, j)
                    continue
                if not (i == n - 1 or j == m - 1):
                    continue
                if j == m - 1 and step[i, j] == 1:  # no end on a hold of the last hands frame
                    continue
                v = g[i, j] + u * (n - 1 - i)
                if v < cost:
                    cost, end = v, (i, j)
    else:
        cost, end = g[n - 1, m - 1], (n - 1, m - 1)
    if not np.isfinite(cost):
        return cost, None
    i, j = end
    path = [(i, j)]
    while step[i, j] != 3:
        s = step[i, j]
        i, j = (i - 1, j - 1) if s == 0 else (i - 1, j) if s == 1 else (i, j - 1)
        path.append((i, j))
    return cost, np.array(path[::-1], dtype=np.int64)


def band_mask(band):
    mask = np.zeros((band.n, band.m), dtype=bool)
    for i in range(band.n):
        mask[i, band.lo[i]:band.hi[i] + 1] = True
    return mask


def check_open_path(path, band):
    steps = {tuple(s) for s in np.diff(path, axis=0)}
    assert steps <= {(1, 0), (0, 1), (1, 1)}
    for i, j in path:
        assert band.contains(i, j)


# ------------------------------------------------------------------ kernel == reference

SHAPES = [(1, 1), (1, 7), (7, 1), (2, 2), (5, 9), (9, 5), (12, 30), (30, 12), (24, 24)]


def random_problem(rng, n, m, trial):
    """Random local costs (some +inf every third trial, else repeated values: ties), an uncovered
    penalty, a step penalty and a horizontal weight."""
    C = rng.random((n, m)) * rng.choice([1.0, 3.0])
    C[rng.random((n, m)) < 0.05] = np.inf if trial % 3 == 0 else C[0, 0]
    u = float(rng.choice([0.0, 0.2, 0.5, 2.0]))
    pen = float(rng.choice([0.0, 0.0, 0.1, 0.7]))
    hw = float(rng.choice([1.0, 1.0, 0.5, 0.2]))
    return C, u, pen, hw


@pytest.mark.parametrize("n,m", SHAPES)
@pytest.mark.parametrize("ends", [(True, False), (False, True), (True, True), (False, False)])
def test_open_ends_match_reference(rng, n, m, ends):
    ob, oe = ends
    for trial in range(6):
        C, u, pen, hw = random_problem(rng, n, m, trial)
        cons = random_constraints(rng, n, m, int(rng.integers(0, 3)), int(rng.integers(0, 3)))
        try:
            if trial % 2:
                band = full_band(n, m, cons, open_begin=ob, open_end=oe)
                mask = band_mask(band)
            else:
                W = float(rng.uniform(2, 10))
                band = make_band(n, m, W, cons)
                mask = ref_mask(n, m, W, band.constraints)
        except SplicerError:                  # infeasible random constraints
            continue
        ref_cost, ref_path = ref_open_dtw(C, mask, ob, oe, u, band.constraints, pen, hw)
        if ref_path is None:
            with pytest.raises(BandError, match="no path of finite cost"):
                dtw(C, band, open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw)
            continue
        for cost in (C, as_callable(C, band)):
            res = dtw(cost, band, open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw)
            assert res.cost == pytest.approx(ref_cost, rel=1e-12, abs=1e-12)
            np.testing.assert_array_equal(res.path, ref_path)
            assert res.covered == (ref_path[0, 0], ref_path[-1, 0])
            check_open_path(res.path, band)
            for c in band.constraints:        # pins hold with open ends
                js = res.path[res.path[:, 0] == c.x, 1]
                assert js.size and np.abs(js - c.y).max() <= c.tolerance


@pytest.mark.parametrize("n,m", [(5, 9), (12, 30), (30, 12), (24, 24)])
@pytest.mark.parametrize("ends", [(True, False), (False, True), (True, True), (False, False)])
def test_held_rows_match_reference(rng, n, m, ends):
    """Rows where the body holds (splicer.align.holds): the kernels, both cost forms and the fused
    one, against the reference, with pins, penalties and forbidden cells."""
    ob, oe = ends
    checked = 0
    for trial in range(8):
        C = rng.random((n, m)) * rng.choice([1.0, 3.0])
        C[rng.random((n, m)) < 0.05] = np.inf if trial % 3 == 0 else C[0, 0]
        u = float(rng.choice([0.0, 0.2, 2.0]))
        pen = float(rng.choice([0.0, 0.1, 0.7]))
        hw = float(rng.choice([1.0, 0.5]))
        held = np.zeros(n, bool)
        a = int(rng.integers(1, n - 1))
        held[a:min(a + int(rng.integers(1, 6)), n)] = True
        cons = random_constraints(rng, n, m, int(rng.integers(0, 2)), int(rng.integers(0, 3)))
        try:
            band = full_band(n, m, cons, open_begin=ob, open_end=oe) if trial % 2 else make_band(n, m, 6.0, cons)
        except SplicerError:
            continue
        mask = band_mask(band)
        ref_cost, ref_path = ref_open_dtw(C, mask, ob, oe, u, band.constraints, pen, hw, held)
        if ref_path is None:
            with pytest.raises(BandError, match="no path of finite cost"):
                dtw(C, band, open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw,
                    held_rows=held)
            continue
        for cost in (C, as_callable(C, band)):
            res = dtw(cost, band, open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw,
                      held_rows=held)
            assert res.cost == pytest.approx(ref_cost, rel=1e-12, abs=1e-12)
            np.testing.assert_array_equal(res.path, ref_path)
        for i, j in res.path:  # a held row is entered from straight above, or the path starts there
            if held[i] and i > res.path[0, 0]:
                assert (i - 1, j) in {tuple(c) for c in res.path}
        checked += 1
    assert checked >= 3


def test_held_rows_fused_kernel_and_bad_input(rng):
    n, m = 23, 37
    X, Y = rng.normal(size=(n, 3)), rng.normal(size=(m, 3))
    band = full_band(n, m, open_begin=True, open_end=True)
    held = np.zeros(n, bool)
    held[8:14] = True
    ref_cost, ref_path = ref_open_dtw(sqdist(X, Y), band_mask(band), True, True, 1.0, (), 0.25, 0.5, held)
    res = dtw_features(X, Y, band, open_begin=True, open_end=True, uncovered_cost=1.0, step_penalty=0.25,
                       horizontal_weight=0.5, held_rows=held)
    assert res.cost == pytest.approx(ref_cost, rel=1e-12)
    np.testing.assert_array_equal(res.path, ref_path)
    with pytest.raises(ValueError, match="held_rows"):
        dtw(sqdist(X, Y), band, held_rows=np.zeros(n))  # not boolean
    with pytest.raises(ValueError, match="held_rows"):
        dtw(sqdist(X, Y), band, held_rows=np.zeros(n + 1, bool))


def test_a_body_hold_is_crossed_flat():
    """Worked answer: the true path runs the diagonal to (19, 19), stays on hands frame 19 while
    the body holds (rows 20-27), then resumes shifted by 8.  Its cells cost 0, every other cell
    1, except a stretch around the hold (rows 14-34, columns 14-26) where every cell costs 0.5:
    the arm is still and D1 cannot tell.  A plain DTW crosses that stretch on as few cells as
    it can and puts the flat part where the tie rule leaves it (rows 14-22, too early); with the
    hold's rows held (all but its first), the flat part lies on the hold and the path is on the
    truth from row 20 on (one frame behind before it)."""
    n, m = 48, 40
    truth = np.array([i if i <= 19 else (19 if i <= 27 else i - 8) for i in range(n)])
    C = np.ones((n, m))
    C[np.arange(n), truth] = 0.0
    C[14:35, 14:27] = 0.5
    held = np.zeros(n, bool)
    held[21:28] = True
    got = {}
    for name, h in (("plain", None), ("held", held)):
        res = dtw(C, full_band(n, m), held_rows=h)
        got[name] = np.array([max(j for i2, j in res.path if i2 == i) for i in range(n)])
    np.testing.assert_array_equal(got["held"][20:], truth[20:])
    assert np.abs(got["held"] - truth).max() <= 1
    assert got["plain"][14:23].tolist() == [14] * 9 and np.abs(got["plain"] - truth).max() >= 5


@pytest.mark.parametrize("ends", [(True, False), (False, True), (True, True)])
def test_features_kernel_matches_reference(rng, ends):
    ob, oe = ends
    n, m = 23, 37
    X, Y = rng.normal(size=(n, 3)), rng.normal(size=(m, 3))
    band = full_band(n, m, open_begin=ob, open_end=oe)
    for metric, C in (("sqeuclidean", sqdist(X, Y)), ("euclidean", np.sqrt(sqdist(X, Y)))):
        ref_cost, ref_path = ref_open_dtw(C, band_mask(band), ob, oe, 1.0, (), 0.25, 0.5)
        res = dtw_features(X, Y, band, metric, open_begin=ob, open_end=oe, uncovered_cost=1.0, step_penalty=0.25,
                           horizontal_weight=0.5)
        assert res.cost == pytest.approx(ref_cost, rel=1e-12)
        np.testing.assert_array_equal(res.path, ref_path)


@pytest.mark.parametrize("n,m", SHAPES)
@pytest.mark.parametrize("ends", [(True, False), (False, True), (True, True), (False, False)])
def test_both_skip_matches_reference(rng, n, m, ends):
    """Starts and ends at any cell (``both_skip_cost``): the kernels against the reference, with
    pins, penalties, horizontal weights and held rows."""
    ob, oe = ends
    for trial in range(6):
        C, u, pen, hw = random_problem(rng, n, m, trial)
        b = float(rng.choice([0.0, 0.1, 0.3, 1.0]))
        held = rng.random(n) < 0.2 if trial % 2 else None
        if held is not None:
            held[0] = False
        cons = random_constraints(rng, n, m, int(rng.integers(0, 3)), int(rng.integers(0, 3)))
        try:
            band = full_band(n, m, cons, open_begin=ob, open_end=oe) if trial % 2 else \
                make_band(n, m, float(rng.uniform(2, 10)), cons)
        except SplicerError:
            continue
        if not ob and band.lo[0] != 0 or not oe and band.hi[-1] != m - 1:
            continue
        mask = band_mask(band)
        ref_cost, ref_path = ref_open_dtw(C, mask, ob, oe, u, band.constraints, pen, hw, held, b)
        kw = dict(open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw,
                  held_rows=held, both_skip_cost=b)
        if ref_path is None:
            with pytest.raises(BandError, match="no path of finite cost"):
                dtw(C, band, **kw)
            continue
        for cost in (C, as_callable(C, band)):
            res = dtw(cost, band, **kw)
            assert res.cost == pytest.approx(ref_cost, rel=1e-12, abs=1e-12)
            np.testing.assert_array_equal(res.path, ref_path)
            assert res.both_skip_cost == b
            check_open_path(res.path, band)
            for c in band.constraints:        # pins hold
                js = res.path[res.path[:, 0] == c.x, 1]
                assert js.size and np.abs(js - c.y).max() <= c.tolerance


def test_both_skip_fused_kernel_and_bad_values(rng):
    n, m = 23, 37
    X, Y = rng.normal(size=(n, 3)), rng.normal(size=(m, 3))
    band = full_band(n, m, open_begin=True, open_end=True)
    for metric, C in (("sqeuclidean", sqdist(X, Y)), ("euclidean", np.sqrt(sqdist(X, Y)))):
        ref_cost, ref_path = ref_open_dtw(C, band_mask(band), True, True, 1.0, (), 0.25, 0.5, None, 0.3)
        res = dtw_features(X, Y, band, metric, open_begin=True, open_end=True, uncovered_cost=1.0, step_penalty=0.25,
                           horizontal_weight=0.5, both_skip_cost=0.3)
        assert res.cost == pytest.approx(ref_cost, rel=1e-12)
        np.testing.assert_array_equal(res.path, ref_path)
    for bad in (-0.1, np.inf, np.nan):
        with pytest.raises(ValueError, match="both_skip_cost"):
            dtw(sqdist(X, Y), band, open_begin=True, open_end=True, both_skip_cost=bad)
    assert dtw(sqdist(X, Y), band, open_begin=True, open_end=True).both_skip_cost is None


def test_hand_checked_both_skip():
    # hands frames 2, 3 show body rows 1, 2: the hands take starts with two frames of extra
    # material and the body with one uncovered row (and likewise at the end)
    C = np.full((4, 6), 5.0)
    C[1, 2] = C[2, 3] = 0.0
    band = full_band(4, 6)
    # without both_skip_cost a start is on row 0 or column 0 (an end on row 3 or column 5): the
    # cheapest is one cell, (0, 5), at 5, and three rows uncovered
    old = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=1.0)
    np.testing.assert_array_equal(old.path, [[0, 5]])
    assert old.cost == 5.0 + 3 * 1.0
    # with it: start (1, 2) for u * 1 + b * min(2, 1), end (2, 3) for u * 1 + b * min(2, 1)
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=1.0, both_skip_cost=0.5)
    np.testing.assert_array_equal(res.path, [[1, 2], [2, 3]])
    assert res.cost == (1.0 + 0.5) + 0.0 + 0.0 + (1.0 + 0.5) and res.covered == (1, 2)
    # skipped hands frames beyond the uncovered rows are free: b counts min(j, i), not j
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=1.0, both_skip_cost=2.0)
    assert res.cost == 2 * (1.0 + 2.0)
    # priced over covering the 5s, the path covers them instead
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=1.0, both_skip_cost=10.0)
    assert res.cost == old.cost and res.covered == old.covered


def test_hand_checked_open_ends():
    # hands frames 0, 1 show body rows 1, 2; body rows 0 and 3 have no hands material
    C = np.array([[5., 5.],
                  [0., 5.],
                  [5., 0.],
                  [5., 5.]])
    band = full_band(4, 2)
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=1.0)
    np.testing.assert_array_equal(res.path, [[1, 0], [2, 1]])     # start (i, 0), end (i, m-1)
    assert res.cost == 2.0 and res.covered == (1, 2)
    # u = 6: still uncovered (12): covering row 0 would hold hands frame 0 from (0, 0) into
    # row 1, covering row 3 would end on a hold of the last hands frame; neither is allowed
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=6.0)
    assert res.covered == (1, 2) and res.cost == 12.0
    res = dtw(C, band, open_begin=True, open_end=False, uncovered_cost=1.0)
    np.testing.assert_array_equal(res.path, [[1, 0], [2, 1], [3, 1]])   # a fixed end may hold
    assert res.cost == 1.0 + 0 + 0 + 5
    # a longer hands take: the path starts on row 0 at the matching hands frame, skipping 0..2 for free
    D = np.full((3, 7), 9.0)
    D[0, 3] = D[1, 4] = D[2, 5] = 1.0
    res = dtw(D, full_band(3, 7), open_begin=True, open_end=True, uncovered_cost=100.0)
    np.testing.assert_array_equal(res.path, [[0, 3], [1, 4], [2, 5]])
    assert res.cost == 3.0


def test_fixed_ends_are_unchanged(rng):
    C = rng.random((20, 26))
    band = make_band(20, 26, 8.0)
    a = dtw(C, band)
    b = dtw(C, band, open_begin=False, open_end=False, uncovered_cost=3.0)
    np.testing.assert_array_equal(a.path, b.path)
    assert a.cost == b.cost and a.covered == (0, 19)


def test_open_band_needs_open_ends(rng):
    band = Band(n=3, m=5, width=2.0, lo=np.array([1, 1, 2]), hi=np.array([2, 3, 3]), open_begin=True,
                open_end=True)
    C = rng.random((3, 5))
    with pytest.raises(BandError, match="open_begin=True"):
        dtw(C, band, open_end=True)
    with pytest.raises(BandError, match="open_end=True"):
        dtw(C, band, open_begin=True)
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=10.0)
    assert res.covered == (0, 2)
    with pytest.raises(ValueError, match="uncovered_cost"):
        dtw(C, band, open_begin=True, open_end=True, uncovered_cost=-1.0)
    with pytest.raises(ValueError, match="step_penalty"):
        dtw(C, band, open_begin=True, open_end=True, step_penalty=np.nan)
    with pytest.raises(ValueError, match="horizontal_weight"):
        dtw(C, band, open_begin=True, open_end=True, horizontal_weight=0.0)
    with pytest.raises(BandError, match="lo\\[0\\]"):
        Band(n=3, m=5, width=2.0, lo=np.array([1, 1, 2]), hi=np.array([2, 3, 4]))


# ------------------------------------------------------------------ known answers, marker-like features

FPS = 30.0


def marker_like(rng, n, d=12):
    """Smooth arm-like motion: a sum of a few sinusoids per channel (cm), 0.05 cm noise."""
    t = np.arange(n) / FPS
    out = np.zeros((n, d))
    for k in range(d):
        for _ in range(3):
            f, p, a = rng.uniform(0.2, 1.2), rng.uniform(0, 2 * np.pi), rng.uniform(3, 15)
            out[:, k] += a * np.sin(2 * np.pi * f * t + p)
    return out


def smooth_warp(rng, n_out, n_in):
    """Monotone map from n_out output frames to fractional input frames 0..n_in-1, speed 0.7-1.4x."""
    speed = np.exp(0.35 * np.sin(2 * np.pi * (np.arange(n_out) / n_out * rng.uniform(1, 3) + rng.uniform())))
    t = np.concatenate([[0.0], np.cumsum(speed[:-1])])
    return t / t[-1] * (n_in - 1)


def sample(X, frames):
    idx = np.arange(X.shape[0])
    return np.stack([np.interp(frames, idx, X[:, k]) for k in range(X.shape[1])], axis=1)


def sq_costs(X, Y):
    return sqdist(X, Y)


def uncovered_cost_for(C):
    """A clean metric (squared distances of noiseless features): a true match costs ~0 while
    unrelated pairs are orders of magnitude dearer, so a low quantile suffices; a high one
    would let the path hold the first (last) hands frame over body frames beyond the take."""
    from splicer.align.openend import uncovered_penalty
    return uncovered_penalty(C.ravel(), 0.01)


def test_body_located_inside_longer_hands_take(rng):
    """hands = [3 s still] + warped body + [3 s of other motion]: located within one frame."""
    n = 300
    body = marker_like(rng, n)
    m_mid = 340
    warp = smooth_warp(rng, m_mid, n)                 # hands frame k shows body frame warp[k]
    pre, post = int(3 * FPS), int(3 * FPS)
    other = marker_like(np.random.default_rng(7), post)
    hands = np.concatenate([np.repeat(body[:1], pre, axis=0), sample(body, warp), other])
    hands = hands + rng.normal(scale=0.05, size=hands.shape)
    C = sq_costs(body, hands)
    res = dtw(C, full_band(n, hands.shape[0]), open_begin=True, open_end=True, uncovered_cost=uncovered_cost_for(C))
    assert res.covered == (0, n - 1)
    j0, j1 = res.path[0, 1], res.path[-1, 1]
    assert abs(j0 - pre) <= 1 and abs(j1 - (pre + m_mid - 1)) <= 1
    # every body row is matched near its true hands frame
    truth = pre + np.interp(np.arange(n), warp, np.arange(m_mid))
    err = np.abs(res.path[:, 1] - truth[res.path[:, 0]])
    assert err.max() <= 2.0 and err.mean() < 0.6
    # fixed ends cannot do it: the path is forced through the still pose and the other motion
    fixed = dtw(C, make_band(n, hands.shape[0], 1e9))
    assert np.abs(fixed.path[:, 1] - truth[fixed.path[:, 0]]).max() > 30


def test_hands_cover_only_the_middle_half(rng):
    """Hands cover body frames n/4 .. 3n/4: the path leaves both ends of the body uncovered."""
    n = 320
    body = marker_like(rng, n)
    a, b = n // 4, 3 * n // 4                        # covered body frames a .. b - 1
    m = 200
    warp = a + smooth_warp(rng, m, b - a)
    hands = sample(body, warp) + rng.normal(scale=0.05, size=(m, body.shape[1]))
    C = sq_costs(body, hands)
    res = dtw(C, full_band(n, m), open_begin=True, open_end=True, uncovered_cost=uncovered_cost_for(C))
    assert abs(res.covered[0] - a) <= 1 and abs(res.covered[1] - (b - 1)) <= 1
    assert res.path[0, 1] <= 1 and res.path[-1, 1] >= m - 2
    truth = np.interp(res.path[:, 0], warp, np.arange(m))
    assert np.abs(res.path[:, 1] - truth).max() <= 2.0


def test_partial_overlap_both_ends(rng):
    """hands = [3 s still] + the body's middle half, warped + [3 s other motion]: the body's
    ends are uncovered *and* the hands' extra material skipped, located within two frames; without
    ``both_skip_cost`` the path must take one of the two at each end."""
    n = 320
    body = marker_like(rng, n)
    a, b = n // 4, 3 * n // 4                        # covered body frames a .. b - 1
    m_mid = 200
    warp = a + smooth_warp(rng, m_mid, b - a)
    pre, post = int(3 * FPS), int(3 * FPS)
    hands = np.concatenate([np.repeat(body[:1], pre, axis=0), sample(body, warp),
                            marker_like(np.random.default_rng(7), post)])
    hands = hands + rng.normal(scale=0.05, size=hands.shape)
    C = sq_costs(body, hands)
    u = uncovered_cost_for(C)
    band = full_band(n, hands.shape[0])
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=u, both_skip_cost=0.3 * u)
    # within two frames (a neighbouring body frame of this smooth motion costs less than u)
    assert abs(res.covered[0] - a) <= 2 and abs(res.covered[1] - (b - 1)) <= 2
    assert abs(res.path[0, 1] - pre) <= 2 and abs(res.path[-1, 1] - (pre + m_mid - 1)) <= 2
    truth = pre + np.interp(res.path[:, 0], warp, np.arange(m_mid))
    assert np.abs(res.path[:, 1] - truth).max() <= 2.0
    old = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=u)
    assert old.cost > res.cost
    wrong = (old.path[0, 0] == 0 or old.path[0, 1] == 0) and (old.path[-1, 0] == n - 1 or
                                                               old.path[-1, 1] == hands.shape[0] - 1)
    assert wrong


def test_pins_hold_with_open_ends(rng):
    """A pin that contradicts the best alignment is honoured with open ends, in both band kinds."""
    n = 200
    body = marker_like(rng, n)
    pre = 60
    hands = np.concatenate([np.repeat(body[:1], pre, axis=0), body, marker_like(rng, 60)])
    hands = hands + rng.normal(scale=0.05, size=hands.shape)
    m = hands.shape[0]
    C = sq_costs(body, hands)
    u = uncovered_cost_for(C)
    pins = [Constraint(30, 30, 2), Constraint(180, 300, 0)]   # far off the true path (j = i + 60)
    for band in (full_band(n, m, pins), make_band(n, m, 60.0, pins)):
        res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=u)
        for c in pins:
            js = res.path[res.path[:, 0] == c.x, 1]
            assert js.size and np.abs(js - c.y).max() <= c.tolerance
        assert res.covered[0] <= 30 and res.covered[1] >= 180
    free = dtw(C, full_band(n, m), open_begin=True, open_end=True, uncovered_cost=u)
    assert np.abs(free.path[:, 1] - free.path[:, 0] - pre).max() <= 1


# ------------------------------------------------------------------ through pass 1, markers from the sample take

SAMPLE = Path(__file__).resolve().parents[1] / "motions"


@pytest.fixture(scope="module")
def sample_markers():
    from splicer.align.passes import resample_markers
    from splicer.io.bvh import read_bvh
    from splicer.rig.markers import arm_markers
    from splicer.rig.roles import find_roles
    bm, hm = read_bvh(SAMPLE / "sample_body.bvh"), read_bvh(SAMPLE / "sample_hands.bvh")
    br, hr = find_roles(bm.skeleton, source="body"), find_roles(hm.skeleton, source="hands")
    body = arm_markers(bm, br.sides["right"], br.up)
    other = resample_markers(arm_markers(hm, hr.sides["left"], hr.up), bm.fps)   # unrelated motion
    return body, other


def _cut(mk, a, b):
    return Markers(mk.points[a:b], mk.shoulder[a:b], mk.heading[a:b], mk.up, mk.fps, mk.side)


def _cat(parts):
    return Markers(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("points", "shoulder", "heading")),
                   parts[0].up, parts[0].fps, parts[0].side)


def _still(mk, k, count, rng):
    pts = np.repeat(mk.points[k:k + 1], count, axis=0) + rng.normal(scale=0.05, size=(count, 4, 3))
    return Markers(pts, np.repeat(mk.shoulder[k:k + 1], count, axis=0), np.repeat(mk.heading[k:k + 1], count),
                   mk.up, mk.fps, mk.side)


def _warp(rng, n_out, n_in):
    return smooth_warp(rng, n_out, n_in)


@pytest.mark.parametrize("seed", [0, 1])
def test_pass1_locates_the_body_inside_a_longer_take(sample_markers, seed):
    """hands = [3 s still] + warped body + [3 s of the other arm]: the start is found within one
    frame, the time map within a couple of frames everywhere, with or without an offset guess."""
    from splicer.align.passes import pass1, path_median, warp_markers
    full, other = sample_markers
    body = _cut(full, 140, 556)                   # a span that starts and ends in motion
    n, fps = body.n_frames, body.fps
    rng = np.random.default_rng(seed)
    m_mid = int(n * rng.uniform(0.8, 1.25))
    warp = _warp(rng, m_mid, n)
    pre = post = int(3 * fps)
    o0 = int(rng.integers(0, other.n_frames - post))
    hands = _cat([_still(body, 0, pre, rng), warp_markers(body, warp), _cut(other, o0, o0 + post)])
    truth = pre + np.interp(np.arange(n), warp, np.arange(m_mid))
    for kw in ({}, {"offset_s": pre / fps + 0.5}):
        res = pass1(body, hands, width=30.0, ends="open", **kw)
        assert res.covered == (0, n - 1)
        assert abs(res.path[0, 1] - pre) <= 1
        assert abs(res.path[-1, 1] - (pre + m_mid - 1)) <= 3     # D1's edge effect at the body's last frames
        err = np.abs(path_median(res.path, n) - truth)
        assert err.mean() < 1.0 and np.quantile(err, 0.95) < 4.0
        assert res.uncovered_cost > 0
    from splicer.align.confidence import pass_confidence
    loc = res.located                             # the coarse locating pass, at its own rate
    assert loc.fps < fps and loc.ends == "open" and res.fps == fps
    assert pass_confidence(loc, loc.fps).confidence.shape == (loc.band.n,)
    fixed = pass1(body, hands, width=30.0)        # the paper's fixed ends: forced through the extra material
    assert np.abs(path_median(fixed.path, n) - truth).mean() > 10 * err.mean()


def test_locate_rates_levels():
    """Worked answers: one level where the whole matrix at 10 fps fits; else the whole matrix at
    the rate that fits the first level's cells, then rates about 3x apart up to 10 fps."""
    from splicer.align.openend import locate_rates
    assert locate_rates(600, 1200, 30.0, 10.0) == [10.0]
    assert locate_rates(600, 1200, 5.0, 10.0) == [5.0]                    # the take's own rate is lower
    first = 30 * np.sqrt(1000 / 720_000)                                  # 1.118 fps: 22 x 45 frames
    assert locate_rates(600, 1200, 30.0, 10.0, max_cells=1000) == pytest.approx([first, np.sqrt(10 * first), 10.0])
    # 24,000 x 24,000 frames at 30 fps: 8,000 x 8,000 at 10 fps; 100 x 100 (10,000 cells) at 0.125 fps,
    # 80x below 10 fps: four steps of 80 ** (1 / 4) = 2.99x
    r = locate_rates(24_000, 24_000, 30.0, 10.0, max_cells=1_000_000, full_cells=10_000)
    assert r[0] == pytest.approx(0.125) and r[-1] == 10.0 and len(r) == 5
    assert np.allclose(np.diff(np.log(r)), np.log(80.0) / 4)
    assert locate_rates(24_000, 24_000, 30.0, 10.0, max_cells=1_000_000, full_cells=10_000, step=1.0) == \
        pytest.approx([30 * np.sqrt(1_000_000) / 24_000])                 # no steps: the one level


def test_pass1_locating_levels_find_the_same_overlap(sample_markers, monkeypatch):
    """A take too long for the whole matrix at 10 fps (here: max_coarse_cells made small) is located
    at a lower rate first, then at 10 fps in a band around that path: the same start, end and path
    as one level at 10 fps, and pins still hold."""
    import splicer.align.passes as P
    full, other = sample_markers
    body = _cut(full, 140, 556)
    n, fps = body.n_frames, body.fps
    rng = np.random.default_rng(0)
    m_mid = int(n * 1.1)
    warp = _warp(rng, m_mid, n)
    pre = post = int(3 * fps)
    hands = _cat([_still(body, 0, pre, rng), P.warp_markers(body, warp), _cut(other, 0, post)])
    truth = pre + np.interp(np.arange(n), warp, np.arange(m_mid))
    one = P.pass1(body, hands, width=30.0, ends="open")
    monkeypatch.setattr(P, "LOCATE_BAND_S", 3.0)                         # a band narrower than the take
    small = 6_000                                                          # 10 fps: 139 x 212 = 29,468 cells
    seen = []
    lv = P.pass1(body, hands, width=30.0, ends="open", max_coarse_cells=small, progress=seen.append)
    loc = lv.located
    assert loc.fps == pytest.approx(10.0)                                  # the last level: the usual rate
    assert int(np.sum(loc.band.hi - loc.band.lo + 1)) < loc.band.n * loc.band.m / 2      # a band, not all
    assert lv.covered == one.covered == (0, n - 1)
    assert abs(lv.path[0, 1] - pre) <= 1
    np.testing.assert_array_equal(lv.path, one.path)
    err = np.abs(P.path_median(lv.path, n) - truth)
    assert err.mean() < 1.0
    assert seen == [0.25, 0.5, 1.0]                                        # two levels share the first half
    pins = [Constraint(50, pre + int(warp[50]) + 1, 2), Constraint(300, pre + int(warp[300]), 0)]
    pinned = P.pass1(body, hands, width=30.0, ends="open", max_coarse_cells=small, constraints=pins)
    for c in pins:
        js = pinned.path[pinned.path[:, 0] == c.x, 1]
        assert js.size and np.abs(js - c.y).max() <= c.tolerance


def test_pass1_locating_levels_fall_back_to_one_level_when_a_band_misses_a_pin(sample_markers, monkeypatch):
    """A finer locating level whose band cannot be built around the coarser path (it misses a
    pin's window) gives way to one level over the whole matrix at the rate that fits, as before
    the levels: the same path as that."""
    import splicer.align.passes as P
    from splicer.align.openend import coarse_rate
    from splicer.errors import BandError
    full, other = sample_markers
    body = _cut(full, 140, 556)
    rng = np.random.default_rng(1)
    hands = _cat([_still(body, 0, 60, rng), body, _cut(other, 0, 60)])
    small = 6_000
    with monkeypatch.context() as mp:                                      # as before: one level
        mp.setattr(P, "locate_rates", lambda n, m, fps, cf, mc: [coarse_rate(n, m, fps, cf, mc)])
        before = P.pass1(body, hands, width=30.0, ends="open", max_coarse_cells=small)
    assert before.located.fps < 10.0
    real, calls = P.guided_band, []

    def missing(path, factor, n, m, width, constraints=(), **kw):
        if kw.get("open_begin") and n < body.n_frames:                    # a locating level's band
            calls.append(n)
            raise BandError("the coarse path misses a constraint window")
        return real(path, factor, n, m, width, constraints, **kw)

    monkeypatch.setattr(P, "guided_band", missing)
    lv = P.pass1(body, hands, width=30.0, ends="open", max_coarse_cells=small)
    assert calls and lv.located.fps == pytest.approx(before.located.fps)
    np.testing.assert_array_equal(lv.located.path, before.located.path)
    np.testing.assert_array_equal(lv.path, before.path)


def test_pass1_hands_cover_the_middle_half(sample_markers):
    from splicer.align.passes import pass1, warp_markers
    full, _ = sample_markers
    body = _cut(full, 140, 556)
    n = body.n_frames
    a, b = n // 4, 3 * n // 4
    hands = warp_markers(body, a + np.linspace(0, b - a - 1, int((b - a) * 1.1)))
    seen = []
    res = pass1(body, hands, width=30.0, ends="open", progress=seen.append)
    assert 0 < res.covered[0] and res.covered[1] < n - 1      # uncovered at both ends
    assert abs(res.covered[0] - a) <= 5 and abs(res.covered[1] - (b - 1)) <= 5
    # the bar: the locating pass fills its first half, the full-rate pass the second
    assert seen == [0.5, 1.0]  # one chunk of rows each here
    np.testing.assert_array_equal(pass1(body, hands, width=30.0, ends="open").path, res.path)  # same path without it


def test_pass1_open_ends_hold_pins(sample_markers):
    """A pin far from the best alignment still holds, and the path covers it."""
    from splicer.align.passes import pass1
    full, other = sample_markers
    body = _cut(full, 140, 556)
    n = body.n_frames
    rng = np.random.default_rng(3)
    hands = _cat([_still(body, 0, 60, rng), body, _cut(other, 0, 60)])
    pins = [Constraint(50, 300, 2), Constraint(300, 420, 0)]
    res = pass1(body, hands, width=30.0, ends="open", constraints=pins)
    for c in pins:
        js = res.path[res.path[:, 0] == c.x, 1]
        assert js.size and np.abs(js - c.y).max() <= c.tolerance
    with pytest.raises(ValueError, match="ends"):
        pass1(body, hands, width=30.0, ends="both")


def test_step_penalty_keeps_the_diagonal_through_a_flat_region():
    """Equal costs everywhere: without a penalty the tie rule decides; with one the diagonal wins."""
    C = np.ones((6, 6))
    band = make_band(6, 6, 1e6)
    res = dtw(C, band, step_penalty=0.5)
    np.testing.assert_array_equal(res.path, np.stack([np.arange(6)] * 2, axis=1))
    C[2, 2] = C[3, 3] = 4.0      # a bump on the diagonal (12 in total); a detour: 7 cells + 2 bends
    res = dtw(C, band, step_penalty=0.5)
    assert res.cost == 7 + 2 * 0.5
    assert not {(2, 2), (3, 3)} & set(map(tuple, res.path))
    hi = dtw(C, band, step_penalty=10.0)
    np.testing.assert_array_equal(hi.path, np.stack([np.arange(6)] * 2, axis=1))
    assert hi.cost == 12.0 and hi.step_penalty == 10.0
