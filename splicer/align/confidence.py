"""Per-frame confidence of an alignment from its cost landscape (ALGORITHM.md section 9).

Forward and backward accumulated costs over the band give, for every admissible cell, the
cost of the best path forced through it::

    through[i, j] = fwd[i, j] + bwd[i, j]

``fwd`` is the engine's recurrence (:mod:`splicer.dtw`, with the same start costs, step
penalty, horizontal weight and open-begin rule): the cheapest prefix ending at ``(i, j)``,
its own cost included; ``bwd`` is the mirror recurrence from the ends backwards (the end
costs play the start costs' part): the cheapest suffix from ``(i, j)``, its own cost
excluded (with the paper's recurrence, ``bwd = fwd`` on the reversed band and costs, minus
``c[i, j]``).  ``min_j through[i, j]`` is the optimal cost for every row the
optimal path covers.  The *excess* ``through[i, j] - optimum`` says how much worse the
alignment becomes when row ``i`` is forced to hands frame ``j``: it rises fast away from the
chosen cell where the row is well determined, and stays flat where it is not (a still arm,
a pause, a repeated gesture).

Per body row ``i`` (covered by the path), with ``tau`` the excess threshold:

* ``near = {j : excess[i, j] <= tau}`` (always contains the path's cells of row ``i``);
* ``spread_frames[i] = max(near) - min(near)`` (hands frames, 0 when only one cell);
* ``est_error_s[i] = max_{j in near} |j - jc[i]| / fps``, ``jc`` the median of the path's
  columns in that row: how far an alternative alignment almost as good as the chosen one
  puts this frame;
* ``confidence[i] = 1 / (1 + (est_error_s[i] / error_scale_s) ** 2)``: 1 for an exactly
  determined frame, 0.5 at ``error_scale_s`` (default 0.1 s, the finger-to-body
  desynchronisation viewers notice), towards 0 beyond.

Rows the path leaves uncovered get ``spread_frames = est_error_s = NaN`` and
``confidence = 0``.

``tau = threshold * median(local cost along the path)``: an alternative is "almost as good"
when it costs at most ``threshold`` typical path cells more in total.

Memory: O(n + band) plus at most :data:`KEEP_COST_BYTES` of local costs, whatever the
number of band cells: the local, forward and backward costs exist one block of rows at a
time.  The forward costs survive the first sweep as one checkpoint row per block and are
recomputed, block by block from the end, while the backward sweep runs, so each row's
statistics are taken as soon as both of its costs exist; local costs beyond the budget are
computed again in the second sweep (the forward and backward values are stored relative to
their row minimum as float32, which keeps their differences to about 1e-3 of a cost unit;
:func:`through_costs`, for tests and plots, keeps all three arrays, 12 bytes per cell).
Time O(n * band): about two DTW passes plus one more forward sweep, and the local costs
computed twice where they exceed the budget.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .confidence_kernels import _backward, _backward_rows, _forward, _forward_rows, _row_stats
from .paths import path_median
from .dtw import CHUNK_CELLS, Band, end_costs

__all__ = ["Confidence", "row_confidence", "pass_confidence", "posterior_confidence", "through_costs", "CONFIDENCE_THRESHOLD"]

#: Default excess threshold, in units of the median local cost along the path.
CONFIDENCE_THRESHOLD = 1.0

#: :func:`row_confidence` keeps the local, forward and backward costs of this many band cells
#: at a time (4 MiB each as float32); the rest of the forward pass survives as one float64 row
#: per block (a checkpoint) and is recomputed block by block during the backward pass.  (Blocks
#: of :data:`CHUNK_CELLS` cells, 4x larger, measured 80-100 MB more at the peak of the 20-minute
#: pair.)
BLOCK_CELLS = 1 << 20
#: :func:`row_confidence` keeps the blocks' local costs (float32) up to this many bytes between
#: its two sweeps and computes the others twice (a long pair with a wide band: more time, no more
#: memory; below about 67 million band cells nothing is computed twice).
KEEP_COST_BYTES = 256 << 20


@dataclass(frozen=True, eq=False)
class Confidence:
    """Per-body-frame reliability of an alignment.

    Attributes
    ----------
    spread_frames : np.ndarray [shape=(n,), dtype=float64]
        How far alignments almost as good as the chosen one spread, hands frames (at the
        alignment's rate): the range whose forced-path cost is within ``threshold`` of the
        optimum (:func:`row_confidence`), or the expected path's standard deviation
        (:func:`posterior_confidence`); NaN where uncovered.
    est_error_s : np.ndarray [shape=(n,), dtype=float64]
        Estimated alignment error, seconds; NaN where uncovered.
    confidence : np.ndarray [shape=(n,), dtype=float64]
        In [0, 1]; 0 where uncovered, 0.5 at ``error_scale_s``.
    threshold : float
        The excess threshold ``tau`` used (:func:`row_confidence`) or the posterior's
        temperature (:func:`posterior_confidence`), local-cost units.
    error_scale_s : float
        Seconds of estimated error at which confidence is 0.5.
    row_excess : np.ndarray [shape=(n,), dtype=float64] or None
        Per body frame, how much dearer the best alignment that covers it is than the
        optimum (local-cost units; 0 on covered frames, ``+inf`` where no path reaches).
        An uncovered frame with ``row_excess <= threshold`` could almost as well be covered:
        after an open-ended locating pass, the overlap's place is ambiguous there
        (:meth:`ambiguous`).
    """

    spread_frames: np.ndarray
    est_error_s: np.ndarray
    confidence: np.ndarray
    threshold: float
    error_scale_s: float
    row_excess: np.ndarray | None = None
    #: per body frame, seconds of hands time between this side's time map and the other
    #: side's (:meth:`with_disagreement`); None when not compared
    disagreement_s: np.ndarray | None = None
    #: per body frame, the estimated error from the spread and the disagreement alone (seconds),
    #: kept when :meth:`with_estimate` replaced ``est_error_s``; None otherwise
    evidence_error_s: np.ndarray | None = None

    def with_disagreement(self, disagreement_s: np.ndarray) -> "Confidence":
        """This confidence with the other side's verdict folded in.

        Both hands come from one hands take, so their time maps should agree: where they
        are ``d`` seconds apart, at least one of them is off, and the estimated error of
        each becomes ``max(est_error_s, d)`` (frames where either side is uncovered, NaN in
        ``disagreement_s``, keep their own estimate; uncovered frames stay NaN).
        ``confidence`` is recomputed from it with the same ``error_scale_s``.
        """
        d = np.asarray(disagreement_s, dtype=np.float64)
        if d.shape != self.est_error_s.shape:
            raise ValueError(f"disagreement_s must have shape {self.est_error_s.shape}, got {d.shape}")
        est = np.where(np.isfinite(self.est_error_s) & np.isfinite(d), np.fmax(self.est_error_s, d),
                       self.est_error_s)
        return Confidence(spread_frames=self.spread_frames, est_error_s=est,
                          confidence=_confidence_of(est, self.error_scale_s), threshold=self.threshold,
                          error_scale_s=self.error_scale_s, row_excess=self.row_excess, disagreement_s=d)

    def with_estimate(self, est_error_s: np.ndarray) -> "Confidence":
        """This confidence with ``est_error_s`` replaced (frames uncovered here stay NaN; the
        previous estimate kept as ``evidence_error_s``); ``confidence`` recomputed with the same
        ``error_scale_s``."""
        e = np.asarray(est_error_s, dtype=np.float64)
        if e.shape != self.est_error_s.shape:
            raise ValueError(f"est_error_s must have shape {self.est_error_s.shape}, got {e.shape}")
        est = np.where(np.isfinite(self.est_error_s), e, np.nan)
        if not bool(np.all(np.isfinite(est) == np.isfinite(self.est_error_s))) or bool(np.any(est < 0)):
            raise ValueError("est_error_s must be finite and >= 0 on every covered frame")
        return replace(self, est_error_s=est, confidence=_confidence_of(est, self.error_scale_s),
                       evidence_error_s=self.est_error_s)

    def uncovered_at(self, where: np.ndarray) -> "Confidence":
        """This confidence with the frames of the boolean mask ``where`` uncovered: NaN in
        ``spread_frames``, ``est_error_s``, ``confidence`` and the per-frame signals kept beside
        them (``disagreement_s``, ``evidence_error_s``)."""
        w = np.asarray(where)
        if w.shape != self.est_error_s.shape or w.dtype != bool:
            raise ValueError(f"where must be a boolean mask of shape {self.est_error_s.shape}, got {w.dtype} {w.shape}")

        def nan_at(a):
            return None if a is None else np.where(w, np.nan, np.asarray(a, dtype=np.float64))

        return replace(self, spread_frames=nan_at(self.spread_frames), est_error_s=nan_at(self.est_error_s),
                       confidence=nan_at(self.confidence), disagreement_s=nan_at(self.disagreement_s),
                       evidence_error_s=nan_at(self.evidence_error_s))

    def with_floor(self, error_s: float, where: np.ndarray | None = None) -> "Confidence":
        """This confidence with every covered frame's estimated error (or only those where the
        boolean mask ``where`` is true) at least ``error_s`` seconds (uncovered frames stay NaN);
        ``confidence`` recomputed with the same ``error_scale_s``."""
        f = float(error_s)
        if not (f >= 0.0 and np.isfinite(f)):
            raise ValueError(f"error_s must be >= 0 and finite, got {error_s!r}")
        apply = np.isfinite(self.est_error_s)
        if where is not None:
            w = np.asarray(where)
            if w.shape != apply.shape or w.dtype != bool:
                raise ValueError(f"where must be a boolean mask of shape {apply.shape}, got {w.dtype} {w.shape}")
            apply = apply & w
        est = np.where(apply, np.fmax(self.est_error_s, f), self.est_error_s)
        return replace(self, est_error_s=est, confidence=_confidence_of(est, self.error_scale_s))

    def ambiguous(self) -> np.ndarray:
        """Boolean mask (n,): uncovered frames an alignment within ``threshold`` of the optimum
        covers (an alternative place for the overlap)."""
        if self.row_excess is None:
            return np.zeros(self.confidence.shape, dtype=bool)
        return ~np.isfinite(self.est_error_s) & (self.row_excess <= self.threshold)

    def low(self, max_error_s: float | None = None) -> np.ndarray:
        """Boolean mask (n,): covered frames whose estimated error exceeds ``max_error_s``
        (default ``error_scale_s``), i.e. confidence below 0.5."""
        lim = self.error_scale_s if max_error_s is None else max_error_s
        e = self.est_error_s
        return np.isfinite(e) & (e > lim)


def _confidence_of(est_error_s: np.ndarray, error_scale_s: float) -> np.ndarray:
    """``1 / (1 + (est / scale)^2)``; 0 where the estimate is NaN (uncovered)."""
    e = np.asarray(est_error_s, dtype=np.float64)
    return np.where(np.isfinite(e), 1.0 / (1.0 + (np.nan_to_num(e) / error_scale_s) ** 2), 0.0)


# ---------------------------------------------------------------- kernels (private, dumb)


# ---------------------------------------------------------------- public

def _gather_rows(cost, band: Band, off: np.ndarray, i0: int, i1: int) -> np.ndarray:
    """Local costs of the band cells of rows ``i0 .. i1-1``, flat float32 (row i at
    ``off[i] - off[i0]``); a callable is asked for at most :data:`CHUNK_CELLS` cells at a time."""
    widths = band.hi - band.lo + 1
    flat = np.empty(int(off[i1] - off[i0]), dtype=np.float32)
    base = int(off[i0])
    if callable(cost):
        wmax = band.max_row_width
        chunk = max(1, CHUNK_CELLS // wmax)
        for a in range(i0, i1, chunk):
            b = min(i1, a + chunk)
            block = np.asarray(cost(a, b))
            if block.ndim != 2 or block.shape[0] != b - a or block.shape[1] < wmax:
                raise ValueError(f"cost({a}, {b}) must return shape ({b - a}, >= {wmax}), got {block.shape}")
            w = widths[a:b]
            if w.min() == w.max():  # rows of one width (most of a band): no boolean mask
                flat[off[a] - base:off[b] - base] = block[:, :w[0]].reshape(-1)
            else:
                flat[off[a] - base:off[b] - base] = block[np.arange(block.shape[1])[None, :] < w[:, None]]
    else:
        c = np.asarray(cost, dtype=np.float64)
        if c.shape != (band.n, band.m):
            raise ValueError(f"cost matrix must have shape (n, m) = ({band.n}, {band.m}), got {c.shape}")
        for i in range(i0, i1):
            flat[off[i] - base:off[i + 1] - base] = c[i, band.lo[i]:band.hi[i] + 1]
    if not bool(np.all(flat > -np.inf)):  # one pass: False for NaN and for -inf
        raise ValueError("local costs contain NaN or -inf")
    return flat


def _gather(cost, band: Band, off: np.ndarray) -> np.ndarray:
    """Local costs of every band cell, flat float32 (row i at off[i] .. off[i+1]-1)."""
    return _gather_rows(cost, band, off, 0, band.n)


def _recurrence(band: Band, open_begin, open_end, uncovered_cost, step_penalty, horizontal_weight):
    """Validated end conditions of the recurrence: ``(sc, ec, ob, oe, pen, hw)``."""
    ob = band.open_begin if open_begin is None else bool(open_begin)
    oe = band.open_end if open_end is None else bool(open_end)
    sc, ec = end_costs(band, ob, oe, uncovered_cost)
    pen = float(step_penalty)
    if not (pen >= 0 and np.isfinite(pen)):
        raise ValueError(f"step_penalty must be >= 0 and finite, got {step_penalty!r}")
    hw = float(horizontal_weight)
    if not 0.0 < hw <= 1.0:
        raise ValueError(f"horizontal_weight must be in (0, 1], got {horizontal_weight!r}")
    return sc, ec, ob, oe, pen, hw


def _blocked_row_stats(cost, band: Band, off, path, sc, ec, ob, oe, pen, hx, path_optimum, jc, spread, err, exmin):
    """``_row_stats`` of every row without whole forward, backward or local-cost arrays.

    Sweep 1 gathers the local costs block by block of rows (:data:`BLOCK_CELLS` cells), runs
    the forward recurrence, keeps its float64 state at the start of each block and the local
    costs along the path, and keeps blocks' local costs while they fit in
    :data:`KEEP_COST_BYTES`.  ``path_optimum(local) -> (optimum, tau)`` then gives the
    thresholds.  Blocks the cost serves from a copy (``cost.cached(i0, i1)``, pass 1's
    :class:`splicer.align.costcache.CachedBandCost`) are not kept again, and the copy's bytes
    (``cost.kept_bytes``) count against :data:`KEEP_COST_BYTES`.  Sweep 2 walks the blocks from the last, takes the block's local costs (kept,
    else gathered again: the same values), recomputes its forward costs from the checkpoint
    (the same arithmetic, so the same float32 values as one full sweep), runs the backward
    recurrence from the state the later block left and takes the rows' statistics.  Fills
    ``spread``, ``err``, ``exmin`` in place.
    """
    n = band.n
    cached = getattr(cost, "cached", None) or (lambda i0, i1: False)  # rows the cost serves from a copy
    lo = np.ascontiguousarray(band.lo, np.int64)
    hi = np.ascontiguousarray(band.hi, np.int64)
    wmax = int(np.max(hi - lo + 1))
    rows = max(1, min(n, BLOCK_CELLS // wmax))
    starts = list(range(0, n, rows))
    ck_prev = np.empty((len(starts), wmax))
    ck_pst = np.empty((len(starts), wmax), np.bool_)
    prev = np.full(wmax, np.inf)
    pst = np.zeros(wmax, np.bool_)
    fmin = np.empty(n)
    bmin = np.empty(n)
    fbuf = np.empty(rows * wmax, np.float32)
    bbuf = np.empty(rows * wmax, np.float32)
    prow = path[:, 0]
    local = np.empty(len(path), np.float32)
    kept: dict[int, np.ndarray] = {}
    room = KEEP_COST_BYTES - int(getattr(cost, "kept_bytes", 0))  # with pass 1's copy: no more cost memory in all
    for b, i0 in enumerate(starts):
        i1 = min(n, i0 + rows)
        cb = _gather_rows(cost, band, off, i0, i1)
        pa, pb = np.searchsorted(prow, [i0, i1])
        r = prow[pa:pb]
        local[pa:pb] = cb[off[r] - off[i0] + path[pa:pb, 1] - lo[r]]
        ck_prev[b] = prev
        ck_pst[b] = pst
        _forward_rows(cb, lo, hi, off, sc, ob, pen, hx, i0, i1, prev, pst, fbuf, off[i0], fmin)
        if cb.nbytes <= room and not cached(i0, i1):
            kept[b] = cb
            room -= cb.nbytes
    optimum, tau = path_optimum(local.astype(np.float64))
    nxt = np.full(wmax, np.inf)
    nst = np.zeros(wmax, np.bool_)
    after = np.zeros(0, np.float32)  # the local costs of the row after the block (none after the last)
    for b in range(len(starts) - 1, -1, -1):
        i0, i1 = starts[b], min(n, starts[b] + rows)
        cb = kept.pop(b) if b in kept else _gather_rows(cost, band, off, i0, i1)
        c = np.concatenate([cb, after]) if after.size else cb
        after = cb[:off[i0 + 1] - off[i0]].copy()
        prev[:] = ck_prev[b]
        pst[:] = ck_pst[b]
        _forward_rows(c, lo, hi, off, sc, ob, pen, hx, i0, i1, prev, pst, fbuf, off[i0], fmin)
        _backward_rows(c, lo, hi, off, ec, oe, pen, hx, band.m, i0, i1, nxt, nst, bbuf, off[i0], bmin)
        _row_stats(fbuf, fmin[i0:i1], bbuf, bmin[i0:i1], lo[i0:i1], hi[i0:i1], off[i0:i1 + 1] - off[i0], optimum,
                   tau, jc[i0:i1], spread[i0:i1], err[i0:i1], exmin[i0:i1])
    return optimum, tau


def through_costs(cost, band: Band, *, open_begin: bool | None = None, open_end: bool | None = None,
                  uncovered_cost: float = 0.0, step_penalty: float = 0.0, horizontal_weight: float = 1.0):
    """Forward and backward accumulated costs over the band (see module docstring).

    Parameters
    ----------
    cost : np.ndarray [shape=(n, m)] or callable
        As :func:`splicer.dtw.dtw`.
    band : Band
    open_begin, open_end : bool, optional
        End conditions (default: the band's ``open_begin`` / ``open_end``).
    uncovered_cost, step_penalty, horizontal_weight : float
        As in :func:`splicer.dtw.dtw`.

    Returns
    -------
    through : callable ``(i) -> (columns, values)``
        The forced-path cost of each admissible cell of row ``i`` (float64, ``+inf`` where no
        path passes).  For tests and plots; :func:`row_confidence` does not build it.
    parts : tuple
        ``(c, fwd, fmin, bwd, bmin, off)``: flat float32 local, forward (relative to ``fmin``)
        and backward (relative to ``bmin``) costs and the row offsets.
    """
    sc, ec, ob, oe, pen, hw = _recurrence(band, open_begin, open_end, uncovered_cost, step_penalty,
                                          horizontal_weight)
    n = band.n
    widths = band.hi - band.lo + 1
    off = np.zeros(n + 1, np.int64)
    np.cumsum(widths, out=off[1:])
    c = _gather(cost, band, off)
    lo = np.ascontiguousarray(band.lo, np.int64)
    hi = np.ascontiguousarray(band.hi, np.int64)
    fwd = np.empty_like(c)
    fmin = np.empty(n)
    _forward(c, lo, hi, off, sc, ob, pen, hw - 1.0, fwd, fmin)
    bwd = np.empty_like(c)
    bmin = np.empty(n)
    _backward(c, lo, hi, off, ec, oe, pen, hw - 1.0, band.m, bwd, bmin)

    def through(i):
        f = fwd[off[i]:off[i + 1]].astype(np.float64) + fmin[i]
        b = bwd[off[i]:off[i + 1]].astype(np.float64) + bmin[i]
        return np.arange(band.lo[i], band.hi[i] + 1), f + b

    return through, (c, fwd, fmin, bwd, bmin, off)


def row_confidence(cost, band: Band, path: np.ndarray, fps: float, *, open_begin: bool | None = None,
                   open_end: bool | None = None, uncovered_cost: float = 0.0, step_penalty: float = 0.0,
                   horizontal_weight: float = 1.0, threshold: float = CONFIDENCE_THRESHOLD,
                   error_scale_s: float = 0.1) -> Confidence:
    """Per-body-frame spread, estimated error and confidence of an alignment.

    Parameters
    ----------
    cost : np.ndarray [shape=(n, m)] or callable
        The local costs the path was computed on, as :func:`splicer.dtw.dtw` takes them.
    band : Band
        The band the path was computed in.
    path : np.ndarray [shape=(K, 2), dtype=int64]
        The optimal path (e.g. :attr:`splicer.dtw.DTWResult.path`).
    fps : float
        Frame rate of the columns (hands frames at the alignment's rate), frames per second.
    open_begin, open_end : bool, optional
        End conditions of the alignment (default: the band's flags).
    uncovered_cost, step_penalty, horizontal_weight : float
        Penalties and weight the alignment used (:func:`splicer.dtw.dtw`).
    threshold : float
        Excess threshold in units of the median local cost along the path (> 0).
    error_scale_s : float
        Estimated error (seconds) at which confidence is 0.5 (> 0).

    Returns
    -------
    Confidence
        Arrays of shape (n,).

    Notes
    -----
    O(n + BLOCK_CELLS) memory plus at most :data:`KEEP_COST_BYTES` of kept local costs
    (the others are computed twice); O(n * band) time.
    """
    if not (fps > 0 and np.isfinite(fps)):
        raise ValueError(f"fps must be positive and finite, got {fps!r}")
    if not (threshold > 0 and np.isfinite(threshold)):
        raise ValueError(f"threshold must be positive and finite, got {threshold!r}")
    if not (error_scale_s > 0 and np.isfinite(error_scale_s)):
        raise ValueError(f"error_scale_s must be positive and finite, got {error_scale_s!r}")
    path = np.asarray(path, dtype=np.int64)
    if path.ndim != 2 or path.shape[1] != 2 or path.shape[0] < 1:
        raise ValueError(f"path must have shape (K, 2), got {path.shape}")
    n = band.n
    sc, ec, ob, oe, pen, hw = _recurrence(band, open_begin, open_end, uncovered_cost, step_penalty,
                                          horizontal_weight)
    off = np.zeros(n + 1, np.int64)
    np.cumsum(band.hi - band.lo + 1, out=off[1:])
    covered = (int(path[0, 0]), int(path[-1, 0]))
    d = np.diff(path, axis=0)
    bends = int(np.count_nonzero((d[:, 0] == 0) | (d[:, 1] == 0)))
    weight = np.ones(len(path))
    weight[1:][d[:, 0] == 0] = float(horizontal_weight)       # cells entered by a (i, j-1) step

    def path_optimum(local):
        """The path's own cost (local costs along it plus its uncovered rows) and the threshold."""
        optimum = (float(np.sum(weight * local)) + float(uncovered_cost) * (covered[0] + (n - 1 - covered[1]))
                   + float(step_penalty) * bends)
        return optimum, float(threshold) * max(float(np.median(local)), 1e-12)

    jc = path_median(path, n)
    spread = np.full(n, np.nan)
    err = np.full(n, np.nan)
    exmin = np.full(n, np.inf)
    _, tau = _blocked_row_stats(cost, band, off, path, sc, ec, ob, oe, pen, hw - 1.0, path_optimum, jc, spread, err,
                                exmin)
    est = err / float(fps)
    conf = _confidence_of(est, error_scale_s)
    return Confidence(spread_frames=spread, est_error_s=est, confidence=conf, threshold=tau,
                      error_scale_s=float(error_scale_s), row_excess=np.maximum(exmin, 0.0))


class _PassRows:
    """``(i0, i1) -> rows i0 + shift .. i1 - 1 + shift`` of a pass's band-chunk cost; ``cached(i0, i1)``
    says whether those rows come from pass 1's kept copy (:mod:`splicer.align.costcache`)."""

    def __init__(self, cost, band: Band, shift: int):
        self.cost, self.band, self.shift = cost, band, shift

    def __call__(self, i0: int, i1: int) -> np.ndarray:
        return self.cost(self.band, i0 + self.shift, i1 + self.shift)

    def cached(self, i0: int, i1: int) -> bool:
        covers = getattr(self.cost, "covers", None)
        return covers is not None and covers(self.band, i0 + self.shift, i1 + self.shift)

    @property
    def kept_bytes(self) -> int:
        return int(getattr(self.cost, "kept_bytes", 0))


def pass_confidence(result, fps: float, **kwargs) -> Confidence:
    """:func:`row_confidence` of a :class:`splicer.align.PassResult` (its band, path, costs, ends).

    ``fps``: the rate of the pass's columns (the body rate for pass 1 and 2).  Keyword
    arguments go to :func:`row_confidence` (``threshold``, ``error_scale_s``).  A pass with
    fixed ends over a covered span (pass 2 after an open-ended pass 1) is measured on that
    span; the frames outside get confidence 0 and NaN errors.
    """
    if result.local_cost is None:
        raise ValueError(f"{result.name} has no local cost to measure confidence on")
    band = result.band
    n = band.n
    cost = getattr(result, "kept_cost", None) or result.local_cost  # pass 1's kept float32 costs: the same values
    cov = getattr(result, "covered", None) or (0, n - 1)
    if getattr(result, "ends", "fixed") == "open" or tuple(cov) == (0, n - 1):
        return row_confidence(_PassRows(cost, band, 0), band, result.path, fps,
                              uncovered_cost=getattr(result, "uncovered_cost", 0.0),
                              step_penalty=getattr(result, "step_penalty", 0.0),
                              horizontal_weight=getattr(result, "horizontal_weight", 1.0), **kwargs)
    a, b = int(cov[0]), int(cov[1])
    # the span's own fixed-ends problem: rows a..b, columns shifted by the path's first column
    c0 = int(result.path[0, 1])
    sub = Band(n=b - a + 1, m=int(result.path[-1, 1]) - c0 + 1, width=band.width,
               lo=band.lo[a:b + 1] - c0, hi=band.hi[a:b + 1] - c0)
    conf = row_confidence(_PassRows(cost, band, a), sub,
                          result.path - np.array([a, c0]), fps, step_penalty=getattr(result, "step_penalty", 0.0),
                          horizontal_weight=getattr(result, "horizontal_weight", 1.0), **kwargs)
    def put(x, fill):
        out = np.full(n, fill)
        out[a:b + 1] = x
        return out

    return Confidence(spread_frames=put(conf.spread_frames, np.nan), est_error_s=put(conf.est_error_s, np.nan),
                      confidence=put(conf.confidence, 0.0), threshold=conf.threshold,
                      error_scale_s=conf.error_scale_s, row_excess=put(conf.row_excess, np.inf))


def posterior_confidence(posterior, fps: float, *, error_scale_s: float = 0.1) -> Confidence:
    """Per-body-frame confidence of an expected path from its own spread.

    The expected path (:mod:`splicer.align.posterior`) weighs every path near the best one
    by ``exp(-cost / temperature)``; its standard deviation per body frame is how far the
    alignments that are almost as good as the chosen one wander: the estimated error.
    Measured against the ground truth (README *Accuracy*; benchmarks/HISTORY.md), it flags badly aligned frames
    far more often than the cost landscape's threshold rule of :func:`row_confidence`, for
    fewer well aligned ones.

    Parameters
    ----------
    posterior : splicer.align.posterior.Posterior
        Pass 1's expected path and its spread (frames of the pass's columns).
    fps : float
        Rate of those columns (the body rate for pass 1), frames per second.
    error_scale_s : float
        Estimated error (seconds) at which confidence is 0.5 (> 0).

    Returns
    -------
    Confidence
        ``spread_frames`` = the posterior's standard deviation (frames), ``est_error_s`` =
        that in seconds, ``threshold`` = the posterior's temperature (cost units); NaN and
        confidence 0 on rows the path does not cover.

    Examples
    --------
    >>> from splicer.align.posterior import Posterior
    >>> p = Posterior(mean=np.array([0.0, 1.0, np.nan]), std=np.array([0.0, 3.0, np.nan]), temperature=24.0, radius=60)
    >>> c = posterior_confidence(p, 30.0)
    >>> c.est_error_s.tolist()[:2], c.confidence.tolist()
    ([0.0, 0.1], [1.0, 0.5, 0.0])
    """
    if not (fps > 0 and np.isfinite(fps)):
        raise ValueError(f"fps must be positive and finite, got {fps!r}")
    if not (error_scale_s > 0 and np.isfinite(error_scale_s)):
        raise ValueError(f"error_scale_s must be positive and finite, got {error_scale_s!r}")
    std = np.asarray(posterior.std, dtype=np.float64)
    est = std / float(fps)
    return Confidence(spread_frames=std, est_error_s=est, confidence=_confidence_of(est, error_scale_s),
                      threshold=float(posterior.temperature), error_scale_s=float(error_scale_s))
