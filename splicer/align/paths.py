"""Paths and warps between the passes: the per-frame median of a path, a coarse path widened into
a band for the full-rate pass, markers resampled or warped by a map, two maps composed, pins
carried through a warp.
"""

from __future__ import annotations

import numpy as np

from ..filters import gaussian_filter1d
from .band import _trim
from .dtw import Band, Constraint
from ..rig.markers import Markers
from ..transfer.sampling import sample_linear

__all__ = ["resample_markers", "guided_band", "coarse_constraints", "path_median", "hold_ends", "warp_markers",
           "compose", "remap_constraints"]


def resample_markers(markers: Markers, fps: float) -> Markers:
    """Markers brought to ``fps`` frames per second (linear in time; Gaussian anti-aliasing when
    the rate goes down).  Frame ``k`` of the result is at ``k / fps`` seconds."""
    if abs(fps - markers.fps) < 1e-9 * fps:
        return markers
    ratio = markers.fps / fps  # source frames per target frame
    if ratio > 1:
        sigma = 0.5 * ratio
        markers = Markers(*(gaussian_filter1d(a, sigma, axis=0, mode="nearest")
                            for a in (markers.points, markers.shoulder, markers.heading)),
                          markers.up, markers.fps, markers.side)
    m = int(np.floor((markers.n_frames - 1) / ratio + 1e-9)) + 1
    return warp_markers(markers, np.arange(m) * ratio, fps=fps)


def guided_band(coarse_path: np.ndarray, factor: float, n: int, m: int, width: float, constraints=(), *,
                open_begin: bool = False, open_end: bool = False) -> Band:
    """A band of width ``width`` (body frames) that follows a coarse path instead of the diagonal.

    Each coarse cell ``(I, J)`` stands for the fine cells around ``(I * factor, J * factor)``; the
    band is the union of those blocks along the coarse path, widened by the half-width
    ``Delta = W * sqrt(1 + s^2) / 2`` (``s = m / n``), clipped to every constraint's window and
    trimmed to cells that lie on a path.  O(n) memory.

    With fixed ends the band reaches ``(0, 0)`` and ``(n - 1, m - 1)``.  With open ends
    (a coarse path from an open-ended pass, which may start after coarse row 0 or end before
    the last) it does not have to: coarse rows before the path's first cell take its first
    column, rows after its last cell its last column, so the fine pass can still move the
    start and end by a coarse frame or more, and leave the rest uncovered.

    Raises
    ------
    BandError
        When the result cannot connect (e.g. the coarse path misses a constraint window).
    """
    I, J = coarse_path[:, 0], coarse_path[:, 1]
    nc = int(I.max()) + 1
    if open_begin or open_end:                        # the coarse path may stop short of the last row
        nc = max(nc, int(np.rint((n - 1) / factor)) + 1)
    jmin = np.full(nc, np.iinfo(np.int64).max)
    jmax = np.full(nc, -1)
    np.minimum.at(jmin, I, J)
    np.maximum.at(jmax, I, J)
    i0, i1 = int(I.min()), int(I.max())
    jmin[:i0], jmax[:i0] = J[0], J[0]                 # rows the coarse path leaves uncovered
    jmin[i1 + 1:], jmax[i1 + 1:] = J[-1], J[-1]
    ci = np.clip(np.rint(np.arange(n) / factor).astype(np.int64), 0, nc - 1)
    # neighbouring coarse rows too, so blocks of consecutive rows overlap
    lo_c = np.minimum(jmin[ci], jmin[np.maximum(ci - 1, 0)])
    hi_c = np.maximum(jmax[ci], jmax[np.minimum(ci + 1, nc - 1)])
    delta = width * np.sqrt(1.0 + (m / n) ** 2) / 2.0
    lo = np.floor(lo_c * factor - factor - delta).astype(np.int64)
    hi = np.ceil(hi_c * factor + factor + delta).astype(np.int64)
    lo = np.clip(lo, 0, m - 1)
    hi = np.clip(hi, 0, m - 1)
    if not open_begin:
        lo[0] = 0
    if not open_end:
        hi[-1] = m - 1
    for c in constraints:
        lo[c.x] = max(lo[c.x], c.y - c.tolerance)
        hi[c.x] = min(hi[c.x], c.y + c.tolerance)
    lo, hi = _trim(lo, hi)
    return Band(n=n, m=m, width=width, lo=lo, hi=hi, constraints=tuple(constraints), open_begin=open_begin,
                open_end=open_end)


def coarse_constraints(constraints, factor: float, n: int, m: int) -> list[Constraint]:
    """Constraints brought to a coarse rate (``factor`` full-rate frames per coarse frame).

    Each pair is rounded to the nearest coarse frames and its tolerance widened to
    ``ceil(T / factor) + 1`` coarse frames (the rounding may move it by one); pairs that land on
    a coarse end frame (``0``, ``n - 1``, ``m - 1``) or do not follow the previous kept pair
    in both coordinates are dropped (the full-rate pass still honours them).

    >>> coarse_constraints([Constraint(45, 60, 0), Constraint(46, 61, 4)], 3.0, 30, 37)
    [Constraint(x=15, y=20, tolerance=1)]
    """
    return _coarse_constraints(constraints, factor, n, m)


def _coarse_constraints(constraints, factor, nc, mc):
    out = []
    for c in constraints:
        x, y = int(round(c.x / factor)), int(round(c.y / factor))
        if 0 < x < nc - 1 and 0 < y < mc - 1 and (not out or (x > out[-1].x and y > out[-1].y)):
            out.append(Constraint(x, y, int(np.ceil(c.tolerance / factor)) + 1))
    return out


def path_median(path: np.ndarray, n: int) -> np.ndarray:
    """For each first-sequence frame 0..n-1, the median of the second-sequence frames matched to it.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=float64]
        Non-decreasing over the frames the path covers; halves where a frame matches an even
        number of frames.  NaN for frames the path does not cover (open ends).
    """
    i, j = path[:, 0], path[:, 1]
    rows = np.arange(n)
    # the frames matched to row r are contiguous along a monotone path
    starts = np.searchsorted(i, rows, side="left")
    ends = np.searchsorted(i, rows, side="right") - 1
    on = ends >= starts
    out = np.full(n, np.nan)
    s, e = starts[on], ends[on]
    out[on] = 0.5 * (j[s + (e - s) // 2] + j[s + (e - s + 1) // 2])
    return out


def hold_ends(values: np.ndarray) -> np.ndarray:
    """``values`` (n,) with NaN outside the covered span (:func:`path_median` after open ends)
    replaced by the first / last finite value; a copy.  Raises ValueError when none is finite."""
    v = np.array(values, dtype=np.float64)
    ok = np.flatnonzero(np.isfinite(v))
    if ok.size == 0:
        raise ValueError("no covered frame")
    v[:ok[0]] = v[ok[0]]
    v[ok[-1] + 1:] = v[ok[-1]]
    return v


def warp_markers(markers: Markers, frames: np.ndarray, *, fps: float | None = None) -> Markers:
    """Markers sampled at fractional ``frames`` (linear), e.g. the hands on the body timeline.

    ``fps`` is the rate of the result (the input's by default)."""
    return Markers(sample_linear(markers.points, frames), sample_linear(markers.shoulder, frames),
                   sample_linear(markers.heading, frames), markers.up, markers.fps if fps is None else fps,
                   markers.side)


def compose(map1: np.ndarray, path2: np.ndarray, n: int) -> np.ndarray:
    """Compose pass 2's path (body frame -> warped frame) with pass 1's map (warped frame -> hands frame).

    Parameters
    ----------
    map1 : np.ndarray [shape=(n,)]
        Hands frame (common rate) of each warped frame, non-decreasing.
    path2 : np.ndarray [shape=(K, 2)]
    n : int
        Body frames.

    Returns
    -------
    np.ndarray [shape=(n,)]
        Hands frame (common rate) for each body frame.
    """
    k = path_median(path2, n)
    return np.interp(k, np.arange(len(map1)), map1)


def remap_constraints(constraints, map1: np.ndarray) -> list[Constraint]:
    """Constraints from (body, hands) frames to (body, warped) frames through pass 1's map."""
    out = []
    idx = np.arange(len(map1), dtype=np.float64)
    for c in constraints:
        k = int(round(float(np.interp(c.y, map1, idx))))
        out.append(Constraint(c.x, k, c.tolerance))
    return out
