"""From a DTW correspondence to hands rotations on the body timeline (ALGORITHM.md section 6).

Two ways, chosen by ``merge=``:

* ``"median"`` (the paper): each body frame takes the rotation median of the hands frames
  matched to it; where consecutive body frames jump in hands time, the rotations are
  blended (slerp) over a window around the jump.
* ``"timemap"`` (beyond the paper): the correspondence becomes a smooth monotone time map
  (Gaussian-smoothed per-frame median, pinned at user constraints) and the hands motion
  is sampled at those fractional frames with slerp.
"""

from __future__ import annotations

import numpy as np
from ..filters import gaussian_filter1d

from ..model.rotations import quat_hemisphere, quat_median, quat_slerp
from ..runs import true_runs
from .sampling import sample_rotations

__all__ = ["smooth_time_map", "monotone_pinned", "median_rotations", "blend_jumps", "pin_constraints", "mean_map"]


def pin_constraints(time_map: np.ndarray, pins) -> np.ndarray:
    """Shift a time map so it honours ``pins`` = [(body frame, hands frame, tolerance)].

    A piecewise-linear correction, zero at both ends and at pins already within tolerance,
    moves each violating pin to the nearest edge of its window; the result is then made
    non-decreasing and bounded by the pins' windows (frames before a pin at most its upper
    edge, frames after it at least its lower edge), so every window holds, a tolerance of 0
    exactly.  Pins must increase in both coordinates.  Frames in hands-frame units.

    >>> pin_constraints(np.arange(5.0), [(2, 3.0, 0.0)]).tolist()
    [0.0, 1.5, 3.0, 3.5, 4.0]
    """
    tm = np.array(time_map, dtype=np.float64)
    n = len(tm)
    if not pins:
        return tm
    xs, ds = [0], [0.0]
    for x, y, t in sorted(pins):
        v = tm[x]
        d = 0.0
        if v < y - t:
            d = (y - t) - v
        elif v > y + t:
            d = (y + t) - v
        xs.append(x)
        ds.append(d)
    xs.append(n - 1)
    ds.append(0.0)
    # the running maximum can lift a pinned frame above its window (a steep rise just before
    # it): bound every frame by the windows of the pins around it
    return _within_pins(np.maximum.accumulate(tm + np.interp(np.arange(n), xs, ds)), pins)


def _within_pins(tm: np.ndarray, pins) -> np.ndarray:
    """A non-decreasing map clipped between the pins' windows: every frame at least the lower
    edge of the pins at or before it and at most the upper edge of the pins at or after it.
    Both bounds are non-decreasing, so the result stays non-decreasing and every window holds."""
    n = len(tm)
    lower = np.full(n, -np.inf)
    upper = np.full(n, np.inf)
    for x, y, t in pins:
        lower[x] = max(lower[x], y - t)
        upper[x] = min(upper[x], y + t)
    lower = np.maximum.accumulate(lower)
    upper = np.minimum.accumulate(upper[::-1])[::-1]
    return np.minimum(np.maximum(tm, lower), upper)


def smooth_time_map(per_frame: np.ndarray, *, sigma_frames: float, last: float, pins=()) -> np.ndarray:
    """Smooth monotone time map from a per-body-frame median of matched hands frames.

    Parameters
    ----------
    per_frame : np.ndarray [shape=(n,)]
        Non-decreasing hands frame per body frame.
    sigma_frames : float
        Gaussian standard deviation, body frames.
    last : float
        Last valid hands frame (the map is clipped to [0, last]).
    pins : sequence of (int, float, float)
        (body frame, hands frame, tolerance) to honour.

    Returns
    -------
    np.ndarray [shape=(n,)], non-decreasing
    """
    tm = np.asarray(per_frame, dtype=np.float64)
    if sigma_frames > 0 and len(tm) > 1:
        # pad by reflection through the end points so the ends keep their slope
        pad = int(np.ceil(4 * sigma_frames))
        pad = min(pad, len(tm) - 1)
        left = 2 * tm[0] - tm[1:pad + 1][::-1]
        right = 2 * tm[-1] - tm[-pad - 1:-1][::-1]
        ext = np.concatenate([left, tm, right])
        tm = gaussian_filter1d(ext, sigma_frames, mode="nearest")[pad:pad + len(per_frame)]
    return monotone_pinned(tm, last=last, pins=pins)


def monotone_pinned(time_map: np.ndarray, *, last: float, pins=()) -> np.ndarray:
    """A smoothed time map made non-decreasing, kept within ``[0, last]`` and every pin held
    (:func:`pin_constraints`): how :func:`smooth_time_map` and the trend stage
    (:func:`splicer.stages.transfer.trend_time_maps`) finish.

    >>> monotone_pinned(np.array([0.0, 2.0, 1.0, 5.0]), last=4.0, pins=[(1, 1.0, 0.0)]).tolist()
    [0.0, 1.0, 1.5, 4.0]
    """
    tm = np.clip(np.maximum.accumulate(np.asarray(time_map, dtype=np.float64)), 0.0, last)
    return np.clip(pin_constraints(tm, list(pins)), 0.0, last)


def median_rotations(q: np.ndarray, path_hands_frames: np.ndarray, rows: np.ndarray, n: int) -> np.ndarray:
    """Rotation median over the hands frames matched to each body frame.

    Parameters
    ----------
    q : np.ndarray [shape=(M, K, 4)]
        Hands joint rotations (any frame rate).
    path_hands_frames : np.ndarray [shape=(P,)]
        Fractional hands frames (units of ``q``'s frames) along the path.
    rows : np.ndarray [shape=(P,)]
        Body frame of each path cell (non-decreasing, covering 0..n-1).
    n : int

    Returns
    -------
    np.ndarray [shape=(n, K, 4)]
    """
    samples = sample_rotations(q, path_hands_frames)  # (P, K, 4)
    out = np.empty((n,) + q.shape[1:])
    starts = np.searchsorted(rows, np.arange(n), side="left")
    ends = np.searchsorted(rows, np.arange(n), side="right")
    single = (ends - starts) == 1
    out[single] = samples[starts[single]]
    for i in np.nonzero(~single)[0]:
        out[i] = quat_median(samples[starts[i]:ends[i]], axis=0)
    return quat_hemisphere(out, axis=0)


def blend_jumps(q: np.ndarray, time_map: np.ndarray, *, jump: float, window: int) -> np.ndarray:
    """Blend rotation discontinuities over ``window`` frames each side of a jump.

    Parameters
    ----------
    q : np.ndarray [shape=(n, K, 4)]
        Rotations per body frame.
    time_map : np.ndarray [shape=(n,)]
        Hands frame per body frame.
    jump : float
        A step of the time map larger than this (hands frames) is a discontinuity.
    window : int
        Frames each side of the jump over which the rotations are slerped from the frame
        before the window to the frame after it.
    """
    q = np.array(q)
    n = len(time_map)
    steps = np.abs(np.diff(time_map))
    for i in np.nonzero(steps > jump)[0]:
        a = max(i - window, 0)
        b = min(i + 1 + window, n - 1)
        if b - a < 2:
            continue
        t = (np.arange(a + 1, b) - a) / (b - a)
        q[a + 1:b] = quat_slerp(q[a][None], q[b][None], t[:, None])
    return q


def hold_pins(time_map: np.ndarray, pins, *, last: float) -> np.ndarray:
    """Project a non-decreasing time map so every pin holds: ``|tm[x] - y| <= T``.

    Each pin ``(x, y, T)`` bounds the map from below by ``y - T`` from row ``x`` on, and
    from above by ``y + T`` up to row ``x`` (the map is non-decreasing).  Clipping a
    non-decreasing map between those two non-decreasing envelopes keeps it non-decreasing
    and puts every pinned row inside its window, whatever the smoothing did.

    Parameters
    ----------
    time_map : np.ndarray [shape=(n,)]
        Hands-file frames per body frame, non-decreasing.
    pins : sequence of (int, float, float)
        (body frame, hands frame, tolerance in hands frames), increasing in both frames.
    last : float
        Last hands frame.

    Returns
    -------
    np.ndarray [shape=(n,)]

    Examples
    --------
    >>> hold_pins(np.array([0., 1., 2., 3., 4.]), [(2, 3.5, 0.0)], last=10).tolist()
    [0.0, 1.0, 3.5, 3.5, 4.0]
    """
    tm = np.maximum.accumulate(np.asarray(time_map, dtype=np.float64))
    return np.clip(_within_pins(tm, pins), 0.0, last)


def coverage_weights(n: int, covered: tuple[int, int] | None, *, window: int) -> np.ndarray:
    """Weight of the hands' rotations per body frame: 1 inside the covered range, 0 outside,
    ramping linearly over ``window`` frames inside the covered range at each uncovered side.

    Parameters
    ----------
    n : int
        Body frames.
    covered : (int, int) or None
        First and last body frame the hands take covers (inclusive); None: all of them.
    window : int
        Frames of each ramp (>= 0).  A ramp never reaches past the middle of the covered range.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=float64]

    Examples
    --------
    >>> coverage_weights(10, (2, 7), window=2).tolist()
    [0.0, 0.0, 0.3333333333333333, 0.6666666666666666, 1.0, 1.0, 0.6666666666666666, 0.3333333333333333, 0.0, 0.0]
    >>> coverage_weights(4, None, window=3).tolist()
    [1.0, 1.0, 1.0, 1.0]
    """
    w = np.ones(n)
    if covered is None:
        return w
    a, b = int(covered[0]), int(covered[1])
    w[:a] = 0.0
    w[b + 1:] = 0.0
    half = max((b - a) // 2, 0)
    if a > 0 and window > 0:
        k = min(window, half)
        w[a:a + k] = np.arange(1, k + 1) / (k + 1)
    if b < n - 1 and window > 0:
        k = min(window, half)
        w[b - k + 1:b + 1] = np.arange(k, 0, -1) / (k + 1)
    return w


def frame_ranges(mask: np.ndarray, *, min_gap: int = 0) -> list[list[int]]:
    """Runs of True in ``mask`` as ``[first, last]`` (inclusive) frame pairs.

    Runs separated by at most ``min_gap`` False frames are joined.

    Examples
    --------
    >>> frame_ranges(np.array([0, 1, 1, 0, 0, 1, 0, 1], bool))
    [[1, 2], [5, 5], [7, 7]]
    >>> frame_ranges(np.array([0, 1, 1, 0, 0, 1, 0, 1], bool), min_gap=1)
    [[1, 2], [5, 7]]
    """
    starts, stops = true_runs(mask)
    ends = stops - 1
    out: list[list[int]] = []
    for s, e in zip(starts, ends):
        if out and s - out[-1][1] - 1 <= min_gap:
            out[-1][1] = int(e)
        else:
            out.append([int(s), int(e)])
    return out


def mean_map(rows) -> np.ndarray:
    """The mean of equally long rows (time maps of the sides, their slopes), each frame over the
    rows that are finite there (the sides that cover it); NaN where none is.

    Examples
    --------
    >>> mean_map([np.array([1.0, np.nan, np.nan]), np.array([3.0, 4.0, np.nan])]).tolist()
    [2.0, 4.0, nan]
    """
    stack = np.vstack([np.asarray(r, dtype=np.float64) for r in rows])
    ok = np.isfinite(stack)
    count = ok.sum(axis=0)
    return np.where(count > 0, np.where(ok, stack, 0.0).sum(axis=0) / np.maximum(count, 1), np.nan)
