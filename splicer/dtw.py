"""Banded dynamic time warping with a stored path (ALGORITHM.md section 2).

Recurrence (0-based, path from ``(0, 0)`` to ``(n - 1, m - 1)``)::

    gamma[0, 0] = c[0, 0]
    gamma[i, j] = c[i, j] + min(gamma[i-1, j-1], gamma[i-1, j], gamma[i, j-1])

over the admissible cells of a :class:`~splicer.band.Band`; cells outside the band are
``+inf``.  Ties are broken deterministically: the diagonal predecessor ``(i-1, j-1)`` is
preferred, then ``(i-1, j)``, then ``(i, j-1)`` (a later candidate wins only if it is
strictly smaller).

Memory is O(n * band): one byte (uint8 step choice) per band cell, plus two rows of
``gamma`` and, for callable costs, one chunk of local costs.  Time is O(n * band).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .band import Band, Constraint, band_frames, make_band
from .errors import BandError

__all__ = ["Constraint", "Band", "DTWResult", "make_band", "band_frames", "dtw", "dtw_features"]

#: float64 cells per chunk of local costs requested from a callable (32 MiB).
CHUNK_CELLS = 1 << 22

_METRICS = {"sqeuclidean": 0, "euclidean": 1}


@dataclass(frozen=True, eq=False)
class DTWResult:
    """Result of a banded DTW.

    Parameters
    ----------
    path : np.ndarray [shape=(K, 2), dtype=int64]
        Cells ``(i, j)`` from ``(0, 0)`` to ``(n - 1, m - 1)``; steps in
        ``{(1, 0), (0, 1), (1, 1)}``.
    cost : float
        Sum of local costs along the path (``gamma[n-1, m-1]``), not normalised.
    band : Band
        The band the alignment was computed in.
    """

    path: np.ndarray
    cost: float
    band: Band


# ---------------------------------------------------------------- kernels (private, dumb)

@njit(cache=True)
def _dp_row(crow, c0, L, H, plo, phi, prev, cur, steps, s0):
    # One DP row.  crow[c0 + k]: local cost of column L + k; prev[k]: gamma of the previous
    # row at column plo + k (columns plo..phi); writes cur[0..H-L], steps[s0 + k].
    # Step codes: 0 diagonal, 1 from (i-1, j), 2 from (i, j-1).  Requires plo <= L <= phi + 1.
    inf = np.inf
    w = H - L + 1
    d = L - plo
    best = inf
    s = 0
    if d > 0:
        best = prev[d - 1]
    if L <= phi:
        up = prev[d]
        if up < best:
            best = up
            s = 1
    cur[0] = crow[c0] + best
    steps[s0] = s
    kend = min(H, phi) - L
    if kend >= 1:                         # all three predecessors exist (slices: no wraparound)
        dg = prev[d:d + kend]
        up = prev[d + 1:d + 1 + kend]
        cr = crow[c0 + 1:c0 + 1 + kend]
        st = steps[s0 + 1:s0 + 1 + kend]
        left = cur[0]
        for t in range(kend):             # branch-free: selects, not jumps
            a = dg[t]
            u = up[t]
            su = u < a
            best = u if su else a
            sl = left < best
            st[t] = 2 if sl else (1 if su else 0)
            left = cr[t] + (left if sl else best)
            cur[t + 1] = left
    k = max(kend + 1, 1)
    if k < w and L + k == phi + 1:        # diagonal and left only
        best = prev[phi - plo]
        s = 0
        left = cur[k - 1]
        if left < best:
            best = left
            s = 2
        cur[k] = crow[c0 + k] + best
        steps[s0 + k] = s
        k += 1
    if k < w:                             # left only
        cr = crow[c0 + k:c0 + w]
        st = steps[s0 + k:s0 + w]
        left = cur[k - 1]
        for t in range(w - k):
            left = cr[t] + left
            cur[k + t] = left
            st[t] = 2


@njit(cache=True)
def _dp_first_row(crow, c0, H, cur, steps):
    # Row 0: columns 0..H, gamma[0, 0] = c[0, 0], then only left steps.
    cur[0] = crow[c0]
    steps[0] = 0
    for k in range(1, H + 1):
        cur[k] = crow[c0 + k] + cur[k - 1]
        steps[k] = 2


@njit(cache=True)
def _dp_rows(C, absolute, i0, i1, lo, hi, off, rows, steps):
    # Rows i0..i1-1 from cost block C (row r = i - i0); column j of row i is at C[r, j] if
    # absolute else C[r, j - lo[i]].  rows: (2, width) gamma buffer indexed by row parity.
    for i in range(i0, i1):
        r = i - i0
        c0 = lo[i] if absolute else 0
        cur = rows[i & 1]
        if i == 0:
            _dp_first_row(C[r], c0, hi[0], cur, steps)
        else:
            _dp_row(C[r], c0, lo[i], hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur,
                    steps, off[i])


@njit(cache=True)
def _dp_fused(X, Yt, metric, lo, hi, off, rows, crow, steps):
    # Whole DP with local cost from features: X (n, d), Yt (d, m) (Y transposed);
    # metric 0 squared Euclidean, 1 Euclidean.  Returns gamma[n-1, m-1].
    n, d = X.shape
    for i in range(n):
        L = lo[i]
        w = hi[i] - L + 1
        c = crow[:w]                      # slices keep indices non-negative: SIMD
        c[:] = 0.0
        for f in range(d):
            xf = X[i, f]
            ys = Yt[f, L:L + w]
            for k in range(w):
                t = xf - ys[k]
                c[k] += t * t
        if metric == 1:
            for k in range(w):
                c[k] = np.sqrt(c[k])
        cur = rows[i & 1]
        if i == 0:
            _dp_first_row(crow, 0, hi[0], cur, steps)
        else:
            _dp_row(crow, 0, L, hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur, steps,
                    off[i])
    return rows[(n - 1) & 1][hi[n - 1] - lo[n - 1]]


@njit(cache=True)
def _backtrack(lo, off, steps, n, m):
    # Follow the step codes from (n-1, m-1) back to (0, 0); returns (K, 2) int64.
    buf = np.empty((n + m - 1, 2), dtype=np.int64)
    i = n - 1
    j = m - 1
    t = n + m - 2
    buf[t, 0] = i
    buf[t, 1] = j
    while i > 0 or j > 0:
        s = steps[off[i] + j - lo[i]]
        if s == 0:
            i -= 1
            j -= 1
        elif s == 1:
            i -= 1
        else:
            j -= 1
        t -= 1
        buf[t, 0] = i
        buf[t, 1] = j
    return buf[t:].copy()


# ---------------------------------------------------------------- public wrappers

def _workspace(band: Band):
    lo = np.ascontiguousarray(band.lo, dtype=np.int64)
    hi = np.ascontiguousarray(band.hi, dtype=np.int64)
    widths = hi - lo + 1
    off = np.zeros(band.n + 1, dtype=np.int64)
    np.cumsum(widths, out=off[1:])
    wmax = int(widths.max())
    steps = np.empty(int(off[-1]), dtype=np.uint8)
    rows = np.full((2, wmax), np.inf)
    return lo, hi, off, wmax, steps, rows


def _finish(band, lo, off, steps, cost):
    if np.isnan(cost):  # pragma: no cover - NaN costs are rejected before the DP
        raise ValueError("DTW produced a NaN cost")
    if not np.isfinite(cost):
        raise BandError("no path of finite cost exists inside the band (every path crosses a "
                        "+inf local cost)")
    path = _backtrack(lo, off, steps, band.n, band.m)
    return DTWResult(path=path, cost=float(cost), band=band)


def _check_costs(block, what):
    if np.isnan(block).any():
        raise ValueError(f"local cost {what} contains NaN")
    if np.isneginf(block).any():
        raise ValueError(f"local cost {what} contains -inf")


def dtw(cost, band: Band) -> DTWResult:
    """Banded DTW with path, on given local costs.

    Parameters
    ----------
    cost : np.ndarray [shape=(n, m), dtype=float64] or callable
        Either the full local-cost matrix (small problems), or a callable
        ``cost(i0, i1) -> np.ndarray [shape=(i1 - i0, w)]`` returning the local costs of rows
        ``i0 .. i1 - 1`` with column ``j`` of row ``i`` at position ``j - band.lo[i]``, where
        ``w = max(band.hi - band.lo + 1)`` (entries beyond a row's width are ignored).  It is
        called once per chunk of rows (about ``CHUNK_CELLS / w`` rows), in increasing order.
        ``+inf`` marks a forbidden cell; NaN and ``-inf`` are errors.
    band : Band
        Admissible cells (see :func:`make_band`).

    Returns
    -------
    DTWResult
        Optimal path (ties: diagonal, then ``(i-1, j)``, then ``(i, j-1)``) and its cost.

    Raises
    ------
    ValueError
        Wrong cost shape, NaN or ``-inf`` costs.
    BandError
        No path of finite cost exists in the band.

    Notes
    -----
    O(n * band) time and memory: 1 byte per band cell (uint8 step choices), two rows of
    ``gamma`` and one chunk of costs; the ``n x m`` matrix is never built by the engine.
    """
    if not isinstance(band, Band):
        raise TypeError(f"band must be a splicer.dtw.Band, got {type(band).__name__}")
    n, m = band.n, band.m
    lo, hi, off, wmax, steps, rows = _workspace(band)
    if callable(cost):
        chunk = max(1, min(n, CHUNK_CELLS // wmax))
        for i0 in range(0, n, chunk):
            i1 = min(n, i0 + chunk)
            block = np.asarray(cost(i0, i1))
            if block.ndim != 2 or block.shape[0] != i1 - i0 or block.shape[1] < wmax:
                raise ValueError(f"cost({i0}, {i1}) must return shape ({i1 - i0}, >= {wmax}), "
                                 f"got {block.shape}")
            block = np.ascontiguousarray(block[:, :wmax], dtype=np.float64)
            # only the band part of each row is checked (padding is ignored)
            mask = np.arange(wmax)[None, :] <= (hi[i0:i1] - lo[i0:i1])[:, None]
            _check_costs(np.where(mask, block, 0.0), f"rows {i0}..{i1 - 1}")
            _dp_rows(block, False, i0, i1, lo, hi, off, rows, steps)
    else:
        c = np.asarray(cost)
        if c.shape != (n, m):
            raise ValueError(f"cost matrix must have shape (n, m) = ({n}, {m}), got {c.shape}")
        c = np.ascontiguousarray(c, dtype=np.float64)
        _check_costs(c, "matrix")
        _dp_rows(c, True, 0, n, lo, hi, off, rows, steps)
    total = rows[(n - 1) & 1][hi[n - 1] - lo[n - 1]]
    return _finish(band, lo, off, steps, total)


def dtw_features(X, Y, band: Band, metric: str = "sqeuclidean") -> DTWResult:
    """Banded DTW with path, local cost computed on the fly from feature vectors.

    Parameters
    ----------
    X : np.ndarray [shape=(n, d) or (n,), dtype=float64]
        First (body) sequence, one feature vector per frame.
    Y : np.ndarray [shape=(m, d) or (m,), dtype=float64]
        Second (hands) sequence, same feature units as ``X``.
    band : Band
        Admissible cells, with ``band.n == n`` and ``band.m == m``.
    metric : {"sqeuclidean", "euclidean"}
        Local cost: squared Euclidean distance (units of X squared) or Euclidean distance.

    Returns
    -------
    DTWResult
        As :func:`dtw`; ``cost`` is the sum of local costs along the path.

    Notes
    -----
    One fused compiled kernel computes local costs row by row and runs the recurrence:
    O(n * band * d) time, O(n * band) bytes for the step choices plus O(band) floats.
    """
    if not isinstance(band, Band):
        raise TypeError(f"band must be a splicer.dtw.Band, got {type(band).__name__}")
    if metric not in _METRICS:
        raise ValueError(f"metric must be one of {sorted(_METRICS)}, got {metric!r}")
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    X = X[:, None] if X.ndim == 1 else X
    Y = Y[:, None] if Y.ndim == 1 else Y
    if X.ndim != 2 or Y.ndim != 2 or X.shape[1] != Y.shape[1]:
        raise ValueError(f"X and Y must be (n, d) and (m, d) with the same d, got {X.shape} "
                         f"and {Y.shape}")
    if X.shape[0] != band.n or Y.shape[0] != band.m:
        raise ValueError(f"band is for n={band.n}, m={band.m} but X has {X.shape[0]} frames and "
                         f"Y has {Y.shape[0]}")
    for name, a in (("X", X), ("Y", Y)):
        if not np.isfinite(a).all():
            raise ValueError(f"{name} contains NaN or inf")
    Xc = np.ascontiguousarray(X)
    Yt = np.ascontiguousarray(Y.T)
    lo, hi, off, wmax, steps, rows = _workspace(band)
    crow = np.empty(wmax)
    total = _dp_fused(Xc, Yt, _METRICS[metric], lo, hi, off, rows, crow, steps)
    return _finish(band, lo, off, steps, total)
