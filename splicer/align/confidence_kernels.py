"""The private numba kernels of :mod:`splicer.align.confidence`: forward and backward accumulated
costs over a band, and each row's near-optimal spread.  Contiguous arrays in, loops, no validation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = []


@njit(cache=True)
def _store_row(cur, w, out, o, rowmin, i):
    m = np.inf
    for k in range(w):
        if cur[k] < m:
            m = cur[k]
    rowmin[i] = m
    for k in range(w):
        out[o + k] = cur[k] - m if m < np.inf else np.inf


@njit(cache=True)
def _forward(c, lo, hi, off, sc, ob, pen, hx, out, rowmin):
    # Forward accumulated cost, the engine's recurrence (values only): the cheapest prefix
    # ending at (i, j), the cell's own local cost included (times 1 + hx when entered by a
    # (i, j-1) step).  c, out: flat float32 band cells (row i at off[i] .. off[i+1]-1).
    # sc[i]: start cost (open begin: anywhere in row 0, column 0 of row i; fixed begin: only
    # (0, lo[0]) at 0).  ob: no step (i-1, 0) -> (i, 0) out of a cell whose best is a start.
    # out = value - rowmin[i] (float32); rowmin[i] = the row's minimum (+inf if none finite).
    n = lo.shape[0]
    wmax = 0
    for i in range(n):
        wmax = max(wmax, hi[i] - lo[i] + 1)
    prev = np.full(wmax, np.inf)
    pst = np.zeros(wmax, np.bool_)
    _forward_rows(c, lo, hi, off, sc, ob, pen, hx, 0, n, prev, pst, out, 0, rowmin)


@njit(cache=True)
def _forward_rows(c, lo, hi, off, sc, ob, pen, hx, i0, i1, prev, pst, out, base, rowmin):
    # Rows i0 .. i1-1 of _forward, continuing from the state of row i0-1: prev (float64
    # accumulated costs, row i0-1's cells first) and pst (those cells' best is a start), both
    # of length >= the widest row and updated in place to row i1-1's state.  Row i is read
    # at c[off[i] - base ...] and written at out[off[i] - base ...] (block buffers when
    # base = off[i0]); rowmin is indexed by the global row.
    wmax = prev.shape[0]
    cur = np.full(wmax, np.inf)
    cst = np.zeros(wmax, np.bool_)
    for i in range(i0, i1):
        L = lo[i]
        w = hi[i] - L + 1
        for k in range(w):
            j = L + k
            cc = np.float64(c[off[i] - base + k])
            best = np.inf
            isst = False
            if i > 0:
                plo = lo[i - 1]
                phi = hi[i - 1]
                if plo <= j - 1 <= phi:
                    best = prev[j - 1 - plo]
                if plo <= j <= phi and not (ob and j == 0 and pst[j - plo]):
                    if prev[j - plo] + pen < best:
                        best = prev[j - plo] + pen
            if k > 0:
                lp = cur[k - 1] + pen + (hx * cc if (hx != 0.0 and cc < np.inf) else 0.0)
                if lp < best:
                    best = lp
            if (ob and (i == 0 or j == 0)) or (i == 0 and k == 0):
                s = sc[i] if ob else 0.0
                if s < best:
                    best = s
                    isst = True
            cur[k] = cc + best
            cst[k] = isst
        _store_row(cur, w, out, off[i] - base, rowmin, i)
        for k in range(w):
            prev[k] = cur[k]
            pst[k] = cst[k]
            cur[k] = np.inf
            cst[k] = False


@njit(cache=True)
def _backward(c, lo, hi, off, ec, oe, pen, hx, m, out, rowmin):
    # Backward accumulated cost: the cheapest suffix from (i, j) to an end, the cell's own
    # local cost excluded (each later cell counts as the forward pass counts it).
    # ec[i]: end cost (open end: anywhere in row n-1, column m-1 of row i; fixed end: only
    # (n-1, m-1) at 0).  oe: no step (i, m-1) -> (i+1, m-1) into a cell whose best is an end
    # (the engine cannot end on a hold of the last hands frame).
    n = lo.shape[0]
    wmax = 0
    for i in range(n):
        wmax = max(wmax, hi[i] - lo[i] + 1)
    nxt = np.full(wmax, np.inf)
    nst = np.zeros(wmax, np.bool_)
    _backward_rows(c, lo, hi, off, ec, oe, pen, hx, m, 0, n, nxt, nst, out, 0, rowmin)


@njit(cache=True)
def _backward_rows(c, lo, hi, off, ec, oe, pen, hx, m, i0, i1, nxt, nst, out, base, rowmin):
    # Rows i1-1 down to i0 of _backward, continuing from the state of row i1: nxt (float64
    # suffix costs of row i1's cells) and nst (their best is an end), updated in place to
    # row i0's state.  Row i is read at c[off[i] - base ...] (c must also hold row i1 when
    # i1 < n) and written at out[off[i] - base ...]; rowmin is indexed by the global row.
    n = lo.shape[0]
    wmax = nxt.shape[0]
    cur = np.full(wmax, np.inf)
    cst = np.zeros(wmax, np.bool_)
    for i in range(i1 - 1, i0 - 1, -1):
        L = lo[i]
        w = hi[i] - L + 1
        for k in range(w - 1, -1, -1):
            j = L + k
            best = np.inf
            isend = False
            if i < n - 1:
                nlo = lo[i + 1]
                nhi = hi[i + 1]
                if nlo <= j + 1 <= nhi:
                    v = nxt[j + 1 - nlo] + np.float64(c[off[i + 1] - base + j + 1 - nlo])
                    if v < best:
                        best = v
                if nlo <= j <= nhi and not (oe and j == m - 1 and nst[j - nlo]):
                    v = nxt[j - nlo] + pen + np.float64(c[off[i + 1] - base + j - nlo])
                    if v < best:
                        best = v
            if k < w - 1:
                cc = np.float64(c[off[i] - base + k + 1])
                v = cur[k + 1] + pen + cc + (hx * cc if (hx != 0.0 and cc < np.inf) else 0.0)
                if v < best:
                    best = v
            if (oe and (i == n - 1 or j == m - 1)) or (i == n - 1 and j == m - 1):
                e = ec[i] if oe else 0.0
                if e < best:
                    best = e
                    isend = True
            cur[k] = best
            cst[k] = isend
        _store_row(cur, w, out, off[i] - base, rowmin, i)
        for k in range(w):
            nxt[k] = cur[k]
            nst[k] = cst[k]
            cur[k] = np.inf
            cst[k] = False


@njit(cache=True)
def _row_stats(fwd, fmin, bwd, bmin, lo, hi, off, optimum, tau, jc, spread, err, exmin):
    # Every row: exmin = min over the row's cells of excess = fwd + bwd - optimum.
    # Covered rows (jc[i] finite): spread = max - min of columns with excess <= tau,
    # err = max |j - jc| over them.
    n = lo.shape[0]
    for i in range(n):
        m = np.inf
        for k in range(hi[i] - lo[i] + 1):
            b = bwd[off[i] + k]
            f = fwd[off[i] + k]
            if np.isfinite(b) and np.isfinite(f):
                x = (np.float64(f) + fmin[i]) + (np.float64(b) + bmin[i]) - optimum
                if x < m:
                    m = x
        exmin[i] = m
        if not np.isfinite(jc[i]):
            continue
        L = lo[i]
        w = hi[i] - L + 1
        jmin = -1
        jmax = -1
        e = 0.0
        for k in range(w):
            b = bwd[off[i] + k]
            f = fwd[off[i] + k]
            if not (np.isfinite(b) and np.isfinite(f)):
                continue
            x = (np.float64(f) + fmin[i]) + (np.float64(b) + bmin[i]) - optimum
            if x <= tau:
                j = L + k
                if jmin < 0:
                    jmin = j
                jmax = j
                d = abs(j - jc[i])
                if d > e:
                    e = d
        if jmin >= 0:
            spread[i] = jmax - jmin
            err[i] = e
        else:                      # pragma: no cover - the path's own cells have excess ~0
            spread[i] = 0.0
            err[i] = 0.0
