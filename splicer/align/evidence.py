"""Evidence that the two takes show the same performance: the alignment against one with the
hands take played backwards.

DTW always returns a path, and on two takes of *different* performances (a wrong file, a
take of another session) it finds one whose cost is as low as warping allows: the cheap cells
of a random cost landscape.  The path's own spread does not show it: the best path through
noise is still the best by some margin.  What shows it is a null alignment: the same pass 1,
with the same options, between the body and the hands take played backwards.  That take moves
like the hands take (same speeds, same poses) but performs nothing of the body's in order, so
its cost is what the pass reaches on unrelated material.  The ratio of the two costs is near
1 for unrelated takes and well below for a genuine pair (README, *Real sessions*).

Both passes run at a coarse rate (:data:`CHECK_FPS`, lowered for long takes so that a pass
searches at most :data:`MAX_CHECK_CELLS` cells) without pins: cheap next to pass 1, and the
same for both, so the ratio compares like with like.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..rig.markers import Markers
from .paths import resample_markers

__all__ = ["CHECK_FPS", "MAX_CHECK_CELLS", "Evidence", "played_backwards", "match_evidence", "path_row_costs", "costs_along"]

#: Rate of the check's two passes, frames per second.
CHECK_FPS = 10.0
#: Cap on the cells one of the check's passes searches: the rate is lowered for long takes (a 20-minute
#: body at 60 fps: 3.1 fps, 2.0 s for the check).
MAX_CHECK_CELLS = 1 << 22


@dataclass(frozen=True)
class Evidence:
    """Pass 1's cost on the takes and on the hands take played backwards, at the check's rate.

    Attributes
    ----------
    cost, backwards_cost : float
        Total cost of each pass (local-cost units; open ends: uncovered frames' penalties included),
        over the same body frames.
    fps : float
        The rate both passes ran at.
    rows, backwards_rows : np.ndarray [shape=(k,)] or None
        Per body frame at ``fps``: each pass's mean local cost on its path there, the pass's
        uncovered penalty where its path leaves the frame uncovered (:func:`path_row_costs`);
        None when not recorded.  :meth:`local_ratio` compares them.
    """

    cost: float
    backwards_cost: float
    fps: float
    rows: np.ndarray | None = field(default=None, compare=False, repr=False)
    backwards_rows: np.ndarray | None = field(default=None, compare=False, repr=False)

    @property
    def ratio(self) -> float:
        """``cost / backwards_cost``: near 1 when the takes may not show the same performance; NaN
        when the backwards pass cost nothing."""
        return self.cost / self.backwards_cost if self.backwards_cost > 0 else math.nan

    def local_ratio(self, n: int, fps: float, window_s: float) -> np.ndarray | None:
        """Per body frame (``n`` frames at ``fps``): the two passes' costs, each averaged over a
        centred window of ``window_s`` seconds, divided (this pass's over the backwards one's).

        Near 1 (or above) where the hands' material matched to the body there is no better than
        what the pass reaches on the hands take played backwards: unrelated material, or motion
        too still to tell; well below 1 where the takes show the same performance.  NaN where the
        backwards pass costs nothing there; None when the rows were not recorded.

        Examples
        --------
        >>> ev = Evidence(6.0, 12.0, 2.0, rows=np.array([1.0, 1.0, 1.0, 4.0]),
        ...               backwards_rows=np.array([4.0, 4.0, 4.0, 4.0]))
        >>> ev.local_ratio(4, 2.0, 0.5).tolist()  # a window of one row, at the rows' own rate
        [0.25, 0.25, 0.25, 1.0]
        >>> ev.local_ratio(4, 2.0, 1.5).tolist()  # three rows: (1 + 1) / 8 at the first (zeros beyond), ...
        [0.25, 0.25, 0.5, 0.625]
        >>> ev.local_ratio(3, 1.0, 0.5).tolist()  # body frame i at 1 fps is row 2 i (the last row at most)
        [0.25, 0.25, 1.0]
        """
        if self.rows is None or self.backwards_rows is None or len(self.rows) == 0:
            return None
        if not (fps > 0 and window_s >= 0):
            raise ValueError(f"fps must be positive and window_s >= 0, got {fps!r}, {window_s!r}")
        k = max(1, int(round(window_s * self.fps)))
        kernel = np.ones(k)
        a = np.convolve(np.asarray(self.rows, dtype=np.float64), kernel, mode="same")
        b = np.convolve(np.asarray(self.backwards_rows, dtype=np.float64), kernel, mode="same")
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.where(b > 0, a / b, np.nan)
        at = np.minimum(np.round(np.arange(n) * (self.fps / fps)).astype(np.int64), len(r) - 1)
        return r[at]


def path_row_costs(p) -> np.ndarray:
    """Per body frame of pass ``p`` (a :class:`~splicer.align.passes.PassResult`): the mean
    local cost of its path's cells in that row; the pass's uncovered penalty in the rows its
    path does not reach (open ends).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> band = SimpleNamespace(n=3, lo=np.array([0, 0, 1]))
    >>> costs = np.array([[1.0, 3.0, 9.0], [5.0, 7.0, 9.0], [2.0, 4.0, 9.0]])  # rows of the band
    >>> p = SimpleNamespace(band=band, path=np.array([[0, 0], [0, 1], [1, 1]]), uncovered_cost=6.0,
    ...                     local_cost=lambda band, i0, i1: costs[i0:i1])
    >>> path_row_costs(p).tolist()  # row 0: cells 0, 1; row 1: cell 1; row 2 uncovered
    [2.0, 7.0, 6.0]
    """
    band = p.band
    n = int(band.n)
    path = np.asarray(p.path, dtype=np.int64)
    total = np.zeros(n)
    count = np.zeros(n)
    if len(path):
        block = 4096  # rows of band costs at a time
        for i0 in range(int(path[0, 0]), int(path[-1, 0]) + 1, block):
            i1 = min(n, i0 + block)
            sel = (path[:, 0] >= i0) & (path[:, 0] < i1)
            if not sel.any():
                continue
            c = np.asarray(p.local_cost(band, i0, i1), dtype=np.float64)
            ii, jj = path[sel, 0], path[sel, 1]
            total[i0:i1] += np.bincount(ii - i0, weights=c[ii - i0, jj - band.lo[ii]], minlength=i1 - i0)
            count[i0:i1] += np.bincount(ii - i0, minlength=i1 - i0)
    return np.where(count > 0, total / np.maximum(count, 1.0), float(p.uncovered_cost))


def costs_along(cost, path: np.ndarray, n: int, m: int) -> np.ndarray:
    """Per row of an ``n x m`` matrix: the mean of ``cost`` over ``path``'s cells in that row, NaN
    in the rows the path does not visit.

    ``cost(band, i0, i1)`` gives a band's rows ``i0..i1-1`` of local costs (a pass's
    ``local_cost`` or one of its ``arm_costs``); the path need not lie in that pass's band
    (:func:`splicer.align.band.path_band`).

    Examples
    --------
    >>> full = np.pad(np.arange(12.0).reshape(3, 4), ((0, 0), (0, 4)))  # cost of cell (i, j): 4 i + j
    >>> w = 2  # the rows of a band's costs: its widest row's cells from each row's first column
    >>> cost = lambda band, i0, i1: np.array([full[i, band.lo[i]:band.lo[i] + w] for i in range(i0, i1)])
    >>> costs_along(cost, np.array([[0, 0], [0, 1], [1, 2]]), 3, 4).tolist()
    [0.5, 6.0, nan]
    """
    from types import SimpleNamespace

    from .band import path_band

    band = path_band(path, n, m)
    p = SimpleNamespace(band=band, path=np.asarray(path, dtype=np.int64), uncovered_cost=np.nan, local_cost=cost)
    return path_row_costs(p)


def played_backwards(markers: Markers) -> Markers:
    """The same markers in reverse time order (frame ``k`` becomes frame ``T - 1 - k``), their
    ``blur`` with them."""
    return Markers(markers.points[::-1], markers.shoulder[::-1], markers.heading[::-1], markers.up, markers.fps,
                   markers.side, None if markers.blur is None else markers.blur[::-1])


def match_evidence(body: Markers, hands: Markers, *, ends: str, others=(), fps: float = CHECK_FPS,
                   max_cells: int = MAX_CHECK_CELLS, progress=None, **options) -> Evidence:
    """Pass 1 on ``body``/``hands`` and on ``body``/``hands`` played backwards, at a coarse rate.

    Parameters
    ----------
    body, hands : Markers
        At a common rate (the splice's), as pass 1 gets them.
    ends : {"fixed", "open"}
        The end conditions pass 1 used: open ends let both passes skip what does not match.
    others : sequence of Arm
        More arms, as :func:`splicer.align.passes.pass1` takes them (their hands are played
        backwards too).
    fps : float
        The check's rate (lowered to the takes' rate, and for long takes so that a pass
        searches at most ``max_cells`` cells).
    progress : callable, optional
        ``progress(fraction)`` as the two passes go.
    **options
        More :func:`~splicer.align.passes.pass1` options (``smooth_s``, ``dead_zone``,
        ``sign_ramp``, ``theta``, ``position_weight``, ``uncovered_quantile``); pins are
        left out on purpose: played backwards, they would pin nonsense.

    Returns
    -------
    Evidence
    """
    from .passes import Arm, pass1, weight_without_signs

    if ends not in ("fixed", "open"):
        raise ValueError(f"ends must be 'fixed' or 'open', got {ends!r}")
    if body.fps != hands.fps:
        raise ValueError(f"body and hands markers must share a rate, got {body.fps:g} and {hands.fps:g} fps")
    n, m = body.n_frames, hands.n_frames
    top = rate = min(float(fps), float(body.fps))
    share = 0.3  # fixed ends: the paper's band, 30 % of the body take
    # cells of one pass at ``rate``: the band (fixed ends) or the whole matrix the open-ended locating pass searches
    cells = (share * n * n if ends == "fixed" else float(n) * m) * (rate / body.fps) ** 2
    if cells > max_cells:
        rate *= math.sqrt(max_cells / cells)

    def down(x: Markers) -> Markers:  # in two steps: one long anti-aliasing kernel over an hour of frames is slow
        return resample_markers(resample_markers(x, top), rate)

    b = down(body)
    hs = down(hands)
    arms0 = [(down(a.body), down(a.hands), a) for a in others]
    width = max(3.0, share * b.n_frames) if ends == "fixed" else max(3.0, 3.0 * rate)
    costs, rows = [], []
    for k, turn in enumerate((lambda x: x, played_backwards)):
        arms = tuple(Arm(ab, turn(ah), a.smooth_s, weight_without_signs(a.position_weight, a.coordinates))
                     for ab, ah, a in arms0)
        step = None if progress is None else (lambda f, k=k: progress((k + f) / 2.0))
        p = pass1(b, turn(hs), width=width, ends=ends, others=arms, progress=step, **options)
        costs.append(float(p.cost))
        rows.append(path_row_costs(p))
    return Evidence(costs[0], costs[1], rate, rows=rows[0], backwards_rows=rows[1])
