"""Banded dynamic time warping with a stored path (ALGORITHM.md section 2).

Recurrence (0-based, path from ``(0, 0)`` to ``(n - 1, m - 1)``)::

    gamma[0, 0] = c[0, 0]
    gamma[i, j] = c[i, j] + min(gamma[i-1, j-1], gamma[i-1, j] + p, gamma[i, j-1] + p + (h - 1) c[i, j])

(``p = step_penalty``, 0, and ``h = horizontal_weight``, 1, by default: the paper) over the
admissible cells of a :class:`~splicer.band.Band`; cells outside the band are
``+inf``.  Ties are broken deterministically: the diagonal predecessor ``(i-1, j-1)`` is
preferred, then ``(i-1, j)``, then ``(i, j-1)`` (a later candidate wins only if it is
strictly smaller).

Open ends (beyond the paper, ALGORITHM.md section 9; off by default)::

    open begin:  gamma[0, j] = c[0, j] + min(gamma[0, j-1] + p, 0)        (start at any (0, j))
                 gamma[i, 0] = c[i, 0] + min(predecessors, u * i)         (or at any (i, 0))
    open end:    cost = min(min_j gamma[n-1, j], min_i gamma[i, m-1] + u * (n - 1 - i))

A path starting at ``(0, j)`` skips hands frames ``0..j-1`` (free: the hands take started
earlier); one starting at ``(i, 0)`` leaves body rows ``0..i-1`` uncovered (the hands take
started later), at ``u`` (``uncovered_cost``) each, and likewise at the end.  Body rows
beyond the hands take are left uncovered, not held on its first or last frame: no step
``(i-1, 0) -> (i, 0)`` leaves a start cell, and the path cannot end on column ``m - 1``
entered by a step ``(i-1, m-1) -> (i, m-1)``.

Both ends skipped at once (``both_skip_cost`` ``b``, off by default): the takes may also
overlap partly, the hands take starting with extra material *and* after the body's first
frame.  The path may then start at any admissible cell ``(i, j)`` for
``u * i + b * min(j, i)`` and end at any ``(i, j)`` for
``u * (n - 1 - i) + b * min(m - 1 - j, n - 1 - i)``: the hands frames skipped beside uncovered
body rows cost ``b`` each, up to one per uncovered row (the material that could have covered
them); hands frames skipped while every body row is covered stay free.  Any step may leave a
start cell then.  A start wins only if strictly cheaper than every
predecessor, an end only if strictly cheaper than every earlier one (rows, then columns,
in increasing order).  With constraints the path must start at or before the first
constraint's row and end at or after the last one, so every constraint is still honoured.

The compiled loops are in :mod:`splicer.align.kernels`; this module validates and wraps them.

Memory is O(n * band): one byte (uint8 step choice) per band cell, plus two rows of
``gamma`` and, for callable costs, one chunk of local costs.  Time is O(n * band).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .band import Band, Constraint, band_frames, full_band, make_band
from .kernels import _backtrack, _dp_fused, _dp_rows
from ..errors import BandError

__all__ = ["Constraint", "Band", "DTWResult", "make_band", "full_band", "band_frames", "dtw", "dtw_features",
           "end_costs"]

#: float64 cells per chunk of local costs requested from a callable (32 MiB).
CHUNK_CELLS = 1 << 22

_METRICS = {"sqeuclidean": 0, "euclidean": 1}


@dataclass(frozen=True, eq=False)
class DTWResult:
    """Result of a banded DTW.

    Parameters
    ----------
    path : np.ndarray [shape=(K, 2), dtype=int64]
        Cells ``(i, j)`` from ``(0, 0)`` to ``(n - 1, m - 1)`` (open ends: from the first
        covered cell to the last); steps in ``{(1, 0), (0, 1), (1, 1)}``.
    cost : float
        Sum of local costs along the path (``gamma[n-1, m-1]``), not normalised, plus
        ``uncovered_cost`` per uncovered body row with open ends.
    band : Band
        The band the alignment was computed in.
    covered : tuple of int
        ``(first, last)`` body rows the path covers (inclusive); ``(0, n - 1)`` with fixed
        ends.  Rows outside are uncovered (no hands frame matches them).
    open_begin, open_end : bool
        The end conditions the path was computed with.
    uncovered_cost : float
        Penalty per uncovered body row included in ``cost``.
    step_penalty : float
        Penalty per non-diagonal step included in ``cost``.
    horizontal_weight : float
        Weight of the local cost of cells entered by a ``(i, j-1)`` step.
    both_skip_cost : float or None
        Cost per hands frame skipped beside uncovered body rows (starts and ends at any cell),
        included in ``cost``; None: starts on row 0 or column 0 only.
    """

    path: np.ndarray
    cost: float
    band: Band
    covered: tuple | None = None
    open_begin: bool = False
    open_end: bool = False
    uncovered_cost: float = 0.0
    step_penalty: float = 0.0
    horizontal_weight: float = 1.0
    both_skip_cost: float | None = None


# ---------------------------------------------------------------- public wrappers (kernels: .kernels)

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


def end_costs(band: Band, open_begin: bool, open_end: bool, uncovered_cost: float):
    """Per-row start and end costs of an (open-ended) alignment over ``band``.

    Parameters
    ----------
    band : Band
    open_begin, open_end : bool
        Whether the path may start on row 0 or column 0 (end on row ``n - 1`` or column
        ``m - 1``).
    uncovered_cost : float
        Penalty per body row left uncovered (units of the local cost), >= 0.

    Returns
    -------
    start, end : np.ndarray [shape=(n,), dtype=float64]
        ``start[i] = uncovered_cost * i``: the cost of starting in row ``i`` (at column 0
        for ``i > 0``, anywhere in row 0; open begin: rows up to the first constraint's
        row), ``end[i] = uncovered_cost * (n - 1 - i)``: of ending in row ``i`` (at column
        ``m - 1`` for ``i < n - 1``; open end: rows from the last constraint's row on);
        ``+inf`` elsewhere.  Fixed begin: ``start`` is all ``+inf`` (row 0 starts at ``(0, 0)``);
        fixed end: ``end`` is all ``+inf`` (the path ends at ``(n - 1, m - 1)``).

    Raises
    ------
    BandError
        A fixed end the band does not reach.
    ValueError
        ``uncovered_cost`` negative or not finite.
    """
    u = float(uncovered_cost)
    if not (u >= 0 and np.isfinite(u)):
        raise ValueError(f"uncovered_cost must be >= 0 and finite, got {uncovered_cost!r}")
    n = band.n
    if not open_begin and band.lo[0] != 0:
        raise BandError(f"the band does not reach (0, 0) (lo[0] = {band.lo[0]}): use open_begin=True")
    if not open_end and band.hi[-1] != band.m - 1:
        raise BandError(f"the band does not reach (n-1, m-1) = ({n - 1}, {band.m - 1}) "
                        f"(hi[-1] = {band.hi[-1]}): use open_end=True")
    xs = [c.x for c in band.constraints]
    rows = np.arange(n, dtype=np.float64)
    start = np.full(n, np.inf)
    end = np.full(n, np.inf)
    if open_begin:
        last = xs[0] if xs else n - 1         # a path must start at or before the first pin
        start[:last + 1] = u * rows[:last + 1]
    if open_end:
        first = xs[-1] if xs else 0           # and end at or after the last pin
        end[first:] = u * (n - 1 - rows[first:])
    return start, end


def _finish(band, lo, off, steps, rows, best, open_begin, open_end, u, pen=0.0, hw=1.0, bs=-1.0):
    if open_end:
        cost, iend, jend = float(best[0]), int(best[1]), int(best[2])
    else:
        cost, iend, jend = float(rows[(band.n - 1) & 1][band.hi[-1] - band.lo[-1]]), band.n - 1, band.m - 1
    if np.isnan(cost):  # pragma: no cover - NaN costs are rejected before the DP
        raise ValueError("DTW produced a NaN cost")
    if not np.isfinite(cost):
        raise BandError("no path of finite cost exists inside the band (every path crosses a "
                        "+inf local cost)")
    path = _backtrack(lo, off, steps, iend, jend)
    return DTWResult(path=path, cost=cost, band=band, covered=(int(path[0, 0]), int(path[-1, 0])),
                     open_begin=bool(open_begin), open_end=bool(open_end), uncovered_cost=float(u),
                     step_penalty=float(pen), horizontal_weight=float(hw),
                     both_skip_cost=None if bs < 0 else float(bs))


def _penalty(step_penalty) -> float:
    p = float(step_penalty)
    if not (p >= 0 and np.isfinite(p)):
        raise ValueError(f"step_penalty must be >= 0 and finite, got {step_penalty!r}")
    return p


def _hweight(horizontal_weight) -> float:
    w = float(horizontal_weight)
    if not (0.0 < w <= 1.0):
        raise ValueError(f"horizontal_weight must be in (0, 1], got {horizontal_weight!r}")
    return w


def _both_skip(both_skip_cost) -> float:
    """The kernels' ``bs``: -1 (off) for None, else the cost, checked."""
    if both_skip_cost is None:
        return -1.0
    b = float(both_skip_cost)
    if not (b >= 0 and np.isfinite(b)):
        raise ValueError(f"both_skip_cost must be >= 0 and finite (or None), got {both_skip_cost!r}")
    return b


def _held(held_rows, n: int) -> np.ndarray:
    """Per-row held flags for the kernels (uint8): all 0 (the paper) when None; row 0 is never held."""
    if held_rows is None:
        return np.zeros(n, np.uint8)
    h = np.asarray(held_rows)
    if h.shape != (n,) or h.dtype != np.bool_:
        raise ValueError(f"held_rows must be a boolean array of shape ({n},), got {h.dtype} {h.shape}")
    out = h.astype(np.uint8)
    if n:
        out[0] = 0
    return out


def _check_costs(block, what):
    if bool(np.all(block > -np.inf)):  # one pass over the block: False for NaN and for -inf
        return
    if np.isnan(block).any():
        raise ValueError(f"local cost {what} contains NaN")
    raise ValueError(f"local cost {what} contains -inf")


def dtw(cost, band: Band, *, open_begin: bool = False, open_end: bool = False,
        uncovered_cost: float = 0.0, step_penalty: float = 0.0, horizontal_weight: float = 1.0,
        held_rows=None, both_skip_cost: float | None = None) -> DTWResult:
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
        Admissible cells (see :func:`make_band`, :func:`splicer.band.full_band`).
    open_begin : bool, default False
        Beyond the paper (ALGORITHM.md section 9): the path may start at any admissible
        ``(0, j)`` (hands frames before ``j`` are skipped, for free) or ``(i, 0)`` (at or
        before the first constraint's row; body rows before ``i`` are uncovered and cost
        ``uncovered_cost`` each) instead of ``(0, 0)``.
    open_end : bool, default False
        Likewise the path may end at any admissible ``(n - 1, j)`` or ``(i, m - 1)`` (at or
        after the last constraint's row; body rows after ``i`` cost ``uncovered_cost`` each).
    uncovered_cost : float, default 0
        Penalty per uncovered body row, in local-cost units (>= 0); it keeps a shorter
        overlap from winning just for being short.  Unused with fixed ends.
    step_penalty : float, default 0
        Beyond the paper: added to every ``(i-1, j)`` and ``(i, j-1)`` step (local-cost units,
        >= 0), so where the costs are flat (a still arm) the path keeps the current speed
        instead of wandering, and unrelated material is harder to fit by warping.  Included
        in ``cost``.  0 is the paper's recurrence.
    horizontal_weight : float, default 1
        Beyond the paper: a cell entered by a ``(i, j-1)`` step (one more hands frame for the
        same body row) counts this fraction of its local cost, in ``(0, 1]``.  With open ends
        a full weight rewards a path for skipping hands material wherever the hands take is
        slower than the body (each extra hands frame costs a whole cell); 0.3 measures better
        (:data:`splicer.openend.OPEN_HORIZONTAL_WEIGHT`).  1 is the paper's recurrence.
    held_rows : np.ndarray [shape=(n,), dtype=bool], optional
        Beyond the paper: rows where the body holds still (:func:`splicer.align.holds.held_rows`).
        A held row is entered only by a ``(i-1, j)`` step (plus ``step_penalty``), at no
        local cost: the path crosses a hold on one hands frame, as if its rows were not
        there, and the motion around the hold places it.  Row 0 is never held.  None: no
        held row, the paper.
    both_skip_cost : float, optional
        Beyond the paper: with open ends, the path may also start (end) at any admissible cell,
        past both takes' heads (tails) at once (the takes overlap partly): hands frames skipped
        beside uncovered body rows cost this much each, up to one per uncovered row (formula
        in the module notes), in local-cost units (>= 0).  A held row still starts only at
        column 0.  None (default): starts on row 0 or column 0, ends on row ``n - 1`` or column
        ``m - 1``.

    Returns
    -------
    DTWResult
        Optimal path (ties: diagonal, then ``(i-1, j)``, then ``(i, j-1)``, then a start)
        and its cost.

    Raises
    ------
    ValueError
        Wrong cost shape, NaN or ``-inf`` costs.
    BandError
        No path of finite cost exists in the band, or a fixed end the band does not reach.

    Notes
    -----
    O(n * band) time and memory: 1 byte per band cell (uint8 step choices), two rows of
    ``gamma`` and one chunk of costs; the ``n x m`` matrix is never built by the engine.
    Open ends add one pass over each row's cells (the cheapest end) and no memory.
    """
    if not isinstance(band, Band):
        raise TypeError(f"band must be a splicer.dtw.Band, got {type(band).__name__}")
    n, m = band.n, band.m
    sc, ec = end_costs(band, open_begin, open_end, uncovered_cost)
    pen = _penalty(step_penalty)
    hx = _hweight(horizontal_weight) - 1.0
    held = _held(held_rows, n)
    bs = _both_skip(both_skip_cost)
    lo, hi, off, wmax, steps, rows = _workspace(band)
    best = np.array([np.inf, -1.0, -1.0])
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
            _dp_rows(block, False, i0, i1, lo, hi, off, rows, steps, sc, ec, best, pen, hx, held, m, bs)
    else:
        c = np.asarray(cost)
        if c.shape != (n, m):
            raise ValueError(f"cost matrix must have shape (n, m) = ({n}, {m}), got {c.shape}")
        c = np.ascontiguousarray(c, dtype=np.float64)
        _check_costs(c, "matrix")
        _dp_rows(c, True, 0, n, lo, hi, off, rows, steps, sc, ec, best, pen, hx, held, m, bs)
    return _finish(band, lo, off, steps, rows, best, open_begin, open_end, uncovered_cost, pen, hx + 1.0, bs)


def dtw_features(X, Y, band: Band, metric: str = "sqeuclidean", *, open_begin: bool = False,
                 open_end: bool = False, uncovered_cost: float = 0.0, step_penalty: float = 0.0,
                 horizontal_weight: float = 1.0, held_rows=None, both_skip_cost: float | None = None) -> DTWResult:
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
    open_begin, open_end, uncovered_cost, step_penalty, horizontal_weight, held_rows, both_skip_cost
        As :func:`dtw`.

    Returns
    -------
    DTWResult
        As :func:`dtw`; ``cost`` is the sum of local costs along the path (plus the
        uncovered rows' penalty with open ends).

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
    sc, ec = end_costs(band, open_begin, open_end, uncovered_cost)
    pen = _penalty(step_penalty)
    hx = _hweight(horizontal_weight) - 1.0
    held = _held(held_rows, band.n)
    bs = _both_skip(both_skip_cost)
    Xc = np.ascontiguousarray(X)
    Yt = np.ascontiguousarray(Y.T)
    lo, hi, off, wmax, steps, rows = _workspace(band)
    crow = np.empty(wmax)
    best = np.array([np.inf, -1.0, -1.0])
    _dp_fused(Xc, Yt, _METRICS[metric], lo, hi, off, rows, crow, steps, sc, ec, best, pen, hx, held, bs)
    return _finish(band, lo, off, steps, rows, best, open_begin, open_end, uncovered_cost, pen, hx + 1.0, bs)
