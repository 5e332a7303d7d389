"""Open-ended alignment helpers (beyond the paper, ALGORITHM.md section 9).

The penalty for body frames no hands material covers, the coarse band a coarse
open-ended pass hands to the full-rate pass, and an open path's end re-aligned with that end
fixed (:func:`close_end`: does the material the open end left continue the performance?).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .band import Band, _as_constraints, _trim, full_band
from .dtw import dtw
from ..errors import BandError
from .costs import PhaseFeatures, d1_cost

__all__ = ["UNCOVERED_QUANTILE", "OPEN_HORIZONTAL_WEIGHT", "OPEN_COARSE_FPS", "MAX_COARSE_CELLS",
           "LOCATE_FULL_CELLS", "LOCATE_STEP", "LOCATE_BAND_S", "uncovered_penalty", "coarse_rate", "locate_rates",
           "offset_band", "d1_sample", "EndClosure", "close_end"]

#: Default quantile of the local costs used as the per-row penalty of uncovered body frames.
from ..defaults import UNCOVERED_QUANTILE  # noqa: E402  (one place of defaults)

#: Default weight of a cell entered by a (i, j-1) step in an open-ended pass 1 (see
#: :func:`splicer.dtw.dtw`): with the paper's 1, skipping hands material is cheaper than
#: covering it wherever the hands take is slower than the body.  Measured on the zeggs take
#: (8 separations with 2-8 s of extra material, 8 with hands covering the middle half):
#: mean error 9.2 / 4.8 / 1.9 / 2.1 / 2.3 frames at 1 / 0.5 / 0.3 / 0.2 / 0.1.
OPEN_HORIZONTAL_WEIGHT = 0.3

#: Default rate of the open-ended locating pass, frames per second (5 fps mislocated the
#: sample take's slow start by 15 frames on average, 10 fps by 5.6: see benchmarks/HISTORY.md).
OPEN_COARSE_FPS = 10.0

#: Largest coarse matrix of the open-ended locating pass (cells = bytes of DTW steps): 64 Mi.
MAX_COARSE_CELLS = 1 << 26

#: Long takes (the whole matrix at :data:`OPEN_COARSE_FPS` over :data:`MAX_COARSE_CELLS`): the
#: locating pass searches the whole matrix at the rate that fits ``LOCATE_FULL_CELLS`` cells,
#: then finer rates about ``LOCATE_STEP`` times apart up to :data:`OPEN_COARSE_FPS`, each in a
#: band of ``LOCATE_BAND_S`` seconds around the coarser path (:func:`locate_rates`; 0.27.1: the
#: 20-minute pair's locating pass searched 67 M cells per arm at 6.35 fps before, 17 M at 3.18
#: fps and a band at 10 fps now, with the same time maps).
LOCATE_FULL_CELLS = 1 << 24
LOCATE_STEP = 3.0
LOCATE_BAND_S = 30.0


def uncovered_penalty(costs, quantile: float = UNCOVERED_QUANTILE, *, max_samples: int = 1_000_000,
                      seed: int = 0) -> float:
    """Penalty per uncovered body frame: a low quantile of the local costs.

    A body frame left uncovered costs what a matched frame costs at the ``quantile`` of all
    local costs (mostly pairs that do not correspond), so a true match (cheaper) is covered,
    while extra material that resembles the body no better than a typical unrelated pair
    (dearer) is skipped.  Hands frames skipped at either end cost nothing.

    Parameters
    ----------
    costs : np.ndarray [any shape]
        Local costs of (a sample of) the cell pairs, e.g. a coarse full matrix; ``+inf``
        (forbidden) cells are ignored.
    quantile : float
        In ``(0, 1)``.
    max_samples : int
        At most this many costs (a seeded random subset) enter the quantile.
    seed : int
        Seed of that subset (deterministic).

    Returns
    -------
    float
        ``>= 0``, in local-cost units per body frame.

    Raises
    ------
    ValueError
        ``quantile`` outside ``(0, 1)`` or no finite cost.
    """
    if not 0.0 < quantile < 1.0:
        raise ValueError(f"quantile must be in (0, 1), got {quantile!r}")
    c = np.asarray(costs, dtype=np.float64).ravel()
    c = c[np.isfinite(c)]
    if c.size == 0:
        raise ValueError("no finite local cost to take the uncovered penalty from")
    if c.size > max_samples:
        c = np.random.default_rng(seed).choice(c, max_samples, replace=False)
    return max(0.0, float(np.quantile(c, quantile)))


def coarse_rate(n: int, m: int, fps: float, coarse_fps: float, max_cells: int = MAX_COARSE_CELLS) -> float:
    """Rate of the open-ended locating pass: ``coarse_fps``, lowered so the coarse matrix fits.

    Parameters
    ----------
    n, m : int
        Body and hands frames at rate ``fps``.
    fps : float
        Common rate of both sequences, frames per second.
    coarse_fps : float
        Wanted coarse rate, frames per second (> 0).
    max_cells : int
        Cap on ``n_coarse * m_coarse``.

    Returns
    -------
    float
        ``min(fps, coarse_fps, fps * sqrt(max_cells / (n * m)))`` frames per second.
    """
    if not (coarse_fps > 0 and math.isfinite(coarse_fps)):
        raise ValueError(f"coarse_fps must be positive and finite, got {coarse_fps!r}")
    return float(min(fps, coarse_fps, fps * math.sqrt(max_cells / max(1.0, float(n) * float(m)))))


def locate_rates(n: int, m: int, fps: float, coarse_fps: float, max_cells: int = MAX_COARSE_CELLS, *,
                 full_cells: int = LOCATE_FULL_CELLS, step: float = LOCATE_STEP) -> list[float]:
    """Rates of the open-ended locating pass's levels, coarsest first.

    One level, :func:`coarse_rate`, when the whole matrix at ``min(fps, coarse_fps)`` has at most
    ``max_cells`` cells.  Else the first level is the rate at which the whole matrix has
    ``full_cells`` cells (at most ``max_cells``) and the last ``min(fps, coarse_fps)``, with the
    levels between them spaced evenly in log rate, each about ``step`` times the last; every level
    but the first searches a band around the path of the one before
    (:func:`splicer.align.paths.guided_band`, :data:`LOCATE_BAND_S`).

    Examples
    --------
    >>> locate_rates(600, 1200, 30.0, 10.0)                  # a 20-s pair: one level at 10 fps
    [10.0]
    >>> [round(r, 2) for r in locate_rates(72_001, 83_178, 60.0, 10.0)]   # the 20-minute pair
    [3.18, 10.0]
    >>> [round(r, 2) for r in locate_rates(216_001, 252_000, 60.0, 10.0)]  # the hour-long pair
    [1.05, 3.25, 10.0]
    """
    want = min(float(fps), float(coarse_fps))
    one = coarse_rate(n, m, fps, coarse_fps, max_cells)
    if one >= want * (1.0 - 1e-9) or not step > 1.0:
        return [one]
    first = coarse_rate(n, m, fps, coarse_fps, min(full_cells, max_cells))
    k = max(1, int(round(math.log(want / first) / math.log(step))))  # steps of about ``step`` each
    return [first * (want / first) ** (i / k) for i in range(k)] + [want]


def offset_band(n: int, m: int, offset: float, width: float, constraints=()) -> Band:
    """An open-ended band around the line ``j = i + offset`` (same rate on both axes).

    Parameters
    ----------
    n, m : int
        Body and hands frames (>= 1).
    offset : float
        Hands frame matching body frame 0 (may be negative or beyond ``m``).
    width : float
        Perpendicular width in body frames: the band admits ``|j - i - offset| <= width / sqrt(2)``.
    constraints : sequence of Constraint
        Each constraint's row is clipped to its window.

    Returns
    -------
    Band
        ``open_begin`` and ``open_end`` set.  Rows where the line lies outside the hands take
        keep one cell at the nearest edge (a path through them would cover nothing real).

    Raises
    ------
    BandError
        The line does not meet the hands take at all, or a constraint lies outside the band.
    """
    if not (width > 0 and math.isfinite(width)):
        raise BandError(f"band width must be positive and finite, got {width!r} frames")
    delta = width / math.sqrt(2.0)
    i = np.arange(n, dtype=np.float64)
    if offset + (n - 1) + delta < 0 or offset - delta > m - 1:
        raise BandError(f"the offset {offset:g} frames puts the whole body outside the hands take "
                        f"(0..{m - 1} frames, band half-width {delta:g})")
    lo = np.clip(np.ceil(i + offset - delta - 1e-9), 0, m - 1).astype(np.int64)
    hi = np.clip(np.floor(i + offset + delta + 1e-9), 0, m - 1).astype(np.int64)
    cons = _as_constraints(constraints, n, m)
    for c in cons:
        if c.y + c.tolerance < lo[c.x] or c.y - c.tolerance > hi[c.x]:
            raise BandError(f"constraint (x={c.x}, y={c.y}, T={c.tolerance}) lies outside the band around "
                            f"the offset {offset:g} frames; widen the band or check the offset")
        lo[c.x] = max(lo[c.x], c.y - c.tolerance)
        hi[c.x] = min(hi[c.x], c.y + c.tolerance)
    lo, hi = _trim(lo, hi)
    return Band(n=n, m=m, width=float(width), lo=lo, hi=hi, constraints=cons, open_begin=True, open_end=True)


def d1_sample(body: PhaseFeatures, hands: PhaseFeatures, *, theta: str = "window", rows: int = 200,
              cols: int = 2000, seed: int = 0, position_weight: float = 0.0) -> np.ndarray:
    """D1 on a seeded random sample of (body frame, hands frame) pairs, for :func:`uncovered_penalty`.

    Parameters
    ----------
    body, hands : PhaseFeatures
        As :func:`splicer.metrics.d1_cost`.
    rows, cols : int
        At most this many body and hands frames (sampled without replacement; all if fewer).
    theta : {"window", "heading"}
    seed : int
    position_weight : float
        As :func:`splicer.align.costs.d1_cost` (the pass's own cost, position term included).

    Returns
    -------
    np.ndarray [shape=(r, c), dtype=float64]
        D1 of every sampled pair.  O(rows * cols) time and memory.
    """
    rng = np.random.default_rng(seed)

    def pick(f: PhaseFeatures, k):
        t = f.n_frames
        idx = np.sort(rng.choice(t, k, replace=False)) if t > k else np.arange(t)
        return dataclasses.replace(f, vel=f.vel[idx], acc=f.acc[idx], window=f.window[idx], heading=f.heading[idx],
                                   position=None if f.position is None else np.ascontiguousarray(f.position[idx]))

    b, h = pick(body, rows), pick(hands, cols)
    band = Band(n=b.n_frames, m=h.n_frames, width=math.inf, lo=np.zeros(b.n_frames, np.int64),
                hi=np.full(b.n_frames, h.n_frames - 1, np.int64))
    return d1_cost(b, h, theta=theta, position_weight=position_weight)(band, 0, b.n_frames)


@dataclasses.dataclass(frozen=True)
class EndClosure:
    """An open-ended path's end re-aligned with that end fixed at the hands take's first or last frame.

    Attributes
    ----------
    end : {"head", "tail"}
    path : np.ndarray [shape=(K, 2), dtype=int64]
        The fixed-end path over the re-aligned block, in the pass's frames: from ``(0, 0)`` to
        the open path's cell ``rows`` body frames in (head), or from that cell to
        ``(n - 1, m - 1)`` (tail).
    open_cost, closed_cost : float
        Mean local cost per cell along the open path's part of the block and along ``path``
        (the pass's own local cost, every cell counted once).
    left_hands : int
        Hands frames the open path leaves at this end.
    """

    end: str
    path: np.ndarray
    open_cost: float
    closed_cost: float
    left_hands: int

    def excess(self, unrelated: float) -> float:
        """How much of the way from the open path's cost to ``unrelated`` (the cost of unrelated
        material, e.g. the pass's uncovered penalty) the closed end's cost lies: about 0 where the
        material left at this end matches like the rest, about 1 where it is unrelated; ``inf``
        when the open path already costs as much as unrelated material (the test says nothing)."""
        room = unrelated - self.open_cost
        if not room > 0.0:
            return math.inf
        return (self.closed_cost - self.open_cost) / room


def _block_band(n: int, m: int, rows: tuple, cols: tuple) -> Band:
    """Cells ``rows x cols`` (inclusive ranges) as a band of the ``n x m`` matrix (the other rows
    one cell wide, so that the band stays connected); for computing that block's local costs."""
    (r0, r1), (c0, c1) = rows, cols
    lo = np.full(n, c0, dtype=np.int64)
    hi = np.full(n, c0, dtype=np.int64)
    hi[r0:r1 + 1] = c1
    lo[r1 + 1:] = c1
    hi[r1 + 1:] = c1
    return Band(n, m, 1.0, lo, hi, open_begin=True, open_end=True)


def close_end(path: np.ndarray, local_cost, n: int, m: int, end: str, rows: int) -> EndClosure:
    """Re-align the first (``end="head"``) or last (``"tail"``) ``rows`` body frames of an
    open-ended path with fixed ends: the block from the path's cell ``rows`` body frames in to the
    corner ``(0, 0)`` or ``(n - 1, m - 1)``, with the pass's own local costs.

    A hands take that runs slower than the body near an end leaves real material past the open
    path's end (the open end is free, so any cost at all makes the path stop short); unrelated
    material (a calibration pose, other motion) costs about as much as any unrelated pair of
    frames.  :meth:`EndClosure.excess` tells the two apart.

    Parameters
    ----------
    path : np.ndarray [shape=(K, 2)]
        The open-ended path (body frame, hands frame), monotone.
    local_cost : callable
        ``(band, i0, i1) -> rows of local costs`` (a :class:`splicer.passes.PassResult`'s ``local_cost``).
    n, m : int
        The pass's body and hands frame counts.
    end : {"head", "tail"}
    rows : int
        Body frames of the path re-aligned (at least 1).

    Returns
    -------
    EndClosure

    Examples
    --------
    >>> cost = lambda band, i0, i1: np.ones((i1 - i0, int(np.max(band.hi - band.lo + 1))))
    >>> open_path = np.array([[0, 3], [1, 4], [2, 5], [3, 6]])
    >>> c = close_end(open_path, cost, 4, 7, "head", 2)
    >>> c.path.tolist(), c.left_hands, c.open_cost, c.closed_cost
    ([[0, 0], [0, 1], [0, 2], [0, 3], [1, 4], [2, 5]], 3, 1.0, 1.0)
    """
    if end not in ("head", "tail"):
        raise ValueError(f"end must be 'head' or 'tail', got {end!r}")
    p = np.asarray(path, dtype=np.int64)
    rows = max(1, int(rows))
    if end == "tail":
        k = int(np.searchsorted(p[:, 0], max(int(p[0, 0]), int(p[-1, 0]) - rows)))
        (r0, c0), (r1, c1) = p[k], (n - 1, m - 1)
        part, left = p[k:], int(m - 1 - p[-1, 1])
    else:
        k = int(np.searchsorted(p[:, 0], min(int(p[-1, 0]), int(p[0, 0]) + rows), side="right")) - 1
        (r0, c0), (r1, c1) = (0, 0), p[k]
        part, left = p[:k + 1], int(p[0, 1])
    r0, c0, r1, c1 = int(r0), int(c0), int(r1), int(c1)
    block = np.asarray(local_cost(_block_band(n, m, (r0, r1), (c0, c1)), r0, r1 + 1), dtype=np.float64)
    block = block[:, :c1 - c0 + 1]
    res = dtw(block, full_band(r1 - r0 + 1, c1 - c0 + 1, open_begin=False, open_end=False))
    open_cost = float(np.mean(block[part[:, 0] - r0, part[:, 1] - c0]))
    closed = res.path + np.array([r0, c0])
    return EndClosure(end, closed, open_cost, float(res.cost) / len(res.path), left)
