"""Where the body holds still: rows pass 1 may cross on one hands frame for free.

When the body performer holds a pose while the hands performer goes on, the true time map is
flat there: every held body frame shows the same instant.  D1 has nothing to go on in those
rows (the body's signs are all zero), so a plain DTW path cuts the corner: it spreads the hold
over the seconds around it, because a straight path through a stretch of equal costs crosses
fewer cells than a flat one (a hold of 1.8 s left the map up to 1 s off, README *Real
sessions*).  Rows where every arm of the body is still are *held*
(:func:`splicer.align.dtw.dtw`'s ``held_rows``): the path crosses them on one hands frame at no
cost, as if those rows were not there, and the motion around the hold places it.

A hold is a stretch of at least ``min_s`` seconds in which every arm's markers (relative to
its shoulder, smoothed over ``smooth_s``) move slower than ``speed_ratio`` times that arm's
median speed over the take.  Units are in the names.
"""

from __future__ import annotations

import numpy as np

from ..defaults import HOLD_MIN_S, HOLD_SMOOTH_S, HOLD_SPEED_RATIO
from ..runs import true_runs

__all__ = ["arm_stillness", "body_holds", "held_rows", "hold_ranges", "hold_band"]


def arm_stillness(points: np.ndarray, fps: float, *, smooth_s: float = HOLD_SMOOTH_S) -> np.ndarray:
    """Each frame's marker speed as a share of the take's median speed.

    Parameters
    ----------
    points : np.ndarray [shape=(n, k, 3)]
        One arm's markers relative to its shoulder, any length unit.
    fps : float
        Frames per second.
    smooth_s : float
        Standard deviation of the Gaussian that smooths the markers first, seconds (> 0).

    Returns
    -------
    np.ndarray [shape=(n,)]
        Mean speed over the markers divided by its median over the frames; 0 everywhere for a
        take whose median speed is 0 (still over half its frames): nothing to measure holds by,
        and :func:`body_holds` then finds none.

    Examples
    --------
    >>> t = np.arange(90) / 30.0
    >>> x = np.where(t < 1, t, np.where(t < 2, 1.0, t - 1.0))        # moves, holds 1 s, moves
    >>> pts = np.stack([x, 0 * x, 0 * x], axis=1)[:, None, :]
    >>> r = arm_stillness(pts, 30.0, smooth_s=0.05)
    >>> bool(r[45] < 0.01), bool(abs(r[10] - 1.0) < 0.05)
    (True, True)
    """
    from ..filters import gaussian_filter1d

    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 3:
        raise ValueError(f"points must have shape (n, k, 3), got {p.shape}")
    if not (fps > 0 and smooth_s > 0):
        raise ValueError(f"fps and smooth_s must be positive, got {fps!r} and {smooth_s!r}")
    n = p.shape[0]
    if n < 3:
        return np.ones(n)
    flat = gaussian_filter1d(p.reshape(n, -1), smooth_s * fps, axis=0, mode="nearest")
    v = np.linalg.norm(np.gradient(flat, axis=0).reshape(n, -1, 3), axis=2).mean(axis=1) * fps
    med = float(np.median(v))
    if not med > 0:
        return np.zeros(n)
    return v / med


def body_holds(arms, fps: float, *, speed_ratio: float = HOLD_SPEED_RATIO, min_s: float = HOLD_MIN_S,
               smooth_s: float = HOLD_SMOOTH_S) -> tuple:
    """Stretches where every arm is still: ``((first, last), ...)`` body frames, inclusive.

    Parameters
    ----------
    arms : sequence of np.ndarray [shape=(n, k, 3)]
        Each arm's markers relative to its shoulder (:func:`arm_stillness`), same ``n``.
    fps : float
    speed_ratio, min_s, smooth_s : float
        A hold: every arm slower than ``speed_ratio`` times its median speed, for at least
        ``min_s`` seconds (markers smoothed over ``smooth_s`` seconds).

    Examples
    --------
    >>> t = np.arange(120) / 30.0
    >>> x = np.where(t < 1, t, np.where(t < 2, 1.0, t - 1.0))
    >>> pts = np.stack([x, 0 * x, 0 * x], axis=1)[:, None, :]
    >>> [(int(a), int(b)) for a, b in body_holds([pts], 30.0, smooth_s=0.05)]
    [(33, 57)]
    """
    arms = [np.asarray(a, dtype=np.float64) for a in arms]
    if not arms:
        return ()
    n = arms[0].shape[0]
    if any(a.shape[0] != n for a in arms):
        raise ValueError("every arm needs the same number of frames")
    still = np.ones(n, bool)
    for a in arms:
        still &= arm_stillness(a, fps, smooth_s=smooth_s) < speed_ratio
    if still.all():  # a take that never moves: nothing to align on, nothing to collapse
        return ()
    need = max(int(round(min_s * fps)), 2)
    starts, ends = true_runs(still)
    return tuple((int(a), int(b) - 1) for a, b in zip(starts, ends) if b - a >= need)


def held_rows(n: int, holds) -> np.ndarray | None:
    """Rows pass 1 crosses on one hands frame for free (:func:`splicer.align.dtw.dtw`'s
    ``held_rows``): every row of a hold but its first (the path enters the hold as usual, then
    stays on that hands frame); None without holds (the paper's recurrence).

    Examples
    --------
    >>> held_rows(6, [(1, 3)]).astype(int)
    array([0, 0, 1, 1, 0, 0])
    """
    if not holds:
        return None
    h = np.zeros(int(n), bool)
    for a, b in holds:
        h[int(a) + 1:int(b) + 1] = True
    return h


def hold_ranges(held) -> tuple:
    """The holds back from their held rows (:func:`held_rows`' inverse): ``((first, last), ...)``,
    each from the row the path enters it on to its last held row; empty for None.

    Examples
    --------
    >>> hold_ranges(held_rows(8, [(1, 3), (5, 6)]))
    ((1, 3), (5, 6))
    """
    if held is None:
        return ()
    return tuple((int(a) - 1, int(b) - 1) for a, b in zip(*true_runs(np.asarray(held, dtype=bool))))


def hold_band(band, held):
    """``band`` with each hold's rows widened to every column the band gives any of them, so that
    a path that enters a hold on any admissible hands frame can stay on it to the end (a band
    that follows a corner-cutting guide across the hold may otherwise shift past it).  Holds
    that hold a pin's row are left as they are (the pin's window bounds that row).

    The rows around a hold are widened too, over one band width (``band.width`` rows, at least
    the hold's length, at most the body's) either side, up to a pinned row: after the hold each
    row's first column is at most the hold's first column plus the rows since the hold (a path
    that leaves the hold on its lowest column can go on at the hands' own rate), before it each
    row's last column at least the hold's last column minus the rows to the hold (a path can
    reach the hold's highest column).  A guide that cuts the hold's corner runs behind the true map
    before the hold and ahead of it after; its band then missed the truth for up to a second
    after a hold (ZEGGS *all*, tuning seed 24: the map 0.5 s off over 4 s; benchmarks/HISTORY.md,
    0.37.0).

    Parameters
    ----------
    band : Band
    held : np.ndarray [shape=(n,), dtype=bool] or None
        :func:`held_rows`.

    Returns
    -------
    (Band, np.ndarray or None)
        The band, and the held rows it was widened for (the holds holding a pin dropped).

    Examples
    --------
    >>> from splicer.align.band import Band
    >>> b = Band(5, 9, 2.0, np.array([0, 1, 2, 3, 4]), np.array([2, 3, 4, 6, 8]))
    >>> w, h = hold_band(b, held_rows(5, [(1, 3)]))
    >>> w.lo.tolist(), w.hi.tolist()
    ([0, 1, 1, 1, 2], [5, 6, 6, 6, 8])
    """
    from .band import Band

    if held is None or not np.any(held):
        return band, None
    held = np.array(held, dtype=bool)
    pinned = {int(c.x) for c in band.constraints}
    lo, hi = band.lo.copy(), band.hi.copy()
    for a, b in hold_ranges(held):  # the hold's rows: a (entered as usual) .. b
        if any(a <= x <= b for x in pinned):
            held[a + 1:b + 1] = False
            continue
        lo[a:b + 1] = lo[a]
        hi[a:b + 1] = hi[b]
        reach = max(int(round(min(band.width, band.n))), b - a + 1)  # a full band's width is inf
        for i in range(b + 1, min(b + reach, band.n - 1) + 1):  # after: from the hold's first column on
            if i in pinned:
                break
            lo[i] = min(lo[i], lo[a] + (i - b))
        for i in range(a - 1, max(a - reach, 0) - 1, -1):  # before: up to the hold's last column
            if i in pinned:
                break
            hi[i] = max(hi[i], hi[b] - (a - i))
    if not held.any():
        return band, None
    return Band(band.n, band.m, band.width, lo, hi, band.constraints, band.open_begin, band.open_end), held
