"""Confidence from the cost landscape (splicer.align.confidence): forward + backward forced-path costs
against a plain-Python full-matrix reference, against pinned DTW runs, and hand-checked spreads."""

from __future__ import annotations

import numpy as np
import pytest

from splicer.align.band import full_band, make_band
from splicer.align.confidence import Confidence, pass_confidence, row_confidence, through_costs
from splicer.align.dtw import dtw

from test_dtw import as_callable, random_constraints
from test_openend import band_mask, marker_like, sample, smooth_warp, sqdist


@pytest.fixture
def rng():
    return np.random.default_rng(4242)


def ref_through(C, mask, ob, oe, u, cons=(), pen=0.0, hw=1.0):
    """fwd + bwd on the full matrix, each filled by explicit loops.

    fwd[i, j]: cheapest prefix ending at (i, j), own cost included (hw * C when entered by a
    (i, j-1) step); starts at (0, 0) (fixed) or (open) on row 0 or column 0 in rows <= first
    pin at u * i, no step (i-1, 0) -> (i, 0) out of a cell whose best is a start.
    bwd[i, j]: cheapest suffix from (i, j), own cost excluded; ends at (n-1, m-1) (fixed) or
    (open) on row n-1 or column m-1 in rows >= last pin at u * (n-1-i), no step
    (i, m-1) -> (i+1, m-1) into a cell whose best is an end."""
    n, m = C.shape
    last_start = cons[0].x if cons else n - 1
    first_end = cons[-1].x if cons else 0
    f = np.full((n, m), np.inf)
    fst = np.zeros((n, m), bool)
    for i in range(n):
        for j in range(m):
            if not mask[i, j]:
                continue
            best = np.inf
            if i > 0 and j > 0:
                best = min(best, f[i - 1, j - 1])
            if i > 0 and not (ob and j == 0 and fst[i - 1, j]):
                best = min(best, f[i - 1, j] + pen)
            if j > 0:
                best = min(best, f[i, j - 1] + pen + (hw - 1) * C[i, j])
            s = ((u * i if i <= last_start and (i == 0 or j == 0) else np.inf) if ob
                 else (0.0 if (i, j) == (0, 0) else np.inf))
            if s < best:
                best, fst[i, j] = s, True
            f[i, j] = C[i, j] + best
    b = np.full((n, m), np.inf)
    bst = np.zeros((n, m), bool)
    for i in range(n - 1, -1, -1):
        for j in range(m - 1, -1, -1):
            if not mask[i, j]:
                continue
            best = np.inf
            if i < n - 1 and j < m - 1 and mask[i + 1, j + 1]:
                best = min(best, b[i + 1, j + 1] + C[i + 1, j + 1])
            if i < n - 1 and mask[i + 1, j] and not (oe and j == m - 1 and bst[i + 1, j]):
                best = min(best, b[i + 1, j] + pen + C[i + 1, j])
            if j < m - 1 and mask[i, j + 1]:
                best = min(best, b[i, j + 1] + pen + hw * C[i, j + 1])
            e = ((u * (n - 1 - i) if i >= first_end and (i == n - 1 or j == m - 1) else np.inf) if oe
                 else (0.0 if (i, j) == (n - 1, m - 1) else np.inf))
            if e < best:
                best, bst[i, j] = e, True
            b[i, j] = best
    return np.where(mask, f + b, np.inf)


@pytest.mark.parametrize("ends", [(False, False), (True, False), (False, True), (True, True)])
@pytest.mark.parametrize("n,m", [(1, 6), (6, 1), (7, 9), (15, 11), (20, 26)])
def test_through_costs_match_reference(rng, ends, n, m):
    ob, oe = ends
    for trial in range(4):
        C = rng.random((n, m)) * 3
        u = float(rng.choice([0.0, 0.5, 2.0]))
        pen = float(rng.choice([0.0, 0.3]))
        hw = float(rng.choice([1.0, 0.5]))
        cons = random_constraints(rng, n, m, int(rng.integers(0, 3)), int(rng.integers(0, 2)))
        try:
            band = full_band(n, m, cons, open_begin=ob, open_end=oe) if trial % 2 else make_band(n, m, 6.0, cons)
        except Exception:
            continue
        ref = ref_through(C, band_mask(band), ob, oe, u, band.constraints, pen, hw)
        for cost in (C, as_callable(C, band)):
            through, _ = through_costs(cost, band, open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen,
                                       horizontal_weight=hw)
            for i in range(n):
                cols, vals = through(i)
                np.testing.assert_allclose(vals, ref[i, cols], rtol=1e-5, atol=1e-4)


def test_fixed_through_cost_is_best_prefix_plus_best_suffix(rng):
    """Fixed ends: the best path through (i, j) = best path (0, 0)..(i, j) + best (i, j)..(n-1, m-1)."""
    n, m = 14, 17
    C = rng.random((n, m))
    band = make_band(n, m, 1e6)
    through, _ = through_costs(C, band)
    for i in range(n):
        cols, vals = through(i)
        for j, v in zip(cols, vals):
            head = dtw(C[:i + 1, :j + 1], make_band(i + 1, j + 1, 1e6)).cost
            tail = dtw(C[i:, j:], make_band(n - i, m - j, 1e6)).cost
            assert v == pytest.approx(head + tail - C[i, j], rel=1e-5)


@pytest.mark.parametrize("ends", [(False, False), (True, True)])
def test_row_minimum_is_the_optimum_on_covered_rows(rng, ends):
    n, m = 40, 55
    C = rng.random((n, m))
    band = full_band(n, m, open_begin=ends[0], open_end=ends[1]) if ends[0] else make_band(n, m, 30.0)
    res = dtw(C, band, open_begin=ends[0], open_end=ends[1], uncovered_cost=0.3, step_penalty=0.1,
              horizontal_weight=0.5)
    through, _ = through_costs(C, band, open_begin=ends[0], open_end=ends[1], uncovered_cost=0.3, step_penalty=0.1,
                               horizontal_weight=0.5)
    for i in range(res.covered[0], res.covered[1] + 1):
        _, vals = through(i)
        assert vals.min() == pytest.approx(res.cost, rel=1e-5)


def test_hand_checked_spread():
    # optimum (0,0) (1,1) (2,2) costs 3; forcing row 1 to column 2 costs 4 (excess 1), column 0
    # costs 9; rows 0 and 2 have no alternative within the threshold.
    C = np.array([[1., 6., 6.],
                  [6., 1., 1.],
                  [6., 6., 1.]])
    band = make_band(3, 3, 1e6)
    path = dtw(C, band).path
    conf = row_confidence(C, band, path, fps=10.0, threshold=1.0)   # tau = 1 x median path cost = 1
    assert isinstance(conf, Confidence) and conf.threshold == 1.0
    np.testing.assert_array_equal(conf.spread_frames, [0, 1, 0])
    np.testing.assert_allclose(conf.est_error_s, [0, 0.1, 0])
    np.testing.assert_allclose(conf.confidence, [1, 0.5, 1])
    tight = row_confidence(C, band, path, fps=10.0, threshold=0.5)
    np.testing.assert_array_equal(tight.spread_frames, [0, 0, 0])
    assert conf.low().tolist() == [False, False, False] and conf.low(0.05).tolist() == [False, True, False]


def test_uncovered_rows_have_zero_confidence():
    C = np.array([[5., 5.],
                  [0., 5.],
                  [5., 0.],
                  [5., 5.]]) + 0.5
    band = full_band(4, 2)
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=2.0)
    assert res.covered == (1, 2)
    conf = row_confidence(C, band, res.path, fps=30.0, uncovered_cost=2.0)
    assert np.isnan(conf.est_error_s[[0, 3]]).all() and np.isnan(conf.spread_frames[[0, 3]]).all()
    np.testing.assert_array_equal(conf.confidence[[0, 3]], [0, 0])
    assert (conf.confidence[1:3] == 1).all()


def test_a_hold_is_less_certain_than_motion(rng):
    """Body rows inside a 1 s hold (no signal) get a large spread; moving rows a small one."""
    fps = 30.0
    n = 240
    body = marker_like(rng, n)
    body[100:130] = body[100]                       # the arm holds still for 1 s
    m = 260
    warp = smooth_warp(rng, m, n)
    hands = sample(body, warp) + rng.normal(scale=0.05, size=(m, body.shape[1]))
    C = sqdist(body, hands)
    band = make_band(n, m, 60.0)
    res = dtw(C, band)
    conf = row_confidence(C, band, res.path, fps, threshold=5.0)
    hold = conf.est_error_s[105:125]
    moving = np.r_[conf.est_error_s[20:90], conf.est_error_s[140:220]]
    assert np.median(hold) > 0.3 and np.median(moving) <= 1 / fps
    assert conf.confidence[105:125].max() < 0.5 < conf.confidence[20:90].min()


def test_pass_confidence_uses_the_pass(rng):
    from splicer.align.passes import PassResult
    C = rng.random((12, 15))
    band = make_band(12, 15, 8.0)
    res = dtw(C, band)
    pr = PassResult(res.path, res.cost, band, "pass1", as_callable_band(C), res.covered, 0.0)
    a = pass_confidence(pr, 30.0)
    b = row_confidence(C, band, res.path, 30.0)
    np.testing.assert_array_equal(a.est_error_s, b.est_error_s)
    with pytest.raises(ValueError, match="fps"):
        row_confidence(C, band, res.path, 0.0)


def as_callable_band(C):
    def cost(band, i0, i1):
        return as_callable(C, band)(i0, i1)
    return cost


def test_pass2_over_a_covered_span_and_its_confidence(rng):
    """Pass 2 after open ends: aligned on the covered span only, reported on every body row."""
    from splicer.align.passes import hold_ends, pass2, warp_markers
    from splicer.rig.markers import Markers
    n = 150
    pts = np.cumsum(rng.normal(size=(n, 4, 3)), axis=0)
    body = Markers(pts, np.zeros((n, 3)), np.zeros(n), 1, 30.0, "right")
    per_frame = np.full(n, np.nan)
    per_frame[20:130] = np.arange(20, 130) + 0.3          # pass 1 covered body frames 20..129
    hw = warp_markers(body, hold_ends(per_frame))
    assert hold_ends(per_frame)[0] == 20.3 and hold_ends(per_frame)[-1] == 129.3
    res = pass2(body, hw, width=10.0, covered=(20, 129))
    assert res.covered == (20, 129) and res.band.n == n and res.ends == "fixed"
    assert tuple(res.path[0]) == (20, 20) and tuple(res.path[-1]) == (129, 129)
    for i, j in res.path:
        assert res.band.contains(i, j)
    conf = pass_confidence(res, 30.0)
    assert conf.confidence.shape == (n,)
    assert (conf.confidence[:20] == 0).all() and (conf.confidence[130:] == 0).all()
    assert np.isnan(conf.est_error_s[:20]).all() and np.isfinite(conf.est_error_s[20:130]).all()
    full = pass2(body, hw, width=10.0)
    assert full.covered == (0, n - 1)
    with pytest.raises(ValueError, match="no covered frame"):
        hold_ends(np.full(3, np.nan))


def test_a_repeated_gesture_makes_the_overlap_ambiguous(rng):
    """Body = A, B, A; hands = A only: one A is covered, the other is an equally good place."""
    A = marker_like(rng, 60)
    B = marker_like(np.random.default_rng(1), 60)
    body = np.concatenate([A, B, A])
    hands = A + rng.normal(scale=0.05, size=A.shape)
    C = sqdist(body, hands)
    band = full_band(180, 60)
    u = float(np.quantile(C, 0.01))
    res = dtw(C, band, open_begin=True, open_end=True, uncovered_cost=u)
    assert res.covered in ((0, 59), (120, 179))
    conf = row_confidence(C, band, res.path, 30.0, uncovered_cost=u)
    other = slice(120, 180) if res.covered == (0, 59) else slice(0, 60)
    assert conf.ambiguous()[other].mean() > 0.9            # the other repetition
    assert not conf.ambiguous()[70:110].any()              # B is no place for A
    assert (conf.row_excess[res.covered[0]:res.covered[1] + 1] < 1e-3 * res.cost + 1e-6).all()


def full_array_row_stats(C, band, path, fps, ob, oe, u, pen, hw, threshold=1.0):
    """The statistics from whole forward and backward arrays (:func:`through_costs`, one sweep each):
    the reference for the blocked sweep of :func:`row_confidence`."""
    from splicer.align.confidence_kernels import _row_stats
    from splicer.align.paths import path_median
    _, (c, fwd, fmin, bwd, bmin, off) = through_costs(C, band, open_begin=ob, open_end=oe, uncovered_cost=u,
                                                      step_penalty=pen, horizontal_weight=hw)
    n = band.n
    idx = off[path[:, 0]] + path[:, 1] - band.lo[path[:, 0]]
    local = c[idx].astype(np.float64)
    d = np.diff(path, axis=0)
    weight = np.ones(len(local))
    weight[1:][d[:, 0] == 0] = hw
    optimum = (float(np.sum(weight * local)) + u * (int(path[0, 0]) + n - 1 - int(path[-1, 0]))
               + pen * int(np.count_nonzero((d[:, 0] == 0) | (d[:, 1] == 0))))
    tau = threshold * max(float(np.median(local)), 1e-12)
    spread, err, exmin = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.inf)
    _row_stats(fwd, fmin, bwd, bmin, band.lo.astype(np.int64), band.hi.astype(np.int64), off, optimum, tau,
               path_median(path, n), spread, err, exmin)
    return spread, err / fps, exmin


@pytest.mark.parametrize("keep_bytes", [0, 600, 1 << 30])
@pytest.mark.parametrize("block_cells", [1, 7, 40, 1 << 20])
@pytest.mark.parametrize("ends", [(False, False), (True, False), (False, True), (True, True)])
def test_blocked_sweep_equals_whole_arrays(rng, monkeypatch, block_cells, ends, keep_bytes):
    """Blocks of one row, of a few rows (not dividing n) and one block, with no, some and all local
    costs kept between the sweeps: the same numbers, bit for bit, as the statistics taken from whole
    forward and backward arrays."""
    import splicer.align.confidence as conf_mod
    monkeypatch.setattr(conf_mod, "BLOCK_CELLS", block_cells)
    monkeypatch.setattr(conf_mod, "KEEP_COST_BYTES", keep_bytes)
    ob, oe = ends
    n, m = 23, 31
    for trial in range(3):
        C = rng.random((n, m)) * 2
        u, pen, hw = [(0.0, 0.0, 1.0), (0.4, 0.1, 0.5), (2.0, 0.3, 1.0)][trial]
        band = full_band(n, m, open_begin=ob, open_end=oe) if (ob or oe) else make_band(n, m, 9.0)
        res = dtw(C, band, open_begin=ob, open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw)
        conf = row_confidence(C if trial != 1 else as_callable(C, band), band, res.path, 30.0, open_begin=ob,
                              open_end=oe, uncovered_cost=u, step_penalty=pen, horizontal_weight=hw)
        spread, est, exmin = full_array_row_stats(C, band, res.path, 30.0, ob, oe, u, pen, hw)
        np.testing.assert_array_equal(conf.spread_frames, spread)
        np.testing.assert_array_equal(conf.est_error_s, est)
        np.testing.assert_array_equal(conf.row_excess, np.maximum(exmin, 0.0))


def test_the_blocked_sweep_keeps_one_block_of_forward_costs(monkeypatch):
    """Worked numbers: 10 rows at most 5 cells wide (44 cells) in blocks of BLOCK_CELLS = 15 cells ->
    3 rows a block, blocks starting at rows 0, 3, 6, 9; the block buffers hold 3 x 5 = 15 cells."""
    import splicer.align.confidence as conf_mod
    import splicer.align.confidence_kernels as kern
    monkeypatch.setattr(conf_mod, "BLOCK_CELLS", 15)
    seen = []
    real = kern._forward_rows

    def spy(c, lo, hi, off, sc, ob, pen, hx, i0, i1, prev, pst, out, base, rowmin):
        seen.append((i0, i1, out.size))
        return real(c, lo, hi, off, sc, ob, pen, hx, i0, i1, prev, pst, out, base, rowmin)

    monkeypatch.setattr(conf_mod, "_forward_rows", spy)
    band = make_band(10, 10, 3.0)
    assert band.max_row_width == 5 and band.n_cells == 44
    C = np.random.default_rng(0).random((10, 10))
    row_confidence(C, band, dtw(C, band).path, 30.0)
    # sweep 1 forward over the 4 blocks, sweep 2 again from the last block to the first
    assert [s[:2] for s in seen] == [(0, 3), (3, 6), (6, 9), (9, 10), (9, 10), (6, 9), (3, 6), (0, 3)]
    assert {s[2] for s in seen} == {15}


@pytest.mark.parametrize("keep,calls", [("all", 4), ("none", 8), ("two", 6)])
def test_local_costs_beyond_the_budget_are_computed_twice(monkeypatch, keep, calls):
    """Worked numbers: 10 rows at most 5 cells wide, blocks of 3 rows (BLOCK_CELLS = 15): blocks at rows
    0, 3, 6, 9.  All kept: one cost call per block; none kept: a second call for each block in the
    backward sweep; a budget of exactly blocks 0 and 1 (4 bytes per cell): 2 and 3 asked again."""
    import splicer.align.confidence as conf_mod
    band = make_band(10, 10, 3.0)
    widths = band.hi - band.lo + 1
    assert widths.max() == 5 and widths[:3].sum() + widths[3:6].sum() == 27  # 3 4 5 | 5 5 5 | 5 5 4 | 3
    monkeypatch.setattr(conf_mod, "BLOCK_CELLS", 15)
    monkeypatch.setattr(conf_mod, "KEEP_COST_BYTES", {"all": 1 << 30, "none": 0, "two": 27 * 4}[keep])
    C = np.random.default_rng(0).random((10, 10))
    asked = []
    f = as_callable(C, band)

    def cost(i0, i1):
        asked.append((i0, i1))
        return f(i0, i1)

    path = dtw(C, band).path
    conf = row_confidence(cost, band, path, 30.0)
    assert len(asked) == calls
    assert asked[:4] == [(0, 3), (3, 6), (6, 9), (9, 10)]
    np.testing.assert_array_equal(conf.est_error_s, row_confidence(C, band, path, 30.0).est_error_s)


def test_with_floor_raises_covered_estimates_and_keeps_uncovered_frames():
    est = np.array([np.nan, 0.02, 0.5, np.nan])
    c = Confidence(spread_frames=np.array([np.nan, 1.0, 2.0, np.nan]), est_error_s=est,
                   confidence=np.zeros(4), threshold=1.0, error_scale_s=0.1)
    f = c.with_floor(0.3)
    np.testing.assert_array_equal(f.est_error_s, [np.nan, 0.3, 0.5, np.nan])
    # confidence is recomputed from the new estimates: lower where the error grew, 0 where uncovered
    assert f.confidence[0] == 0.0 and f.confidence[3] == 0.0
    assert 0.0 < f.confidence[2] <= f.confidence[1] < 0.5
    np.testing.assert_array_equal(f.low(), [False, True, True, False])
    assert c.with_floor(0.0).est_error_s[1] == 0.02  # a zero floor changes nothing
    with pytest.raises(ValueError):
        c.with_floor(-1.0)
    with pytest.raises(ValueError):
        c.with_floor(float("inf"))
