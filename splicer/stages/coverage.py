"""Stage 6e, coverage edges: where the hands' material starts or stops inside the body.

With open ends the alignment decides which body frames the hands take covers.  Where an
uncovered range begins or ends inside the body, the exact frame is located only to within a
few frames (the covered frames there may show material from before the hands performance or
after it), and nothing in the expected path's spread or the arms' check says so: the path is
as sure of itself there as anywhere.  So the covered frames within
:data:`splicer.defaults.COVERAGE_EDGE_S` of an uncovered range get at least that estimated
error, which makes them low confidence; the output motion is not changed.

Before that, :func:`uncover_unsure_edges`: where the hands' material starts (stops) inside
the body, the path may go on through material from outside the body's performance (a hands
take that starts early *and* covers only part of the body: a calibration pose, other
gestures), which the open ends cannot skip on both takes at once.  The risk stage knows it is
unsure there; a stretch of at least :data:`splicer.defaults.UNSURE_EDGE_S` next to the
uncovered frames whose estimated error exceeds :data:`splicer.defaults.UNSURE_EDGE_ERROR_S`
throughout is taken as uncovered too: those body frames keep their own fingers, and the
report lists them with the other uncovered frames.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..align.risk import distance_to_uncovered
from ..defaults import COVERAGE_EDGE_S, UNSURE_EDGE_ERROR_S, UNSURE_EDGE_S
from ..runs import true_runs

__all__ = ["coverage_edges", "mark_coverage_edges", "unsure_edges", "uncover_unsure_edges"]


def unsure_edges(hands_frame, est_error_s, fps: float, *, min_s: float = UNSURE_EDGE_S,
                 error_s: float = UNSURE_EDGE_ERROR_S, pinned=()) -> np.ndarray:
    """Covered body frames to take as uncovered: the unsure stretches next to uncovered ones.

    At each end of the covered span that lies inside the body (uncovered frames before its
    first frame, or after its last), the run of covered frames from that end whose estimated
    error exceeds ``error_s``, when it lasts at least ``min_s`` seconds and stops at a sure
    frame of the span.  A run that reaches a pin is left alone: the animator says the hands'
    material there is the body's.  An end at the body's
    first or last frame is left alone (the takes start or stop together there; nothing says the
    hands' material is from elsewhere), and so is a span unsure from end to end (nothing in it
    is sure enough to be the genuine material the stretch would lead to).

    Parameters
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        Hands-file frame of each body frame; NaN where uncovered (a single covered span).
    est_error_s : np.ndarray [shape=(n,)]
        Estimated error per body frame, seconds (NaN where uncovered).
    fps : float
        Body frames per second.
    min_s, error_s : float
        Shortest stretch, seconds (0: none is taken); the estimated error it must exceed.
    pinned : iterable of int
        Body frames of the pins: never taken.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=bool]

    Examples
    --------
    >>> hf = np.array([np.nan, np.nan, 0, 1, 2, 3, 4, 5, 6, 7])
    >>> est = np.array([np.nan, np.nan, 0.5, 0.3, 0.25, 0.05, 0.05, 0.4, 0.4, 0.4])
    >>> unsure_edges(hf, est, 10.0, min_s=0.3).astype(int).tolist()  # start: 3 frames; the end is the body's last
    [0, 0, 1, 1, 1, 0, 0, 0, 0, 0]
    >>> unsure_edges(hf, est, 10.0, min_s=0.4).astype(int).tolist()  # too short
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    >>> unsure_edges(hf, est, 10.0, min_s=0.2, pinned=[4]).astype(int).tolist()  # a pin in the run
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    """
    h = np.asarray(hands_frame, dtype=np.float64)
    e = np.asarray(est_error_s, dtype=np.float64)
    if h.ndim != 1 or e.shape != h.shape:
        raise ValueError(f"hands_frame and est_error_s must have one shape (n,), got {h.shape}, {e.shape}")
    if not (fps > 0 and np.isfinite(fps)) or not (min_s >= 0 and np.isfinite(min_s)) or not (error_s >= 0):
        raise ValueError(f"fps must be positive, min_s and error_s >= 0, got {fps!r}, {min_s!r}, {error_s!r}")
    n = len(h)
    out = np.zeros(n, dtype=bool)
    cov = np.flatnonzero(np.isfinite(h))
    if len(cov) == 0 or min_s == 0:
        return out
    need = max(1, int(round(min_s * fps)))
    unsure = np.isfinite(h) & (np.nan_to_num(e, nan=0.0) > error_s)
    pins = np.zeros(n, dtype=bool)
    pins[np.asarray([p for p in pinned if 0 <= p < n], dtype=np.int64)] = True
    unsure &= ~pins
    a, b = int(cov[0]), int(cov[-1])
    starts, stops = true_runs(unsure)  # unsure runs [lo, hi); the frame past each end stops it
    for lo, hi in zip(starts.tolist(), stops.tolist()):
        at_start = lo == a and a > 0 and hi <= b  # from the span's first frame, stopped inside it
        at_end = hi == b + 1 and b < n - 1 and lo > a  # up to the span's last frame, stopped inside it
        stop = hi if at_start else lo - 1
        if (at_start or at_end) and hi - lo >= need and not pins[stop]:  # stopped by a sure, unpinned frame
            out[lo:hi] = True
    return out


def coverage_edges(hands_frame, fps: float, edge_s: float = COVERAGE_EDGE_S) -> np.ndarray:
    """Covered body frames within ``edge_s`` seconds of an uncovered one.

    Parameters
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        Hands-file frame of each body frame; NaN where uncovered.
    fps : float
        Body frames per second.
    edge_s : float
        Seconds each side of an uncovered range (rounded to whole frames).

    Returns
    -------
    np.ndarray [shape=(n,), dtype=bool]

    Examples
    --------
    >>> hf = np.array([np.nan, np.nan, 5, 6, 7, 8, 9, 10, np.nan, np.nan])
    >>> coverage_edges(hf, 10.0, 0.2).astype(int).tolist()  # 2 frames each side
    [0, 0, 1, 1, 0, 0, 1, 1, 0, 0]
    >>> bool(coverage_edges(np.arange(5.0), 10.0, 0.2).any())  # nothing uncovered: no edges
    False
    """
    h = np.asarray(hands_frame, dtype=np.float64)
    if h.ndim != 1:
        raise ValueError(f"hands_frame must have shape (n,), got {h.shape}")
    if not (fps > 0 and np.isfinite(fps)) or not (edge_s >= 0 and np.isfinite(edge_s)):
        raise ValueError(f"fps must be positive and edge_s >= 0 (both finite), got {fps!r}, {edge_s!r}")
    unc = ~np.isfinite(h)
    # an uncovered frame within w frames (the risk model's edge feature counts the same way)
    return (distance_to_uncovered(unc) <= int(round(edge_s * fps))) & ~unc


def uncover_unsure_edges(sides: dict, opts=None, log=None, *, error_s: float = UNSURE_EDGE_ERROR_S) -> dict:
    """Each side's :func:`unsure_edges` taken as uncovered (after the risk stage, before
    :func:`mark_coverage_edges`).

    Parameters
    ----------
    sides : dict of str -> SideResult
    opts : SpliceOptions, optional
        ``unsure_edge_s`` (0: nothing changes).
    log : Log, optional
        Receives one note per side that changed.

    Returns
    -------
    dict of str -> SideResult
        A side that changed has NaN in ``hands_frame`` there, its alignment's ``covered``
        span narrowed and its confidence uncovered there
        (:meth:`~splicer.align.confidence.Confidence.uncovered_at`); the others unchanged.
    """
    min_s = UNSURE_EDGE_S if opts is None else opts.unsure_edge_s
    out = {}
    for s, r in sides.items():
        conf = r.alignment.confidence
        if conf is None or r.alignment.covered is None or not min_s:
            out[s] = r
            continue
        fps = r.markers.spaces.body_fps
        take = unsure_edges(r.hands_frame, conf.est_error_s, fps, min_s=min_s, error_s=error_s,
                            pinned=[p.body for p in r.pins])
        if not take.any():
            out[s] = r
            continue
        hf = np.where(take, np.nan, np.asarray(r.hands_frame, dtype=np.float64))
        cov = np.flatnonzero(np.isfinite(hf))
        aln = replace(r.alignment, covered=(int(cov[0]), int(cov[-1])), confidence=conf.uncovered_at(take))
        out[s] = replace(r, hands_frame=hf, alignment=aln)
        if log is not None:
            from ..transfer.timemap import frame_ranges

            spans = ", ".join(f"{a}-{b} ({(b - a + 1) / fps:.1f} s)" for a, b in frame_ranges(take))
            log.note(f"{s} side: body frames {spans} next to the uncovered ones are taken as uncovered too: the "
                     f"alignment there is unsure throughout (estimated error over {error_s:g} s for at least "
                     f"{min_s:g} s), as where the hands take holds material from outside the body's performance")
    return out


def mark_coverage_edges(sides: dict, edge_s: float = COVERAGE_EDGE_S) -> dict:
    """Each side's confidence with its coverage edges' estimated error at least ``edge_s``.

    Parameters
    ----------
    sides : dict of str -> SideResult
        The finished sides of a splice (:func:`splicer.pipeline.splice`).

    Returns
    -------
    dict of str -> SideResult
        The same sides; a side with a confidence and an uncovered range inside its body gets
        :meth:`~splicer.align.confidence.Confidence.with_floor` ``(edge_s, where=edges)``.
    """
    out = {}
    for s, r in sides.items():
        conf = r.alignment.confidence
        edges = coverage_edges(r.hands_frame, r.markers.spaces.body_fps, edge_s) if conf is not None else None
        if edges is None or not edges.any():
            out[s] = r
            continue
        out[s] = replace(r, alignment=replace(r.alignment, confidence=conf.with_floor(edge_s, where=edges)))
    return out
