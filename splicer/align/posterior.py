"""The alignment's posterior around the best path: an expected hands frame and its spread.

The DTW returns one path, the cheapest.  Where several paths cost nearly the same (a still
arm gives D1 nothing to go on; D1's costs are whole numbers, so exact ties are common), which
one wins is decided by the tie-break order, and a change of the input far below capture noise
(Blender's float32 round trip: 1e-5 degrees) can swap them and move the time map by frames.

Here every monotone path through a tube around the best path is weighted by
``exp(-cost / temperature)`` (a Gibbs distribution over paths, as in soft-DTW, Cuturi &
Blondel 2017), and forward-backward sums give the probability of every cell and every
diagonal step.  Each path crosses each anti-diagonal ``d = i + j`` exactly once: at a cell,
or half-way along a diagonal step over it.  The expected crossing point of every
anti-diagonal traces the **expected path**, monotone in both frames; read at each body frame
it is the expected hands frame.  It is a smooth function of the costs, so near-ties average
instead of flipping, and it treats the two takes alike: an identical pair gives the diagonal
exactly, also at the ends, where a row-wise mean would be pulled inwards.  The spread of the
crossing point says how well the alignment is determined there.

The path's first and last cells are kept fixed (the ends are the DTW's decision), the costs
and steps are the pass's own (step penalty, horizontal weight), and the tube is clipped to
the pass's band, so pins still hold.  Memory is 8 bytes per tube cell (float32 costs and
forward sums, each row of sums relative to its largest).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .band import Band
from .dtw import _held
from .paths import path_median

__all__ = ["Posterior", "expected_frames", "path_posterior", "tube_band"]

#: :func:`path_posterior` runs its backward sweep in this many pieces of rows, with a progress
#: update after each (on an hour-long pair the sweep takes seconds); the sums are the same.
BACKWARD_PIECES = 16


@dataclass(frozen=True, eq=False)
class Posterior:
    """Expected hands frame per body frame under the path distribution.

    Attributes
    ----------
    mean : np.ndarray [shape=(n,)]
        The expected path read at each body frame: a hands frame (the pass's frames),
        non-decreasing; NaN outside the rows the path covers.
    std : np.ndarray [shape=(n,)]
        Its spread, frames; NaN outside the covered rows.
    temperature : float
        Cost units (the pass's local cost) per e-fold of path probability.
    radius : int
        Columns each side of the best path that the tube admits.
    """

    mean: np.ndarray
    std: np.ndarray
    temperature: float
    radius: int


def tube_band(band: Band, path: np.ndarray, radius: int) -> Band:
    """The cells within ``radius`` columns of ``path`` on each row, clipped to ``band``.

    Rows the path does not cover get the path's end cell (they are never visited).  The
    first row of the path starts at the path's first cell and its last row ends at the path's
    last cell.
    """
    n = band.n
    i, j = path[:, 0].astype(np.int64), path[:, 1].astype(np.int64)
    r0, r1 = int(i[0]), int(i[-1])
    rows = np.arange(r0, r1 + 1)
    first = np.searchsorted(i, rows, side="left")
    last = np.searchsorted(i, rows, side="right") - 1
    lo = np.empty(n, np.int64)
    hi = np.empty(n, np.int64)
    lo[:r0], hi[:r0] = j[0], j[0]
    lo[r1 + 1:], hi[r1 + 1:] = j[-1], j[-1]
    lo[r0:r1 + 1] = np.maximum(np.maximum(j[first] - radius, band.lo[r0:r1 + 1]), j[0])
    hi[r0:r1 + 1] = np.minimum(np.minimum(j[last] + radius, band.hi[r0:r1 + 1]), j[-1])
    lo[r0] = j[0]
    hi[r1] = j[-1]
    # every row holds the path's own cells, so consecutive rows connect (Band checks it)
    return Band(n=n, m=band.m, width=float(radius), lo=lo, hi=hi, constraints=band.constraints,
                open_begin=True, open_end=True)


@njit(cache=True, inline="always")
def _lae(a, b):
    # log(exp(a) + exp(b)), with -inf handled
    if a < b:
        a, b = b, a
    if b == -np.inf:
        return a
    return a + np.log1p(np.exp(b - a))


@njit(cache=True)
def _forward(C, lo, hi, off, r0, r1, inv_t, pen, hx, held, alpha, shift):
    # alpha[off[i] + k] + shift[i]: log of the summed weight of the partial paths from the start
    # cell (r0, lo[r0]) to (i, lo[i] + k), the cell's own cost included.  Each row is stored
    # as float32 relative to its largest value (shift[i], float64), so a long take's sums keep
    # their precision in half the memory.
    ninf = -np.inf
    p = pen * inv_t
    W = 0
    for i in range(r0, r1 + 1):
        W = max(W, hi[i] - lo[i] + 1)
    prev = np.full(W, ninf)
    cur = np.full(W, ninf)
    for i in range(r0, r1 + 1):
        L, H, o = lo[i], hi[i], off[i]
        top = ninf
        if i > r0 and held[i]:  # a body hold: entered only from the cell above, at no cost
            pL, pH = lo[i - 1], hi[i - 1]
            for k in range(H - L + 1):
                j = L + k
                v = prev[j - pL] - p if pL <= j <= pH and C[o + k] < np.inf else ninf
                cur[k] = v
                if v > top:
                    top = v
        else:
            for k in range(H - L + 1):
                j = L + k
                c = C[o + k]
                if c == np.inf:
                    cur[k] = ninf
                    continue
                acc = ninf
                if i == r0 and k == 0:
                    acc = 0.0
                if i > r0:
                    pL, pH = lo[i - 1], hi[i - 1]
                    if pL <= j - 1 <= pH:
                        acc = _lae(acc, prev[j - 1 - pL])
                    if pL <= j <= pH:
                        acc = _lae(acc, prev[j - pL] - p)
                if k > 0:
                    acc = _lae(acc, cur[k - 1] - p - hx * c * inv_t)
                v = acc - c * inv_t
                cur[k] = v
                if v > top:
                    top = v
        if top == ninf:
            top = 0.0
        shift[i] = top
        for k in range(H - L + 1):
            alpha[o + k] = cur[k] - top
            prev[k] = cur[k]
            cur[k] = ninf


@njit(cache=True)
def _backward(C, lo, hi, off, r0, r1, a, b, inv_t, pen, hx, held, alpha, shift, s0, s1, s2, nxt):
    # beta (two rows): log of the summed weight of the completions from (i, j) to the end
    # cell (r1, hi[r1]), that cell's cost excluded.  The probabilities of the cells
    # (exp(alpha + beta - Z)) and of the diagonal steps are added up per anti-diagonal
    # d = i + j (a step (i-1, j-1) -> (i, j) crosses d = i + j - 1 at row i - 0.5):
    # s0[d] total (1 up to rounding), s1[d] sum of p * row, s2[d] sum of p * row^2.
    # Rows a down to b (r1 >= a >= b >= r0), in pieces: nxt holds beta of row a + 1 (all -inf
    # when a == r1; length: the widest row + 1) and is left holding row b's.
    ninf = -np.inf
    p = pen * inv_t
    W = nxt.shape[0] - 1
    cur = np.full(W + 1, ninf)
    Z = alpha[off[r1] + hi[r1] - lo[r1]] + shift[r1]
    for i in range(a, b - 1, -1):
        L, H, o = lo[i], hi[i], off[i]
        w = H - L + 1
        for k in range(w - 1, -1, -1):
            j = L + k
            acc = ninf
            if i == r1 and k == w - 1:
                acc = 0.0
            if k < w - 1 and not (held[i] and i > r0):
                c = C[o + k + 1]
                if c < np.inf:
                    acc = _lae(acc, cur[k + 1] - p - (1.0 + hx) * c * inv_t)
            if i < r1:
                nL, nH, no = lo[i + 1], hi[i + 1], off[i + 1]
                if held[i + 1]:  # the next row is a body hold: only straight down, at no cost
                    if nL <= j <= nH and C[no + j - nL] < np.inf:
                        acc = _lae(acc, nxt[j - nL] - p)
                else:
                    if nL <= j + 1 <= nH:
                        c = C[no + j + 1 - nL]
                        if c < np.inf:
                            acc = _lae(acc, nxt[j + 1 - nL] - c * inv_t)
                    if nL <= j <= nH:
                        c = C[no + j - nL]
                        if c < np.inf:
                            acc = _lae(acc, nxt[j - nL] - p - c * inv_t)
            cur[k] = acc
        for k in range(w):
            j = L + k
            lp = alpha[o + k] + shift[i] + cur[k] - Z
            if lp > -745.0:
                q = np.exp(lp)
                s0[i + j] += q
                s1[i + j] += q * i
                s2[i + j] += q * i * i
            if i > r0 and not held[i]:
                pL, pH, po = lo[i - 1], hi[i - 1], off[i - 1]
                c = C[o + k]
                if pL <= j - 1 <= pH and c < np.inf:
                    lp = alpha[po + j - 1 - pL] + shift[i - 1] - c * inv_t + cur[k] - Z
                    if lp > -745.0:
                        q = np.exp(lp)
                        x = i - 0.5
                        s0[i + j - 1] += q
                        s1[i + j - 1] += q * x
                        s2[i + j - 1] += q * x * x
        for k in range(w):
            nxt[k] = cur[k]
            cur[k] = ninf
        for k in range(w, W + 1):
            nxt[k] = ninf


def _rows_from_diagonals(s0, s1, s2, d0: int, d1: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The expected path (crossing point of each anti-diagonal ``d0 .. d1``) read at every row.

    Returns ``(mean, std)`` of shape (n,): the expected column at each row the path covers
    (NaN elsewhere) and the spread of the column there, ``(1 + slope) x`` the crossing point's
    standard deviation along the anti-diagonal (a crossing ``e`` rows further on lands
    ``(1 + slope) e`` columns off at the same row).
    """
    d = np.arange(d0, d1 + 1)
    w = s0[d0:d1 + 1]
    ei = s1[d0:d1 + 1] / w
    vi = np.maximum(s2[d0:d1 + 1] / w - ei * ei, 0.0)
    ej = d - ei
    ei = np.maximum.accumulate(ei)  # monotone in exact arithmetic; rounding only
    ej = np.maximum.accumulate(ej)
    # rows where the expected path runs flat (several crossings on one row): their mean
    xs, inv = np.unique(ei, return_inverse=True)
    cnt = np.bincount(inv)
    fj = np.bincount(inv, ej) / cnt
    fv = np.bincount(inv, vi) / cnt
    mean = np.full(n, np.nan)
    std = np.full(n, np.nan)
    rows = np.arange(int(np.ceil(xs[0] - 1e-9)), int(np.floor(xs[-1] + 1e-9)) + 1)
    mean[rows] = np.interp(rows, xs, fj)
    slope = np.gradient(fj, xs) if len(xs) > 1 else np.zeros(1)
    std[rows] = (1.0 + np.interp(rows, xs, np.abs(slope))) * np.sqrt(np.interp(rows, xs, fv))
    return mean, std


def path_posterior(cost, band: Band, path: np.ndarray, *, temperature: float, radius: int,
                   step_penalty: float = 0.0, horizontal_weight: float = 1.0, held_rows=None,
                   chunk_rows: int = 2048, progress=None) -> Posterior:
    """Expected column and its spread for every row, over the paths near ``path``.

    Parameters
    ----------
    cost : callable ``(band, i0, i1) -> np.ndarray``
        The pass's band-chunk cost (:func:`splicer.align.costs.d1_cost`).
    band : Band
        The pass's band (pins included): the tube never leaves it.
    path : np.ndarray [shape=(K, 2)]
        The pass's best path; its first and last cells are the ends of every path weighed.
    temperature : float
        Cost units per e-fold of probability, > 0.  Small: the best path alone.
    radius : int
        Columns each side of the best path that alternative paths may use, >= 0.
    step_penalty, horizontal_weight, held_rows
        The pass's own (:func:`splicer.align.dtw.dtw`).
    progress : callable, optional
        ``progress(fraction)`` as the tube's costs are computed (up to 0.5), after the forward
        sweep (0.6) and after each piece of the backward sweep (up to 1.0).

    Returns
    -------
    Posterior
    """
    if not temperature > 0 or not np.isfinite(temperature):
        raise ValueError(f"temperature must be positive and finite, got {temperature!r}")
    radius = int(radius)
    if radius < 0:
        raise ValueError(f"radius must be >= 0, got {radius}")
    path = np.asarray(path)
    if path.ndim != 2 or path.shape[1] != 2 or len(path) == 0:
        raise ValueError(f"path must have shape (K, 2), got {path.shape}")
    tube = tube_band(band, path, radius)
    r0, r1 = int(path[0, 0]), int(path[-1, 0])
    widths = tube.hi - tube.lo + 1
    off = np.zeros(tube.n + 1, np.int64)
    np.cumsum(widths, out=off[1:])
    C = np.empty(int(off[-1]), np.float32)  # D1 needs no more: sums of a few dozen squares
    for i0 in range(r0, r1 + 1, chunk_rows):
        i1 = min(i0 + chunk_rows, r1 + 1)
        block = cost(tube, i0, i1)
        for r in range(i1 - i0):
            w = widths[i0 + r]
            C[off[i0 + r]:off[i0 + r] + w] = block[r, :w]
        if progress is not None:
            progress(0.5 * (i1 - r0) / (r1 + 1 - r0))
    alpha = np.empty(C.shape[0], np.float32)
    shift = np.zeros(band.n)
    inv_t = 1.0 / float(temperature)
    hx = float(horizontal_weight) - 1.0
    held = _held(held_rows, band.n)
    _forward(C, tube.lo, tube.hi, off, r0, r1, inv_t, float(step_penalty), hx, held, alpha, shift)
    if progress is not None:
        progress(0.6)
    nd = band.n + band.m
    s0, s1, s2 = np.zeros(nd), np.zeros(nd), np.zeros(nd)
    nxt = np.full(int(widths[r0:r1 + 1].max()) + 1, -np.inf)
    step = -(-(r1 + 1 - r0) // BACKWARD_PIECES)  # rows per piece (the backward sweep takes seconds on an hour)
    for a in range(r1, r0 - 1, -step):
        b = max(a - step + 1, r0)
        _backward(C, tube.lo, tube.hi, off, r0, r1, a, b, inv_t, float(step_penalty), hx, held, alpha, shift,
                  s0, s1, s2, nxt)
        if progress is not None:
            progress(0.6 + 0.4 * (r1 + 1 - b) / (r1 + 1 - r0))
    mean, std = _rows_from_diagonals(s0, s1, s2, int(path[0, 0] + path[0, 1]), int(path[-1, 0] + path[-1, 1]), band.n)
    return Posterior(mean, std, float(temperature), radius)


def expected_frames(p, *, temperature: float, radius: int, progress=None) -> tuple[np.ndarray, Posterior | None]:
    """A pass's hands frame for each body frame: its expected path, or its best path.

    Parameters
    ----------
    p : PassResult
        The pass (:func:`splicer.align.passes.pass1`): its path, band, local cost and steps.
    temperature : float
        > 0: the expected path over the paths near the best one (:func:`path_posterior`);
        0: the best path alone, each body frame's median hands frame (the paper).
    radius : int
        Columns each side of the best path, see :func:`path_posterior`.
    progress : callable, optional
        ``progress(fraction)``, see :func:`path_posterior`.

    Returns
    -------
    (np.ndarray [shape=(n,)], Posterior or None)
        Non-decreasing where finite, NaN for the body frames the path does not cover.
    """
    if temperature == 0:
        return path_median(p.path, p.band.n), None
    cost = getattr(p, "kept_cost", None) or p.local_cost  # pass 1's kept float32 costs: the tube stores float32
    post = path_posterior(cost, p.band, p.path, temperature=temperature, radius=radius,
                          step_penalty=p.step_penalty, horizontal_weight=p.horizontal_weight,
                          held_rows=getattr(p, "held_rows", None), progress=progress)
    return post.mean, post
