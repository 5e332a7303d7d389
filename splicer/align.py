"""The two alignment passes and their composition (ALGORITHM.md sections 4-5).

Sequences: the body markers (``n`` frames at the body rate) and the hands markers brought
to the body rate (``m`` frames).  Paths are (K, 2) arrays of (body frame, hands frame)
at that common rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .band import _trim
from .defaults import DEAD_ZONE, SMOOTH_S
from .dtw import Band, Constraint, DTWResult, dtw, make_band
from .errors import BandError
from .markers import Markers
from .metrics import PalmFeatures, d1_cost, d2_cost, palm_features, phase_features
from .timewarp import sample_linear

__all__ = ["PassResult", "resample_markers", "pass1", "pass2", "path_median", "compose", "guided_band",
           "remap_constraints", "warp_markers", "coarse_constraints"]


@dataclass(frozen=True, eq=False)
class PassResult:
    """One DTW pass.

    Attributes
    ----------
    path : np.ndarray [shape=(K, 2), dtype=int64]
        (body frame, second-sequence frame) pairs, monotone.
    cost : float
        Total local cost along the path (D1: squared sign differences; D2: radians).
    band : Band
        The admissible region, for plotting.
    name : str
    """

    path: np.ndarray
    cost: float
    band: Band
    name: str
    local_cost: object = None  # callable (band, i0, i1) -> band rows of local costs, for plots

    def __repr__(self) -> str:
        return f"PassResult(name={self.name!r}, path={len(self.path)} cells, cost={self.cost:.6g}, band={self.band!r})"


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


def _run(cost, band: Band, progress=None) -> DTWResult:
    """The DTW over ``band`` with a band-chunk cost; ``progress(fraction)`` after each chunk of rows."""
    if progress is None:
        return dtw(lambda i0, i1: cost(band, i0, i1), band)

    def chunk(i0, i1):
        out = cost(band, i0, i1)
        progress(i1 / band.n)
        return out

    return dtw(chunk, band)


def guided_band(coarse_path: np.ndarray, factor: float, n: int, m: int, width: float, constraints=()) -> Band:
    """A band of width ``width`` (body frames) that follows a coarse path instead of the diagonal.

    Each coarse cell ``(I, J)`` stands for the fine cells around ``(I * factor, J * factor)``; the
    band is the union of those blocks along the coarse path, widened by the half-width
    ``Delta = W * sqrt(1 + s^2) / 2`` (``s = m / n``), clipped to every constraint's window and
    trimmed to cells that lie on a path.  O(n) memory.

    Raises
    ------
    BandError
        When the result cannot connect (e.g. the coarse path misses a constraint window).
    """
    I, J = coarse_path[:, 0], coarse_path[:, 1]
    nc = int(I.max()) + 1
    jmin = np.full(nc, np.iinfo(np.int64).max)
    jmax = np.full(nc, -1)
    np.minimum.at(jmin, I, J)
    np.maximum.at(jmax, I, J)
    ci = np.clip(np.rint(np.arange(n) / factor).astype(np.int64), 0, nc - 1)
    # neighbouring coarse rows too, so blocks of consecutive rows overlap
    lo_c = np.minimum(jmin[ci], jmin[np.maximum(ci - 1, 0)])
    hi_c = np.maximum(jmax[ci], jmax[np.minimum(ci + 1, nc - 1)])
    delta = width * np.sqrt(1.0 + (m / n) ** 2) / 2.0
    lo = np.floor(lo_c * factor - factor - delta).astype(np.int64)
    hi = np.ceil(hi_c * factor + factor + delta).astype(np.int64)
    lo = np.clip(lo, 0, m - 1)
    hi = np.clip(hi, 0, m - 1)
    lo[0] = 0
    hi[-1] = m - 1
    for c in constraints:
        lo[c.x] = max(lo[c.x], c.y - c.tolerance)
        hi[c.x] = min(hi[c.x], c.y + c.tolerance)
    lo, hi = _trim(lo, hi)
    return Band(n=n, m=m, width=width, lo=lo, hi=hi, constraints=tuple(constraints))


def coarse_constraints(constraints, factor: float, n: int, m: int) -> list[Constraint]:
    """Constraints brought to a coarse rate (``factor`` full-rate frames per coarse frame).

    Each pair is rounded to the nearest coarse frames and its tolerance widened to
    ``ceil(T / factor) + 1`` coarse frames (the rounding may move it by one); pairs that land on
    a coarse end frame (``0``, ``n - 1``, ``m - 1``) or do not follow the previous kept pair
    in both coordinates are dropped (the full-rate pass still honours them).

    >>> coarse_constraints([Constraint(45, 60, 0), Constraint(46, 61, 4)], 3.0, 30, 37)
    [Constraint(x=15, y=20, tolerance=1)]
    """
    out: list[Constraint] = []
    for c in constraints:
        x, y = int(round(c.x / factor)), int(round(c.y / factor))
        if 0 < x < n - 1 and 0 < y < m - 1 and (not out or (x > out[-1].x and y > out[-1].y)):
            out.append(Constraint(x, y, int(np.ceil(c.tolerance / factor)) + 1))
    return out


def pass1(body: Markers, hands: Markers, *, width: float, constraints=(), smooth_s: float = SMOOTH_S,
          dead_zone: float = DEAD_ZONE, theta: str = "window", coarse_fps: float | None = None,
          coarse_width: float | None = None, progress=None) -> PassResult:
    """Pass 1: banded DTW with the phase metric D1.

    Parameters
    ----------
    body, hands : Markers
        One side's markers, at the same frame rate (see :func:`resample_markers`).
    width : float
        Band width W in body frames.
    constraints : sequence of Constraint
        In the frames of these two sequences.
    smooth_s, dead_zone, theta
        See :func:`splicer.metrics.phase_features` and :func:`splicer.metrics.d1_cost`.
    progress : callable, optional
        ``progress(fraction)`` as the rows are done.
    coarse_fps : float, optional
        Beyond the paper, for long takes: first align both sequences brought down to this
        rate, in a band of ``coarse_width`` body frames (at the full rate) around the
        diagonal, then run the full-rate pass in a band of ``width`` around that coarse path
        (:func:`guided_band`).  A performance that drifts far from uniform timing over many
        minutes stays inside the band.  None: the band follows the diagonal (the paper).
    """
    fb = phase_features(body, smooth_s=smooth_s, dead_zone=dead_zone)
    fh = phase_features(hands, smooth_s=smooth_s, dead_zone=dead_zone)
    n, m = body.n_frames, hands.n_frames
    if coarse_fps is not None and coarse_fps < body.fps:
        factor = body.fps / coarse_fps
        cb, ch = resample_markers(body, coarse_fps), resample_markers(hands, coarse_fps)
        ccons = coarse_constraints(constraints, factor, cb.n_frames, ch.n_frames)
        cw = (coarse_width if coarse_width is not None else width) / factor
        coarse = pass1(cb, ch, width=cw, constraints=ccons, smooth_s=smooth_s, dead_zone=dead_zone, theta=theta)
        try:
            band = guided_band(coarse.path, factor, n, m, width, constraints)
        except BandError:
            band = make_band(n, m, width, constraints)  # the coarse path missed a window: the paper's band
    else:
        band = make_band(n, m, width, constraints)
    d1 = d1_cost(fb, fh, theta=theta)
    res = _run(d1, band, progress)
    return PassResult(res.path, res.cost, band, "pass1", d1)


def path_median(path: np.ndarray, n: int) -> np.ndarray:
    """For each first-sequence frame 0..n-1, the median of the second-sequence frames matched to it.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=float64]
        Non-decreasing; halves where a frame matches an even number of frames.
    """
    i, j = path[:, 0], path[:, 1]
    # the frames matched to row r are contiguous along a monotone path
    starts = np.searchsorted(i, np.arange(n), side="left")
    ends = np.searchsorted(i, np.arange(n), side="right") - 1
    return 0.5 * (j[starts + (ends - starts) // 2] + j[starts + (ends - starts + 1) // 2])


def _pass2_cost(d2, d1, n_band_scale: float, weight: float, d1_weight: float):
    """D2 + ``d1_weight`` * D1 / 24 + ``weight`` radians per band width of departure from the diagonal.

    D1 / 24 is 1 when half of the 24 sign components disagree (D1 ranges 0..96)."""

    def cost(band, i0, i1):
        out = d2(band, i0, i1)
        if d1 is not None and d1_weight > 0:
            out = out + (d1_weight / 24.0) * d1(band, i0, i1)
        if weight > 0:
            rows = np.arange(i0, i1)
            cols = band.lo[i0:i1, None] + np.arange(out.shape[1])[None, :]
            centre = rows * ((band.m - 1) / max(band.n - 1, 1))
            out = out + weight * np.abs(cols - centre[:, None]) / n_band_scale
        return out

    return cost


def pass2(body: Markers, hands_warped: Markers, *, width: float, constraints=(),
          diagonal_weight: float = 0.0, d1_weight: float = 0.0, smooth_s: float = SMOOTH_S,
          dead_zone: float = DEAD_ZONE, theta: str = "window", progress=None) -> PassResult:
    """Pass 2: banded DTW with the palm metric D2 between the body and the pass-1-warped hands.

    Parameters
    ----------
    body : Markers
    hands_warped : Markers
        Hands markers sampled at the pass-1 time map, one per body frame (or, for pass 2
        alone, the hands at the body rate).
    width : float
        Band width W in body frames (the paper: 10% of the body length).
    constraints : sequence of Constraint
        In (body frame, warped frame) coordinates.
    diagonal_weight : float
        0 is the paper's literal pass 2.  A positive weight adds that many radians per
        band width of departure from the diagonal (the pass-1 warp): D2 alone is small next
        to capture noise between neighbouring frames and the path wanders.
    d1_weight : float
        Weight of the phase metric D1 (normalised by 24) added to D2, so D2 refines within
        phases instead of overriding them; 0 is the paper's pass 2.
    smooth_s, dead_zone, theta
        D1's settings, as in :func:`pass1`.
    progress : callable, optional
        ``progress(fraction)`` as the rows are done.
    """
    fb: PalmFeatures = palm_features(body.points)
    fh: PalmFeatures = palm_features(hands_warped.points)
    d1 = None
    if d1_weight > 0:
        d1 = d1_cost(phase_features(body, smooth_s=smooth_s, dead_zone=dead_zone),
                     phase_features(hands_warped, smooth_s=smooth_s, dead_zone=dead_zone), theta=theta)
    band = make_band(body.n_frames, hands_warped.n_frames, width, constraints)
    cost = _pass2_cost(d2_cost(fb, fh), d1, max(width, 1.0), diagonal_weight, d1_weight)
    res = _run(cost, band, progress)
    return PassResult(res.path, res.cost, band, "pass2", cost)


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
