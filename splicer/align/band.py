"""Band geometry for banded DTW with user constraints (ALGORITHM.md sections 2-3).

A band is stored as one admissible column interval per row of the first (body)
sequence: ``lo[i] <= j <= hi[i]``.  It never materialises the ``n x m`` matrix:
memory is O(n) here and O(n * band) in the DTW engine (:mod:`splicer.dtw`).

0-based conversion
------------------
ALGORITHM.md states the geometry 1-based, with the virtual anchors ``(x_0, y_0) = (0, 0)``
and ``(x_{l+1}, y_{l+1}) = (n, m)``.  Here frames are 0-based and the anchors are the real
first and last cells, ``(0, 0)`` and ``(n - 1, m - 1)``; constraint pairs ``(x_k, y_k)``
are 0-based frame numbers.  For row ``i`` in segment ``k`` (``x_{k-1} < i <= x_k``; row 0
belongs to segment 1), with ``dx = x_k - x_{k-1}``, ``dy = y_k - y_{k-1}``::

    c(i)    = y_{k-1} + dy * (i - x_{k-1}) / dx           (centre line, passes through anchors)
    Delta_k = W * sqrt(dx**2 + dy**2) / (2 * dx)           (perpendicular width W, in body frames)
    lo(i)   = max(0,     y_{k-1} - T, ceil(c(i) - Delta_k - EPS))
    hi(i)   = min(m - 1, y_k + T,     floor(c(i) + Delta_k + EPS))

With no constraints this is ALGORITHM.md section 2 with the diagonal from ``(0, 0)`` to
``(n - 1, m - 1)``.  ``EPS = 1e-9`` absorbs float rounding of cells exactly on the border.

The one-cell adjustment
-----------------------
The literal formula bounds the constraint row ``x_k`` only from above by ``y_k + T``.  The
next segment starts at ``y_k - T``, so a path may leave row ``x_k`` by a diagonal step
from column ``y_k - T - 1``: it would miss the tolerance by one cell.  The constraint row is
therefore clipped to ``[y_k - T, y_k + T]``, and then *every* path in the band passes
through row ``x_k`` within ``T`` of ``y_k`` (``T = 0``: exactly through ``(x_k, y_k)``).

Finally, cells on no monotone path are dropped (``lo`` becomes its running maximum and
``hi`` its reversed running minimum); this does not change the set of paths and makes
``lo`` and ``hi`` non-decreasing, which the DTW kernels rely on.

A sequence of length 1 (``n == 1``) has a single row; its only path is the whole row
``(0, 0) .. (0, m - 1)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import BandError, ConstraintError
from .band_width import band_frames  # noqa: F401  (re-exported: one place for band widths)

__all__ = ["Constraint", "Band", "band_frames", "make_band", "full_band", "path_band"]

EPS = 1e-9


@dataclass(frozen=True)
class Constraint:
    """A user constraint: body frame ``x`` matches hands frame ``y``.

    Parameters
    ----------
    x : int
        0-based frame of the first (body) sequence.
    y : int
        0-based frame of the second (hands) sequence.
    tolerance : int, default 0
        ``T``, in frames of the second sequence: the path must pass through row ``x``
        at a column within ``[y - T, y + T]``.
    """

    x: int
    y: int
    tolerance: int = 0


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.int64, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Band:
    """Admissible cells of a banded DTW, one column interval per row.

    Parameters
    ----------
    n, m : int
        Lengths of the first (rows) and second (columns) sequence, frames.
    width : float
        ``W``, the band's perpendicular width in frames of the first sequence.
    lo, hi : np.ndarray [shape=(n,), dtype=int64]
        First and last admissible column of each row (inclusive, 0-based).  Both are
        non-decreasing and ``lo[i] <= hi[i-1] + 1`` (consecutive rows connect), and unless
        the band is open, ``lo[0] == 0`` and ``hi[-1] == m - 1``, so a monotone path from
        ``(0, 0)`` to ``(n - 1, m - 1)`` exists.  Stored read-only.
    constraints : tuple of Constraint
        The constraints the band was built for (0-based).
    open_begin, open_end : bool, default False
        Beyond the paper (ALGORITHM.md section 9): the band is meant for an open-ended
        alignment whose path may start (end) at any admissible cell, so ``lo[0]`` need not be
        0 (``hi[-1]`` need not be ``m - 1``).  Every row still has a non-empty, connected
        interval: rows a path leaves uncovered are simply not visited.  A fixed-ends DTW
        (:func:`splicer.dtw.dtw` with ``open_begin=False``) still needs ``lo[0] == 0``
        (``open_end=False``: ``hi[-1] == m - 1``) and says so.

    Notes
    -----
    Memory is O(n); the DTW engine uses O(n * band) (one byte per cell).
    """

    n: int
    m: int
    width: float
    lo: np.ndarray
    hi: np.ndarray
    constraints: tuple = ()
    open_begin: bool = False
    open_end: bool = False

    def __post_init__(self):
        n, m = int(self.n), int(self.m)
        if n < 1 or m < 1:
            raise BandError(f"band needs n >= 1 and m >= 1, got n={n}, m={m}")
        lo, hi = _readonly(self.lo), _readonly(self.hi)
        if lo.shape != (n,) or hi.shape != (n,):
            raise BandError(f"lo and hi must have shape ({n},), got {lo.shape} and {hi.shape}")
        bad = _first_bad_row(lo, hi, m, bool(self.open_begin), bool(self.open_end))
        if bad is not None:
            raise BandError(f"invalid band at row {bad[0]}: {bad[1]}")
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "m", m)
        object.__setattr__(self, "width", float(self.width))
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "constraints", tuple(self.constraints))
        object.__setattr__(self, "open_begin", bool(self.open_begin))
        object.__setattr__(self, "open_end", bool(self.open_end))

    @property
    def n_cells(self) -> int:
        """Number of admissible cells (bytes of the DTW step array)."""
        return int(np.sum(self.hi - self.lo + 1))

    @property
    def max_row_width(self) -> int:
        """Largest number of admissible cells in one row."""
        return int(np.max(self.hi - self.lo + 1))

    def contains(self, i: int, j: int) -> bool:
        """True if cell ``(i, j)`` (0-based) is admissible."""
        return 0 <= i < self.n and bool(self.lo[i] <= j <= self.hi[i])

    def __repr__(self) -> str:
        return (f"Band(n={self.n}, m={self.m}, width={self.width:g}, cells={self.n_cells}, "
                f"max_row_width={self.max_row_width}, constraints={len(self.constraints)}"
                + (", open_begin" if self.open_begin else "") + (", open_end" if self.open_end else "") + ")")


def _first_bad_row(lo, hi, m, open_begin=False, open_end=False):
    """Return ``(row, reason)`` of the first violation of the band invariants, or None."""
    n = lo.shape[0]
    if lo[0] != 0 and not open_begin:
        return 0, f"lo[0] must be 0, got {lo[0]}"
    if hi[n - 1] != m - 1 and not open_end:
        return n - 1, f"hi[{n - 1}] must be m - 1 = {m - 1}, got {hi[n - 1]}"
    for name, arr in (("lo < 0", lo < 0), ("hi > m - 1", hi > m - 1), ("lo > hi", lo > hi)):
        if arr.any():
            return int(np.argmax(arr)), name
    if n > 1:
        for name, arr in (("lo decreases", lo[1:] < lo[:-1]), ("hi decreases", hi[1:] < hi[:-1]),
                          ("lo[i] > hi[i-1] + 1 (rows do not connect)", lo[1:] > hi[:-1] + 1)):
            if arr.any():
                return int(np.argmax(arr)) + 1, name
    return None


def _as_constraints(constraints, n, m):
    out = []
    for k, c in enumerate(constraints):
        if isinstance(c, Constraint):
            x, y, t = c.x, c.y, c.tolerance
        else:
            try:
                vals = tuple(c)
            except TypeError:
                raise ConstraintError(f"constraint #{k}: expected (x, y[, T]), got {c!r}") from None
            if len(vals) not in (2, 3):
                raise ConstraintError(f"constraint #{k}: expected (x, y[, T]), got {c!r}")
            x, y, t = (*vals, 0) if len(vals) == 2 else vals
        for name, v in (("x", x), ("y", y), ("tolerance", t)):
            if isinstance(v, bool) or not float(v).is_integer():
                raise ConstraintError(f"constraint #{k}: {name}={v!r} must be an integer frame")
        x, y, t = int(x), int(y), int(t)
        if t < 0:
            raise ConstraintError(f"constraint #{k} (x={x}, y={y}): tolerance T={t} must be >= 0")
        if not 0 < x < n - 1:
            raise ConstraintError(
                f"constraint #{k} (x={x}, y={y}): body frame x must satisfy 0 < x < n-1 = {n - 1}")
        if not 0 < y < m - 1:
            raise ConstraintError(
                f"constraint #{k} (x={x}, y={y}): hands frame y must satisfy 0 < y < m-1 = {m - 1}")
        if out and not (x > out[-1].x and y >= out[-1].y):
            p = out[-1]
            raise ConstraintError(
                f"constraint #{k} (x={x}, y={y}) does not follow constraint #{k - 1} "
                f"(x={p.x}, y={p.y}): constraints must increase in x and not decrease in y")
        out.append(Constraint(x, y, t))
    return tuple(out)


def _raw_intervals(n, m, width, cons):
    """Literal per-row intervals of ALGORITHM.md sec. 3 plus the constraint-row clip."""
    if n == 1:
        return np.zeros(1, np.int64), np.full(1, m - 1, np.int64)
    xs = [0] + [c.x for c in cons] + [n - 1]
    ys = [0] + [c.y for c in cons] + [m - 1]
    ts = [0] + [c.tolerance for c in cons] + [0]
    lo = np.empty(n, np.int64)
    hi = np.empty(n, np.int64)
    for k in range(1, len(xs)):
        x0, x1, y0, y1 = xs[k - 1], xs[k], ys[k - 1], ys[k]
        dx, dy = x1 - x0, y1 - y0
        delta = width * math.sqrt(dx * dx + dy * dy) / (2.0 * dx)
        first = 0 if k == 1 else x0 + 1
        rows = np.arange(first, x1 + 1, dtype=np.int64)
        c = y0 + (dy * (rows - x0)) / dx
        lo[first:x1 + 1] = np.maximum(max(0, y0 - ts[k - 1]), np.ceil(c - delta - EPS))
        hi[first:x1 + 1] = np.minimum(min(m - 1, y1 + ts[k]), np.floor(c + delta + EPS))
        if k < len(xs) - 1:                        # a user constraint, not the end anchor:
            lo[x1] = max(lo[x1], y1 - ts[k])      # the one-cell adjustment (module docstring)
    return lo, hi


def _trim(lo, hi):
    return np.maximum.accumulate(lo), np.minimum.accumulate(hi[::-1])[::-1].copy()


def _disconnected_row(n, m, width, cons):
    """First row ``i`` where no path continues (None if the band connects)."""
    lo, hi = _raw_intervals(n, m, width, cons)
    r = np.maximum.accumulate(lo)                  # first reachable column of each row
    limit = hi.copy()
    limit[1:] = np.minimum(hi[1:], hi[:-1] + 1)
    bad = r > limit
    if lo[0] != 0:
        return 0
    if bad.any():
        return int(np.argmax(bad))
    return None


def _WIDEST(n, m):
    # Delta >= W / 2 >= n + m: every column within the tolerance clips is admissible
    return 2.0 * (n + m) + 2.0


def _min_width(n, m, width, cons):
    """Smallest W (to float precision) for which the band connects, by bisection."""
    a, b = float(width), _WIDEST(n, m)             # a fails, b works (checked by caller)
    for _ in range(200):
        mid = 0.5 * (a + b)
        if mid <= a or mid >= b:
            break
        if _disconnected_row(n, m, mid, cons) is None:
            b = mid
        else:
            a = mid
    return b


def make_band(n: int, m: int, width: float, constraints=()) -> Band:
    """Build the constrained DTW band (ALGORITHM.md sections 2-3, 0-based; see module doc).

    Parameters
    ----------
    n, m : int
        Lengths of the first (body) and second (hands) sequence, frames (>= 1).
    width : float
        ``W``, perpendicular band width in frames of the first sequence (see
        :func:`band_frames` for percentages and seconds).
    constraints : sequence of Constraint or (x, y[, T]) tuples
        0-based frame pairs, strictly increasing in ``x`` and non-decreasing in ``y`` (a path
        may hold one hands frame over several body frames), with
        ``0 < x < n - 1`` and ``0 < y < m - 1``.  The endpoints are implicit.

    Returns
    -------
    Band
        Every path inside it is monotone from ``(0, 0)`` to ``(n - 1, m - 1)`` and passes
        through row ``x_k`` within ``T_k`` columns of ``y_k`` for every constraint.  O(n) memory.

    Raises
    ------
    ConstraintError
        Malformed, out-of-range or non-increasing constraints, negative tolerance.
    BandError
        The band cannot connect; the message names the segment and the smallest ``W`` that
        connects (also in the exception's ``min_width`` and ``segment`` attributes).
    """
    for name, v in (("n", n), ("m", m)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise BandError(f"{name} must be an integer >= 1, got {v!r}")
    n, m = int(n), int(m)
    try:
        width = float(width)
    except (TypeError, ValueError):
        raise BandError(f"band width must be a number of frames, got {width!r}") from None
    if not (width > 0 and math.isfinite(width)):
        raise BandError(f"band width must be positive and finite, got {width!r} frames")
    cons = _as_constraints(constraints, n, m)
    bad = _disconnected_row(n, m, width, cons)
    if bad is not None and _disconnected_row(n, m, _WIDEST(n, m), cons) is not None:
        # no width helps: two constraints on adjacent body frames too far apart in y
        for k in range(1, len(cons)):
            p, c = cons[k - 1], cons[k]
            if c.x == p.x + 1 and (c.y - c.tolerance) - (p.y + p.tolerance) > 1:
                err = ConstraintError(
                    f"constraints #{k - 1} (x={p.x}, y={p.y}, T={p.tolerance}) and #{k} "
                    f"(x={c.x}, y={c.y}, T={c.tolerance}) are infeasible: adjacent body frames "
                    f"cannot match hands frames more than T + T' + 1 apart")
                err.pair = (k - 1, k)
                raise err
        raise ConstraintError("the constraints cannot be satisfied by any band width")  # pragma: no cover
    if bad is not None:
        wmin = _min_width(n, m, width, cons)
        xs = [c.x for c in cons]
        k = int(np.searchsorted(xs, bad, side="left"))      # segment k: x_{k-1} < bad <= x_k
        start = "the start (0, 0)" if k == 0 else (
            f"constraint #{k - 1} (x={cons[k - 1].x}, y={cons[k - 1].y})")
        end = f"the end ({n - 1}, {m - 1})" if k == len(cons) else (
            f"constraint #{k} (x={cons[k].x}, y={cons[k].y})")
        err = BandError(
            f"a band of width W={width:g} frames cannot connect the segment between {start} and "
            f"{end} (at body frame {bad}); the smallest width that connects the band is "
            f"W={math.ceil(wmin * 1000) / 1000:g} frames")
        err.min_width = wmin
        err.segment = k
        raise err
    lo, hi = _trim(*_raw_intervals(n, m, width, cons))
    return Band(n=n, m=m, width=width, lo=lo, hi=hi, constraints=cons)


def full_band(n: int, m: int, constraints=(), *, open_begin: bool = True, open_end: bool = True) -> Band:
    """Every cell admissible, except where a constraint narrows its row (beyond the paper).

    For open-ended alignments of short or coarse sequences, where the offset is unknown.

    Parameters
    ----------
    n, m : int
        Lengths of the first (body) and second (hands) sequence, frames (>= 1).
    constraints : sequence of Constraint or (x, y[, T]) tuples
        As :func:`make_band`: row ``x`` is clipped to ``[y - T, y + T]``.
    open_begin, open_end : bool
        Recorded on the band (see :class:`Band`).

    Returns
    -------
    Band
        ``width`` is ``inf``; O(n) memory, but the DTW over it stores ``n * m`` bytes.
    """
    for name, v in (("n", n), ("m", m)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise BandError(f"{name} must be an integer >= 1, got {v!r}")
    n, m = int(n), int(m)
    cons = _as_constraints(constraints, n, m)
    lo = np.zeros(n, np.int64)
    hi = np.full(n, m - 1, np.int64)
    for c in cons:
        lo[c.x] = max(lo[c.x], c.y - c.tolerance, 0)
        hi[c.x] = min(hi[c.x], c.y + c.tolerance, m - 1)
    lo, hi = _trim(lo, hi)
    return Band(n=n, m=m, width=math.inf, lo=lo, hi=hi, constraints=cons, open_begin=open_begin,
                open_end=open_end)


def path_band(path: np.ndarray, n: int, m: int) -> Band:
    """The narrowest open band holding a monotone path: each row its path cells' columns.

    Rows before the path's first row hold its first column, rows after its last row its last
    column, so every row has a cell (the band invariants) and the path's cells are exactly the
    band's cells in the rows it visits.

    Parameters
    ----------
    path : np.ndarray [shape=(K, 2), dtype=int]
        (row, column) cells, rows and columns non-decreasing, steps of at most one in each.
    n, m : int
        The matrix's rows and columns.

    Examples
    --------
    >>> b = path_band(np.array([[1, 0], [1, 1], [2, 2], [3, 2]]), 5, 4)
    >>> b.lo.tolist(), b.hi.tolist()
    ([0, 0, 2, 2, 2], [0, 1, 2, 2, 2])
    """
    path = np.asarray(path, dtype=np.int64)
    if path.ndim != 2 or path.shape[1] != 2 or len(path) == 0:
        raise BandError("path_band needs a non-empty (K, 2) path")
    ii, jj = path[:, 0], path[:, 1]
    if ii.min() < 0 or ii.max() >= n or jj.min() < 0 or jj.max() >= m:
        raise BandError(f"path_band: the path leaves the {n} x {m} matrix")
    lo = np.full(n, m, np.int64)
    hi = np.full(n, -1, np.int64)
    np.minimum.at(lo, ii, jj)
    np.maximum.at(hi, ii, jj)
    first, last = int(ii[0]), int(ii[-1])
    lo[:first] = hi[:first] = jj[0]
    lo[last + 1:] = hi[last + 1:] = jj[-1]
    return Band(n=n, m=m, width=1.0, lo=lo, hi=hi, open_begin=True, open_end=True)
