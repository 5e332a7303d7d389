"""Tempo-matched smoothing: both takes blurred over the same span of the performance.

Noise matching (:func:`splicer.align.noise.matched_smoothing`) smooths both takes' markers over
the same seconds before D1 reads their directions.  Where the hands performer ran at another
tempo than the body's, the same seconds hold different amounts of the performance: with the
time map's slope ``t`` (hands seconds per body second, :func:`map_tempo`) under 1 the hands
went faster, and their ``sigma`` seconds of smoothing blur ``sigma / t`` seconds of the body's
performance, more than the body's own ``sigma``; D1's signs then differ where the motion is
the same.  A second performance, which noise matching smooths over 0.15-0.2 s, loses most
there (benchmarks/HISTORY.md, 0.26.1: hands three times faster than the body for 23 s took one
run 0.229 s off; with the true tempo's smoothing 0.039 s).

Given a first alignment's maps, :func:`tempo_blur` says how much further to smooth the take
that is blurred less, in multiples of the phase metric's smoothing (Gaussians compose by their
variances)::

    body:  sqrt(1 / t^2 - 1)  where t < 1        hands:  sqrt(t^2 - 1)  where t > 1

so both are blurred over ``sigma`` seconds of the body's time, or ``sigma * t`` of the hands'.
:class:`~splicer.rig.markers.Markers` carry it as ``blur``; :func:`splicer.align.costs.phase_features`
applies it (:func:`splicer.filters.varying_gaussian_filter1d`).  The second opinion of a noisy
pair (:mod:`splicer.stages.recheck`) aligns the pair again with it.
"""

from __future__ import annotations

import numpy as np

from ..defaults import TEMPO_RANGE, TEMPO_SLOPE_S
from ..filters import gaussian_filter1d
from ..transfer.timemap import mean_map

__all__ = ["map_tempo", "tempo_blur"]


def _fill(x: np.ndarray) -> np.ndarray:
    """NaNs replaced by the nearest finite value (linear between two); all NaN: ones."""
    ok = np.isfinite(x)
    if not ok.any():
        return np.ones_like(x)
    if ok.all():
        return x
    idx = np.arange(len(x))
    return np.interp(idx, idx[ok], x[ok])


def map_tempo(maps, fps: float, *, slope_s: float = TEMPO_SLOPE_S, limits: tuple = TEMPO_RANGE) -> np.ndarray:
    """The hands' tempo at each body frame, from time maps in common frames.

    Parameters
    ----------
    maps : sequence of np.ndarray [shape=(n,)]
        Time maps (common hands frame per body frame, both at the body's rate; NaN where a body
        frame is uncovered), one per side of one hands take: their slopes are averaged.
    fps : float
        Body frames per second.
    slope_s : float
        The slope's Gaussian smoothing, seconds (>= 0).
    limits : (float, float)
        The tempo is clipped to this range (an estimated map can stand still or jump).

    Returns
    -------
    np.ndarray [shape=(n,)]
        Hands seconds per body second (unitless); where no map gives a slope, the nearest
        frame's; all ones where none does anywhere.

    Examples
    --------
    >>> c = np.concatenate([np.arange(60) * 0.5, 30 + np.arange(60) * 2.0])
    >>> t = map_tempo([c], 30.0, slope_s=0.0)
    >>> float(t[10]), float(t[100])
    (0.5, 2.0)
    """
    rows = []
    for c in maps:
        c = np.asarray(c, dtype=np.float64)
        if c.ndim != 1:
            raise ValueError(f"each map must be one-dimensional, got shape {c.shape}")
        rows.append(np.gradient(c) if len(c) > 1 else np.full(len(c), np.nan))
    if not rows:
        raise ValueError("map_tempo needs at least one map")
    if len({len(r) for r in rows}) != 1:
        raise ValueError("the maps must have one frame each per body frame")
    t = _fill(mean_map(rows))
    if slope_s > 0 and len(t) > 1:
        t = gaussian_filter1d(t, slope_s * fps, mode="nearest")
    lo, hi = limits
    return np.clip(t, lo, hi)


def tempo_blur(tempo: np.ndarray, c: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Each take's further smoothing, in multiples of the phase metric's, that blurs both over
    the same span of the performance.

    Parameters
    ----------
    tempo : np.ndarray [shape=(n,)]
        :func:`map_tempo` (> 0).
    c : np.ndarray [shape=(n,)]
        A time map in common frames (NaN where uncovered): where each body frame's tempo falls
        on the hands take.  Hands frames outside it take the tempo at its nearer end.
    m : int
        Hands frames at the common rate.

    Returns
    -------
    body, hands : np.ndarray [shape=(n,)], np.ndarray [shape=(m,)]
        ``sqrt(max(1 / t^2 - 1, 0))`` per body frame and ``sqrt(max(t^2 - 1, 0))`` per hands
        frame (unitless, >= 0): one of the two is 0 wherever the tempo is known.

    Examples
    --------
    >>> b, h = tempo_blur(np.array([0.5, 0.5, 2.0, 2.0]), np.array([0.0, 0.5, 1.0, 3.0]), 6)
    >>> b.round(3).tolist(), h.round(3).tolist()
    ([1.732, 1.732, 0.0, 0.0], [0.0, 1.732, 1.732, 1.732, 1.732, 1.732])
    """
    t = np.asarray(tempo, dtype=np.float64)
    c = np.asarray(c, dtype=np.float64)
    if t.ndim != 1 or c.shape != t.shape:
        raise ValueError(f"tempo and c must be one-dimensional and alike, got {t.shape} and {c.shape}")
    if t.size and not (np.all(np.isfinite(t)) and t.min() > 0):
        raise ValueError("tempo must be finite and > 0")
    body = np.sqrt(np.maximum(1.0 / np.maximum(t, 1e-12) ** 2 - 1.0, 0.0))
    ok = np.isfinite(c)
    if not ok.any():
        return body, np.zeros(int(m))
    x = np.maximum.accumulate(c[ok])  # a map runs forwards; where it stands still, the later frame's tempo
    th = np.interp(np.arange(int(m), dtype=np.float64), x, t[ok])
    hands = np.sqrt(np.maximum(th ** 2 - 1.0, 0.0))
    return body, hands
