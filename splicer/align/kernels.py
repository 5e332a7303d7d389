"""The compiled kernels of the banded DTW (private, dumb; ALGORITHM.md section 2).

They only loop: contiguous float64 / int64 arrays and ints in, no defaults, no validation.
The recurrence, the open ends and the tie-breaking they implement are documented in
:mod:`splicer.align.dtw`, whose public wrappers (:func:`~splicer.align.dtw.dtw`,
:func:`~splicer.align.dtw.dtw_features`) validate the inputs, allocate the workspace and call
them.  Each kernel is checked against a slow plain-Python reference in ``tests/test_dtw.py``.

Layout shared by the kernels: the band's cells are stored row after row; row ``i`` covers
columns ``lo[i] .. hi[i]`` and starts at ``off[i]`` in the flat ``steps`` array (one uint8
step code per cell: 0 diagonal, 1 from ``(i-1, j)``, 2 from ``(i, j-1)``, 3 the path starts
here).  ``gamma`` is kept for two rows only (``rows[i & 1]``).
"""

import numpy as np
from numba import njit

@njit(cache=True)
def _dp_row(crow, c0, L, H, plo, phi, prev, cur, steps, s0, sc, ob, p0, pen, hx):
    # One DP row.  crow[c0 + k]: local cost of column L + k; prev[k]: gamma of the previous
    # row at column plo + k (columns plo..phi); writes cur[0..H-L], steps[s0 + k].
    # Step codes: 0 diagonal, 1 from (i-1, j), 2 from (i, j-1), 3 the path starts here.
    # Requires plo <= L <= phi + 1.
    # sc: start cost at column 0 of this row (+inf: none; only used when L == 0).
    # ob (open begin): no step (i-1, 0) -> (i, 0) out of a start cell (steps[p0] == 3): body
    # rows before the first hands frame are uncovered, not held on it.
    # pen: added to the (i-1, j) and (i, j-1) steps (0: the paper's recurrence).
    # hx: (horizontal weight - 1); a cell entered by a (i, j-1) step costs (1 + hx) * c
    # (hx * c is skipped when hx == 0 or c == +inf, so that +inf costs stay +inf, not NaN).
    inf = np.inf
    w = H - L + 1
    d = L - plo
    best = inf
    s = 0
    if d > 0:
        best = prev[d - 1]
    if L <= phi:
        up = prev[d] + pen
        if ob and L == 0 and steps[p0] == 3:
            up = inf
        if up < best:
            best = up
            s = 1
    if L == 0 and sc < best:
        best = sc
        s = 3
    cur[0] = crow[c0] + best
    steps[s0] = s
    kend = min(H, phi) - L
    if kend >= 1:                         # all three predecessors exist (slices: no wraparound)
        dg = prev[d:d + kend]
        up = prev[d + 1:d + 1 + kend]
        cr = crow[c0 + 1:c0 + 1 + kend]
        st = steps[s0 + 1:s0 + 1 + kend]
        left = cur[0]
        if hx == 0.0:
            for t in range(kend):         # branch-free: selects, not jumps
                a = dg[t]
                u = up[t] + pen
                su = u < a
                best = u if su else a
                lp = left + pen
                sl = lp < best
                st[t] = 2 if sl else (1 if su else 0)
                left = cr[t] + (lp if sl else best)
                cur[t + 1] = left
        else:
            for t in range(kend):
                a = dg[t]
                u = up[t] + pen
                su = u < a
                best = u if su else a
                c = cr[t]
                lp = left + pen + (hx * c if c < inf else 0.0)
                sl = lp < best
                st[t] = 2 if sl else (1 if su else 0)
                left = c + (lp if sl else best)
                cur[t + 1] = left
    k = max(kend + 1, 1)
    if k < w and L + k == phi + 1:        # diagonal and left only
        best = prev[phi - plo]
        s = 0
        left = cur[k - 1] + pen + (hx * crow[c0 + k] if (hx != 0.0 and crow[c0 + k] < np.inf) else 0.0)
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
            c = cr[t]
            left = c + (left + pen + (hx * c if (hx != 0.0 and c < inf) else 0.0))
            cur[k + t] = left
            st[t] = 2


@njit(cache=True)
def _dp_held_row(crow, c0, L, H, plo, phi, prev, cur, steps, s0, sc, ob, p0, pen):
    # A row where the body holds still: entered only by a (i-1, j) step, at no cost (the path
    # crosses the hold on one hands frame, as if the row were not there), or by a start at
    # column 0 (sc, with the cell's cost).  ob: as _dp_row (no step (i-1, 0) out of a start cell).
    # A +inf local cost still forbids its cell.
    inf = np.inf
    for k in range(H - L + 1):
        j = L + k
        best = inf
        if plo <= j <= phi and crow[c0 + k] < inf:
            best = prev[j - plo] + pen
            if ob and j == 0 and steps[p0] == 3:
                best = inf
        s = 1
        if j == 0 and sc + crow[c0] < best:  # j == 0: k == 0
            best = sc + crow[c0]
            s = 3
        cur[k] = best
        steps[s0 + k] = s


@njit(cache=True)
def _dp_first_row(crow, c0, w, cur, steps, sc, pen, hx):
    # Row 0: columns lo[0] .. lo[0] + w - 1.  The path starts at the first cell (fixed begin:
    # (0, 0)) or, with sc finite (open begin), at any cell where sc is strictly below the
    # accumulated cost from the left.
    cur[0] = crow[c0]
    if sc < np.inf:
        cur[0] += sc
    steps[0] = 3
    for k in range(1, w):
        left = cur[k - 1] + pen + (hx * crow[c0 + k] if (hx != 0.0 and crow[c0 + k] < np.inf) else 0.0)
        if sc < left:
            cur[k] = crow[c0 + k] + sc
            steps[k] = 3
        else:
            cur[k] = crow[c0 + k] + left
            steps[k] = 2


@njit(cache=True)
def _scan_end(cur, w, ec, i, L, best, steps, s0, last_row, m):
    # Open end: best = [cost, row, column] of the cheapest gamma + ec so far (strictly smaller
    # wins).  Ends: any cell of the last row, or column m - 1 of an earlier row; not on
    # column m - 1 entered by a step (i-1, j): body rows after the last hands frame are
    # uncovered, not held on it.
    k0 = 0 if last_row else w - 1
    if not last_row and L + w - 1 != m - 1:
        return
    for k in range(k0, w):
        if L + k == m - 1 and steps[s0 + k] == 1:
            continue
        v = cur[k] + ec
        if v < best[0]:
            best[0] = v
            best[1] = i
            best[2] = L + k


@njit(cache=True)
def _dp_row_both(crow, c0, L, H, plo, phi, prev, cur, steps, s0, i, sci, bs, p0, pen, hx, held_start):
    # One DP row (i >= 1) where the path may also start at any cell: at (i, j) for
    # sci + bs * min(j, i) (sci: the row's start cost, +inf: none; bs: per hands frame skipped
    # beside uncovered body rows).  Candidates in the tie order diagonal, (i-1, j), (i, j-1),
    # start; a later one wins only if strictly smaller.  No step (i-1, j) -> (i, j) out of a
    # start cell (steps[p0 + j - plo] == 3: body rows before the hands material are uncovered,
    # not held on its first frame), except a row-0 start past column 0; held_start: the previous
    # row has a start cell (else there is nothing to check).  Arguments as _dp_row.  Returns
    # whether this row has a start cell.
    inf = np.inf
    left = inf
    started = False
    can_start = sci < inf
    late = sci + bs * i                   # the start cost from column i on
    first = i == 1
    for k in range(H - L + 1):
        j = L + k
        c = crow[c0 + k]
        d = j - plo
        best = inf
        s = 0
        if 1 <= d <= phi - plo + 1:
            best = prev[d - 1]
        if 0 <= d <= phi - plo:
            if not (held_start and steps[p0 + d] == 3 and (not first or j == 0)):
                up = prev[d] + pen
                if up < best:
                    best = up
                    s = 1
        if k > 0:
            lp = left + pen
            if hx != 0.0 and c < inf:
                lp += hx * c
            if lp < best:
                best = lp
                s = 2
        if can_start:
            st = late if j >= i else sci + bs * j
            if st < best:
                best = st
                s = 3
                started = True
        left = c + best
        cur[k] = left
        steps[s0 + k] = s
    return started


@njit(cache=True)
def _scan_end_both(cur, w, eci, i, L, best, n, m, bs, steps, s0):
    # Open end at any cell: (i, j) for gamma + eci + bs * min(m - 1 - j, n - 1 - i), strictly
    # smaller than the best so far (rows, then columns, in increasing order); not on a cell
    # entered by a step (i-1, j) (body rows after the hands material are uncovered, not held
    # on its last frame), except on the last row before column m - 1.
    for k in range(w):
        j = L + k
        if steps[s0 + k] == 1 and (i < n - 1 or j == m - 1):
            continue
        v = cur[k] + eci + bs * min(m - 1 - j, n - 1 - i)
        if v < best[0]:
            best[0] = v
            best[1] = i
            best[2] = j


@njit(cache=True)
def _dp_rows(C, absolute, i0, i1, lo, hi, off, rows, steps, sc, ec, best, pen, hx, held, m, bs):
    # Rows i0..i1-1 from cost block C (row r = i - i0); column j of row i is at C[r, j] if
    # absolute else C[r, j - lo[i]].  rows: (2, width) gamma buffer indexed by row parity.
    # sc[i]: start cost in row i (+inf: none; row 0 always starts); ec[i]: end cost (+inf: none).
    # held[i]: row i is a body hold (_dp_held_row).  bs >= 0: starts and ends at any cell
    # (_dp_row_both, _scan_end_both); bs < 0: on row 0 / column 0 and row n-1 / column m-1.
    started = True                        # the row before i0 may hold a start cell
    for i in range(i0, i1):
        r = i - i0
        c0 = lo[i] if absolute else 0
        cur = rows[i & 1]
        if i == 0:
            _dp_first_row(C[r], c0, hi[0] - lo[0] + 1, cur, steps, sc[0], pen, hx)
            started = True
        elif bs >= 0.0 and not held[i]:
            started = _dp_row_both(C[r], c0, lo[i], hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur,
                                   steps, off[i], i, sc[i], bs, off[i - 1], pen, hx, started)
        elif held[i]:
            started = True
            _dp_held_row(C[r], c0, lo[i], hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur,
                         steps, off[i], sc[i], sc[0] < np.inf, off[i - 1], pen)
        else:
            _dp_row(C[r], c0, lo[i], hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur,
                    steps, off[i], sc[i], sc[0] < np.inf, off[i - 1], pen, hx)
        if ec[i] < np.inf:
            if bs >= 0.0:
                _scan_end_both(cur, hi[i] - lo[i] + 1, ec[i], i, lo[i], best, lo.shape[0], m, bs, steps, off[i])
            else:
                _scan_end(cur, hi[i] - lo[i] + 1, ec[i], i, lo[i], best, steps, off[i], i == lo.shape[0] - 1,
                          m)


@njit(cache=True)
def _dp_fused(X, Yt, metric, lo, hi, off, rows, crow, steps, sc, ec, best, pen, hx, held, bs):
    # Whole DP with local cost from features: X (n, d), Yt (d, m) (Y transposed);
    # metric 0 squared Euclidean, 1 Euclidean.  Start / end costs and bs as _dp_rows.
    n, d = X.shape
    started = True
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
            _dp_first_row(crow, 0, w, cur, steps, sc[0], pen, hx)
            started = True
        elif bs >= 0.0 and not held[i]:
            started = _dp_row_both(crow, 0, L, hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur, steps,
                                   off[i], i, sc[i], bs, off[i - 1], pen, hx, started)
        elif held[i]:
            started = True
            _dp_held_row(crow, 0, L, hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur, steps,
                         off[i], sc[i], sc[0] < np.inf, off[i - 1], pen)
        else:
            _dp_row(crow, 0, L, hi[i], lo[i - 1], hi[i - 1], rows[(i - 1) & 1], cur, steps,
                    off[i], sc[i], sc[0] < np.inf, off[i - 1], pen, hx)
        if ec[i] < np.inf:
            if bs >= 0.0:
                _scan_end_both(cur, w, ec[i], i, L, best, n, Yt.shape[1], bs, steps, off[i])
            else:
                _scan_end(cur, w, ec[i], i, L, best, steps, off[i], i == n - 1, Yt.shape[1])


@njit(cache=True)
def _backtrack(lo, off, steps, iend, jend):
    # Follow the step codes from (iend, jend) back to the first cell (code 3); returns (K, 2).
    buf = np.empty((iend + jend + 1, 2), dtype=np.int64)
    i = iend
    j = jend
    t = iend + jend
    buf[t, 0] = i
    buf[t, 1] = j
    s = steps[off[i] + j - lo[i]]
    while s != 3:
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
        s = steps[off[i] + j - lo[i]]
    return buf[t:].copy()
