"""Tests of the banded DTW engine (splicer.align.dtw) and its band geometry (splicer.align.band).

The kernels are compared with a slow plain-Python reference that builds the full n x m
admissibility mask directly from ALGORITHM.md sections 2-3 (0-based form, see the
splicer.align.band module docstring) and fills the full gamma matrix.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from splicer.align import dtw as dtw_module
from splicer.align.dtw import Band, Constraint, DTWResult, band_frames, dtw, dtw_features, make_band
from splicer.errors import BandError, ConstraintError, SplicerError


@pytest.fixture
def rng():
    return np.random.default_rng(20060901)


# ------------------------------------------------------------------ slow reference

def ref_mask(n, m, W, cons):
    """Admissible cells, straight from the formulas (plus the documented one-cell clip)."""
    mask = np.zeros((n, m), dtype=bool)
    if n == 1:
        mask[0, :] = True
        return mask
    pts = [(0, 0, 0)] + [(c.x, c.y, c.tolerance) for c in cons] + [(n - 1, m - 1, 0)]
    for i in range(n):
        k = 1
        while not (i <= pts[k][0]):
            k += 1
        (x0, y0, t0), (x1, y1, t1) = pts[k - 1], pts[k]
        s = (y1 - y0) / (x1 - x0)
        delta = W * math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2) / (2 * (x1 - x0))
        for j in range(m):
            ok = abs(j - (y0 + s * (i - x0))) <= delta + 1e-9
            ok = ok and max(0, y0 - t0) <= j <= min(m - 1, y1 + t1)
            if i == x1 and k < len(pts) - 1:        # constraint row: within tolerance
                ok = ok and j >= y1 - t1
            mask[i, j] = ok
    return mask


def ref_dtw(C, mask):
    """Full-matrix DTW; ties: diagonal, then (i-1, j), then (i, j-1). Returns (cost, path)."""
    n, m = C.shape
    g = np.full((n, m), np.inf)
    step = np.zeros((n, m), dtype=int)
    for i in range(n):
        for j in range(m):
            if not mask[i, j]:
                continue
            if i == 0 and j == 0:
                g[0, 0] = C[0, 0]
                continue
            cands = [(g[i - 1, j - 1] if i > 0 and j > 0 else np.inf, 0),
                     (g[i - 1, j] if i > 0 else np.inf, 1),
                     (g[i, j - 1] if j > 0 else np.inf, 2)]
            best, s = cands[0]
            for v, code in cands[1:]:
                if v < best:
                    best, s = v, code
            g[i, j] = C[i, j] + best
            step[i, j] = s
    i, j = n - 1, m - 1
    path = [(i, j)]
    if np.isfinite(g[i, j]):
        while (i, j) != (0, 0):
            s = step[i, j]
            i, j = (i - 1, j - 1) if s == 0 else (i - 1, j) if s == 1 else (i, j - 1)
            path.append((i, j))
    return g[n - 1, m - 1], np.array(path[::-1], dtype=np.int64)


def cells_on_some_path(mask):
    """Cells of ``mask`` on some monotone path (0, 0) -> (n-1, m-1) inside it: reachable
    forwards from the start and backwards from the end."""
    n, m = mask.shape
    fwd = np.zeros_like(mask, dtype=bool)
    bwd = np.zeros_like(mask, dtype=bool)
    for i in range(n):
        for j in range(m):
            prev = (i == 0 and j == 0) or (i > 0 and fwd[i - 1, j]) or (j > 0 and fwd[i, j - 1]) \
                or (i > 0 and j > 0 and fwd[i - 1, j - 1])
            fwd[i, j] = mask[i, j] and prev
    for i in range(n - 1, -1, -1):
        for j in range(m - 1, -1, -1):
            nxt = (i == n - 1 and j == m - 1) or (i < n - 1 and bwd[i + 1, j]) or (j < m - 1 and bwd[i, j + 1]) \
                or (i < n - 1 and j < m - 1 and bwd[i + 1, j + 1])
            bwd[i, j] = mask[i, j] and nxt
    return fwd & bwd


def sqdist(X, Y):
    return ((X[:, None, :] - Y[None, :, :]) ** 2).sum(-1)


def as_callable(C, band, calls=None):
    w = band.max_row_width

    def cost(i0, i1):
        if calls is not None:
            calls.append((i0, i1))
        out = np.full((i1 - i0, w), np.nan)      # padding must be ignored
        for r, i in enumerate(range(i0, i1)):
            out[r, :band.hi[i] - band.lo[i] + 1] = C[i, band.lo[i]:band.hi[i] + 1]
        return out
    return cost


def random_constraints(rng, n, m, count, tol):
    if n < 3 or m < 3:
        return ()
    count = min(count, n - 2, m - 2)
    xs = np.sort(rng.choice(np.arange(1, n - 1), count, replace=False))
    ys = np.sort(rng.choice(np.arange(1, m - 1), count, replace=False))
    return tuple(Constraint(int(x), int(y), int(tol)) for x, y in zip(xs, ys))


def check_path(path, n, m):
    assert path.dtype == np.int64 and path.ndim == 2 and path.shape[1] == 2
    assert tuple(path[0]) == (0, 0) and tuple(path[-1]) == (n - 1, m - 1)
    steps = {tuple(s) for s in np.diff(path, axis=0)}
    assert steps <= {(1, 0), (0, 1), (1, 1)}


SHAPES = [(1, 1), (1, 6), (6, 1), (2, 2), (2, 9), (5, 5), (7, 12), (12, 7), (16, 40), (40, 16),
          (25, 25), (31, 29)]


@pytest.mark.parametrize("n,m", SHAPES)
def test_matches_reference(rng, n, m):
    """Band, full matrix, callable and fused kernel agree with the slow reference."""
    compared = 0
    for trial in range(8):
        W = float(rng.choice([0.7, 1.0, 2.5, 4.0, 0.3 * n, 0.3 * n + 3.3, 10.0, 2.0 * (n + m)]))
        cons = random_constraints(rng, n, m, int(rng.integers(0, 4)), int(rng.choice([0, 0, 1, 3])))
        mask = ref_mask(n, m, W, cons)
        X, Y = rng.normal(size=(n, 3)), rng.normal(size=(m, 3))
        C = sqdist(X, Y)
        try:
            band = make_band(n, m, W, cons)
        except (BandError, ConstraintError):
            # the reference agrees that no path exists in the literal band
            assert not np.isfinite(ref_dtw(np.zeros((n, m)), mask)[0])
            continue
        # the band holds exactly the reference cells that lie on some path
        on_path = cells_on_some_path(mask)
        for i in range(n):
            np.testing.assert_array_equal(np.arange(band.lo[i], band.hi[i] + 1), np.flatnonzero(on_path[i]))
        ref_cost, ref_path = ref_dtw(C, mask)
        for res in (dtw(C, band), dtw(as_callable(C, band), band), dtw_features(X, Y, band)):
            assert isinstance(res, DTWResult) and res.band is band
            np.testing.assert_allclose(res.cost, ref_cost, rtol=1e-12)
            np.testing.assert_array_equal(res.path, ref_path)
            check_path(res.path, n, m)
        compared += 1
    if n > 2 and m > 2:
        assert compared > 0


def test_forbidden_cells_and_chunking(rng, monkeypatch):
    """+inf costs are avoided; several callable chunks give the same answer."""
    monkeypatch.setattr(dtw_module, "CHUNK_CELLS", 64)
    n, m = 40, 35
    cons = (Constraint(12, 10, 2), Constraint(30, 24, 0))
    band = make_band(n, m, 9.0, cons)
    C = rng.random((n, m))
    C[rng.random((n, m)) < 0.15] = np.inf
    C[0, 0] = C[-1, -1] = 0.5
    ref_cost, ref_path = ref_dtw(C, ref_mask(n, m, 9.0, cons))
    if not np.isfinite(ref_cost):  # pragma: no cover - the seed gives a finite path
        pytest.skip("no finite path for this seed")
    calls = []
    res = dtw(as_callable(C, band, calls), band)
    assert len(calls) > 3 and calls[0][0] == 0 and calls[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(calls, calls[1:]))
    np.testing.assert_allclose(res.cost, ref_cost, rtol=1e-12)
    np.testing.assert_array_equal(res.path, ref_path)
    np.testing.assert_array_equal(dtw(C, band).path, ref_path)


@pytest.mark.parametrize("n,m", [(1, 9), (9, 1), (20, 20), (17, 33), (33, 17)])
def test_wide_band_is_unconstrained_dtw(rng, n, m):
    X, Y = rng.normal(size=(n, 2)), rng.normal(size=(m, 2))
    band = make_band(n, m, 2.0 * math.hypot(n, m))
    assert band.n_cells == n * m
    ref_cost, ref_path = ref_dtw(sqdist(X, Y), np.ones((n, m), bool))
    res = dtw_features(X, Y, band)
    np.testing.assert_allclose(res.cost, ref_cost, rtol=1e-12)
    np.testing.assert_array_equal(res.path, ref_path)


@pytest.mark.parametrize("W", [3.0, 8.0, 1000.0])
@pytest.mark.parametrize("n,m", [(30, 30), (24, 41), (50, 13)])
def test_swap_transposes_path(rng, n, m, W):
    X, Y = rng.normal(size=(n, 4)), rng.normal(size=(m, 4))
    a = dtw_features(X, Y, make_band(n, m, W))
    b = dtw_features(Y, X, make_band(m, n, W))   # W is a perpendicular width: same strip
    np.testing.assert_allclose(a.cost, b.cost, rtol=1e-12)
    np.testing.assert_array_equal(a.path, b.path[:, ::-1])


@pytest.mark.parametrize("metric", ["sqeuclidean", "euclidean"])
def test_known_warp_is_recovered(rng, metric):
    """Y is X played with a known monotone time warp; the zero-cost path is that warp."""
    n = 200
    t = np.linspace(0, 6 * np.pi, n)
    X = np.stack([np.sin(t), np.cos(1.3 * t), t / 10], axis=1)   # distinct consecutive frames
    inc = (rng.random(300) < 0.67).astype(np.int64)               # 0: repeat a frame, 1: advance
    warp = np.concatenate([[0], np.cumsum(inc)])
    warp = warp[warp < n]
    warp = np.concatenate([warp, np.arange(warp[-1] + 1, n)])    # end on the last frame
    Y = X[warp]
    truth = np.stack([warp, np.arange(len(warp))], axis=1)
    band = make_band(n, len(warp), 0.3 * n)
    res = dtw_features(X, Y, band, metric=metric)
    assert res.cost == 0.0
    np.testing.assert_array_equal(res.path, truth)
    res_t = dtw_features(Y, X, make_band(len(warp), n, 0.3 * n), metric=metric)
    np.testing.assert_array_equal(res_t.path, truth[:, ::-1])


@pytest.mark.parametrize("tol", [0, 1, 4])
def test_constraint_contract(rng, tol):
    n, m = 120, 90
    cons = (Constraint(20, 40, tol), Constraint(50, 45, tol), Constraint(100, 60, tol))
    band = make_band(n, m, 25.0, cons)
    for c in cons:       # every path in the band satisfies the constraint
        assert c.y - tol <= band.lo[c.x] and band.hi[c.x] <= c.y + tol
    for _ in range(3):
        res = dtw_features(rng.normal(size=(n, 2)), rng.normal(size=(m, 2)), band)
        for c in cons:
            cols = res.path[res.path[:, 0] == c.x, 1]
            assert len(cols) and np.all(np.abs(cols - c.y) <= tol)
            if tol == 0:
                assert set(cols) == {c.y}


def test_hand_checked_matrix():
    """Worked by hand (own example, local cost |x_i - y_j|), x = [1, 3, 4], y = [1, 2, 4, 4].

    C = | 0 1 3 3 |      gamma = | 0 1 4 7 |      (row 0: running sum)
        | 2 1 1 1 |              | 2 1 2 3 |      (1,2): 1 + min(diag 1, up 4, left 1) = 2,
        | 3 2 0 0 |              | 5 3 1 1 |             tie -> diagonal
    gamma[2, 3] = 0 + min(diag 2, up 3, left 1) = 1; backtrack: left, diagonal, diagonal.
    """
    x, y = np.array([1.0, 3.0, 4.0]), np.array([1.0, 2.0, 4.0, 4.0])
    C = np.abs(x[:, None] - y[None, :])
    band = make_band(3, 4, 100.0)
    res = dtw(C, band)
    assert res.cost == 1.0
    np.testing.assert_array_equal(res.path, [[0, 0], [1, 1], [2, 2], [2, 3]])
    np.testing.assert_array_equal(dtw_features(x, y, band, metric="euclidean").path, res.path)
    assert dtw_features(x, y, band, metric="sqeuclidean").cost == 1.0


def test_tie_rule_prefers_diagonal_then_up():
    # all-zero costs: every predecessor ties; backtracking takes diagonals while it can
    res = dtw(np.zeros((3, 5)), make_band(3, 5, 100.0))
    np.testing.assert_array_equal(res.path, [[0, 0], [0, 1], [0, 2], [1, 3], [2, 4]])
    res = dtw(np.zeros((5, 3)), make_band(5, 3, 100.0))
    np.testing.assert_array_equal(res.path, [[0, 0], [1, 0], [2, 0], [3, 1], [4, 2]])


def test_no_constraints_band_geometry():
    band = make_band(11, 21, 2.0)
    # Delta = 2 * hypot(10, 20) / 20 = 2.236; centre c(i) = 2 i
    np.testing.assert_array_equal(band.lo, np.maximum(0, np.ceil(2 * np.arange(11) - 2.236)))
    np.testing.assert_array_equal(band.hi, np.minimum(20, np.floor(2 * np.arange(11) + 2.236)))
    assert band.contains(5, 8) and not band.contains(5, 7) and not band.contains(11, 20)
    assert band.n_cells == int(np.sum(band.hi - band.lo + 1))
    assert not band.lo.flags.writeable


# ------------------------------------------------------------------ errors

def test_constraints_may_share_a_column():
    """Two pins that round onto one hands frame: the path holds that frame across both rows."""
    band = make_band(50, 40, 10.0, [(10, 5), (12, 5)])
    assert band.lo[10] == band.hi[10] == 5 and band.lo[12] == band.hi[12] == 5
    r = dtw(lambda i0, i1: np.zeros((i1 - i0, band.max_row_width)), band)
    cols = {int(i): int(j) for i, j in r.path}
    assert cols[10] == 5 and cols[12] == 5


@pytest.mark.parametrize("cons,match", [
    ([(10, 5), (10, 8)], r"#1 \(x=10, y=8\) does not follow.*increase in x"),
    ([(10, 5), (12, 4)], r"#1 \(x=12, y=4\) does not follow.*not decrease in y"),
    ([(10, 5), (8, 9)], r"#1 \(x=8, y=9\)"),
    ([(0, 5)], r"#0 \(x=0, y=5\).*0 < x < n-1 = 49"),
    ([(49, 5)], r"#0 .*0 < x"),
    ([(10, 0)], r"#0 \(x=10, y=0\).*0 < y < m-1 = 39"),
    ([(10, 39)], r"#0 .*0 < y"),
    ([(10, 5, -1)], r"#0 \(x=10, y=5\).*tolerance T=-1"),
    ([(10.5, 5)], r"#0: x=10.5"),
])
def test_bad_constraints(cons, match):
    with pytest.raises(ConstraintError, match=match):
        make_band(50, 40, 10.0, cons)


def test_band_too_narrow_names_segment_and_min_width():
    cons = (Constraint(20, 20), Constraint(30, 70), Constraint(80, 90))
    with pytest.raises(BandError) as info:
        make_band(100, 100, 1.0, cons)
    err = info.value
    assert isinstance(err, SplicerError)
    msg = str(err)
    assert "between constraint #0 (x=20, y=20) and constraint #1 (x=30, y=70)" in msg
    assert err.segment == 1
    wmin = err.min_width
    assert f"W={math.ceil(wmin * 1000) / 1000:g}" in msg
    make_band(100, 100, wmin, cons)                          # the suggestion works
    make_band(100, 100, math.ceil(wmin * 1000) / 1000, cons)  # as printed, too
    with pytest.raises(BandError):
        make_band(100, 100, wmin * (1 - 1e-9), cons)         # slightly below fails


def test_constraints_infeasible_for_any_width():
    with pytest.raises(ConstraintError, match=r"#0 \(x=11, y=2, T=0\) and #1 \(x=12, y=7, T=1\)"):
        make_band(25, 25, 10.0, [(11, 2), (12, 7, 1)])
    make_band(25, 25, 10.0, [(11, 2, 3), (12, 7, 1)])   # within reach: feasible


def test_band_too_narrow_at_start_and_end():
    with pytest.raises(BandError, match=r"start \(0, 0\) and the end \(9, 99\)") as info:
        make_band(10, 100, 0.5)
    make_band(10, 100, info.value.min_width)
    with pytest.raises(BandError, match="positive"):
        make_band(10, 10, 0.0)


def test_invalid_costs_and_shapes(rng):
    band = make_band(6, 5, 100.0)
    C = rng.random((6, 5))
    for bad in (np.nan, -np.inf):
        D = C.copy()
        D[2, 3] = bad
        with pytest.raises(ValueError, match="NaN|-inf"):
            dtw(D, band)
        with pytest.raises(ValueError):
            dtw(as_callable(D, band), band)
    with pytest.raises(ValueError, match="shape"):
        dtw(C[:, :4], band)
    with pytest.raises(ValueError, match="shape"):
        dtw(lambda i0, i1: np.zeros((i1 - i0, 2)), band)
    with pytest.raises(ValueError, match="NaN"):
        dtw_features(np.full((6, 2), np.nan), np.zeros((5, 2)), band)
    with pytest.raises(ValueError, match="band is for"):
        dtw_features(np.zeros((7, 2)), np.zeros((5, 2)), band)
    with pytest.raises(ValueError, match="metric"):
        dtw_features(np.zeros((6, 2)), np.zeros((5, 2)), band, metric="cosine")
    D = C.copy()
    D[:, 2] = np.inf                      # a wall no monotone path can cross
    with pytest.raises(BandError, match="no path of finite cost"):
        dtw(D, band)


def test_band_validates_its_intervals():
    with pytest.raises(BandError, match="connect"):
        Band(n=3, m=6, width=1.0, lo=np.array([0, 3, 5]), hi=np.array([1, 4, 5]))
    with pytest.raises(BandError, match="lo\\[0\\]"):
        Band(n=2, m=3, width=1.0, lo=np.array([1, 1]), hi=np.array([1, 2]))
    with pytest.raises(BandError, match="shape"):
        Band(n=2, m=3, width=1.0, lo=np.array([0]), hi=np.array([2]))


def test_inputs_not_modified(rng):
    X, Y = rng.normal(size=(30, 3)), rng.normal(size=(25, 3))
    C = sqdist(X, Y)
    copies = [a.copy() for a in (X, Y, C)]
    band = make_band(30, 25, 6.0, [Constraint(10, 9, 1)])
    lo, hi = band.lo.copy(), band.hi.copy()
    dtw(C, band)
    dtw(as_callable(C, band), band)
    dtw_features(X, Y, band)
    for a, b in zip((X, Y, C), copies):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(band.lo, lo)
    np.testing.assert_array_equal(band.hi, hi)


@pytest.mark.parametrize("spec,expected", [
    (120, 120.0), (1.0, 1.0), (1, 1.0), (2.5, 2.5), ("30%", 30.0), ("120", 120.0), ("120f", 120.0),
    (" 2.5s ", 300.0), ("0.3%", 0.3), (np.int64(7), 7.0),
])
def test_band_frames(spec, expected):
    assert band_frames(spec, n=100, fps=120.0) == pytest.approx(expected)


@pytest.mark.parametrize("spec,match", [
    ("20s", "frame rate"), ("abc", "cannot parse"), (0, "positive"), (-3, "positive"),
    (float("nan"), "positive"), (True, "number"), ("0%", "positive"), ("0s", "positive"),
    (0.3, "less than one frame.*'30%'"), (0.999, "less than one frame.*'99.9%'"), ("0.3", "less than one frame"),
    ("0.5f", "less than one frame"), (float("inf"), "positive"), (None, "number"), ("3 m", "cannot parse"),
])
def test_band_frames_errors(spec, match):
    with pytest.raises(ConstraintError, match=match):
        band_frames(spec, n=100)


def test_check_costs_tells_nan_from_minus_inf_and_lets_plus_inf_pass():
    from splicer.align.dtw import _check_costs
    _check_costs(np.array([[0.0, np.inf], [1.0, 2.0]]), "rows 0..1")  # +inf: a forbidden cell, allowed
    _check_costs(np.zeros((0, 3)), "rows 0..-1")
    with pytest.raises(ValueError, match=r"local cost rows 0\.\.1 contains NaN"):
        _check_costs(np.array([[0.0, -np.inf], [np.nan, 2.0]]), "rows 0..1")  # both: NaN is named
    with pytest.raises(ValueError, match=r"local cost matrix contains -inf"):
        _check_costs(np.array([[0.0, -np.inf]]), "matrix")
