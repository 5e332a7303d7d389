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
report lists them with the other uncovered frames.  Then :func:`unmatched_edges` does the same
where the alignment there costs nearly what it costs against the hands take played backwards
(:meth:`splicer.align.evidence.Evidence.local_ratio` over :data:`splicer.defaults.UNMATCHED_RATIO`
for at least :data:`splicer.defaults.UNMATCHED_EDGE_S`): material no better than unrelated.
At the body's own first or last frame, which those two rules leave alone (the takes may start
together there), :func:`unmatched_body_ends` takes the stretch whose material fits the body
worse than the hands played backwards on the whole.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..align.risk import distance_to_uncovered
from ..defaults import (COVERAGE_EDGE_S, JUDGE_UNCOVERED, UNMATCHED_EDGE_S, UNMATCHED_OWN_MARGIN_S,
                        UNMATCHED_OWN_RATIO, UNMATCHED_RATIO, UNMATCHED_WINDOW_S, UNSURE_EDGE_ERROR_S, UNSURE_EDGE_S)
from ..runs import true_runs

__all__ = ["coverage_edges", "mark_coverage_edges", "unsure_edges", "unmatched_edges", "unmatched_body_ends",
           "uncover_unsure_edges"]


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
    if not (error_s >= 0):
        raise ValueError(f"error_s must be >= 0, got {error_s!r}")
    return _edge_runs(h, np.nan_to_num(e, nan=0.0) > error_s, fps, min_s, pinned)


def unmatched_edges(hands_frame, ratio, fps: float, *, min_s: float = UNMATCHED_EDGE_S,
                    ratio_above: float = UNMATCHED_RATIO, beyond_s: float = COVERAGE_EDGE_S,
                    pinned=()) -> np.ndarray:
    """Covered body frames to take as uncovered: stretches next to uncovered ones whose hands
    material matches the body no better than the hands take played backwards.

    The same stretches as :func:`unsure_edges` (from an end of the covered span inside the
    body, at least ``min_s`` seconds, stopping at a frame of the span that is kept, never
    through a pin), with every frame's :meth:`~splicer.align.evidence.Evidence.local_ratio`
    above ``ratio_above``, and only where more than ``beyond_s`` seconds of uncovered frames
    lie past that end: an end nearer the body's own first (last) frame is within the
    precision the open ends locate it to (:data:`splicer.defaults.COVERAGE_EDGE_S`), so the
    takes start (stop) together there, and a ratio near 1 there says only that the motion
    does not tell (a still or noisy start: held-out zeggs *imitation*, seed 102, whose path
    left the body's first 6 frames uncovered, lost 3.5 s of genuine material to the rule
    without this).

    Parameters
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        Hands-file frame of each body frame; NaN where uncovered (a single covered span).
    ratio : np.ndarray [shape=(n,)]
        The alignment's cost over its cost against the hands take played backwards, locally,
        per body frame (NaN: not known, never taken).
    fps : float
        Body frames per second.
    min_s, ratio_above : float
        Shortest stretch, seconds (0: none is taken); the ratio it must exceed throughout.
    beyond_s : float
        Uncovered seconds past the end needed (more than this).
    pinned : iterable of int
        Body frames of the pins: never taken.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=bool]

    Examples
    --------
    >>> hf = np.array([0, 1, 2, 3, 4, 5, 6, 7, np.nan, np.nan])
    >>> ratio = np.array([0.4, 0.5, 0.9, 0.5, 0.95, 0.9, 1.1, 0.9, np.nan, np.nan])
    >>> unmatched_edges(hf, ratio, 10.0, min_s=0.3, beyond_s=0.1).astype(int).tolist()  # the start is the body's
    [0, 0, 0, 0, 1, 1, 1, 1, 0, 0]
    >>> unmatched_edges(hf, ratio, 10.0, min_s=0.5, beyond_s=0.1).astype(int).tolist()  # too short
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    >>> unmatched_edges(hf, ratio, 10.0, min_s=0.3, beyond_s=0.2).astype(int).tolist()  # 0.2 s past the end: too few
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    """
    h = np.asarray(hands_frame, dtype=np.float64)
    r = np.asarray(ratio, dtype=np.float64)
    if h.ndim != 1 or r.shape != h.shape:
        raise ValueError(f"hands_frame and ratio must have one shape (n,), got {h.shape}, {r.shape}")
    if not (ratio_above >= 0) or not (beyond_s >= 0):
        raise ValueError(f"ratio_above and beyond_s must be >= 0, got {ratio_above!r}, {beyond_s!r}")
    return _edge_runs(h, np.nan_to_num(r, nan=-np.inf) > ratio_above, fps, min_s, pinned, beyond_s)


def unmatched_body_ends(hands_frame, ratio, fps: float, *, min_s: float = UNMATCHED_EDGE_S,
                        ratio_above: float = UNMATCHED_OWN_RATIO, margin_s: float = UNMATCHED_OWN_MARGIN_S,
                        beyond_s: float = COVERAGE_EDGE_S, pinned=()) -> np.ndarray:
    """Covered body frames to take as uncovered: at the body's own first or last frame, the
    stretch whose hands material matches the body *worse* than the hands take played backwards.

    :func:`unmatched_edges` leaves the ends of the covered span at (or within ``beyond_s`` of)
    the body's own first and last frames alone: the takes seem to start (stop) together there.
    But a hands take that starts early and covers only part of the body cannot be skipped on
    both takes at once by the open ends, and its calibration pose and other gestures then cover
    the body's start.  There the local ratio
    (:meth:`~splicer.align.evidence.Evidence.local_ratio`) runs above 1, though not in every
    frame.  From each such end, with ``r`` the ratios walking inwards (NaN: 0 excess)::

        S(k) = sum_{i < k} (r_i - ratio_above)

    the ``k`` maximising ``S`` is taken when ``k`` lasts at least ``min_s`` seconds and ``S(k)``
    exceeds ``margin_s`` seconds' worth of excess 1 (``margin_s * fps``); never through a pin (the
    walk stops before the first).  Nothing is taken when the two ends' stretches would leave less
    than ``min_s`` of the span (nothing left that they lead to: a pair unmatched throughout is the
    check against the hands played backwards' business, :func:`splicer.align.evidence.match_evidence`).

    Parameters
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        Hands-file frame of each body frame; NaN where uncovered (a single covered span).
    ratio : np.ndarray [shape=(n,)]
        As :func:`unmatched_edges`.
    fps : float
        Body frames per second.
    min_s, ratio_above, margin_s : float
        Shortest stretch, seconds (0: none is taken); the ratio its frames exceed on the whole;
        the excess it must add up to, seconds of excess 1.
    beyond_s : float
        An end counts as the body's own with at most this many seconds of uncovered frames past it.
    pinned : iterable of int
        Body frames of the pins: never taken.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=bool]

    Examples
    --------
    >>> hf = np.arange(10.0)
    >>> ratio = np.array([1.4, 1.3, 0.9, 1.4, 1.1, 0.5, 0.4, 0.5, 0.6, 0.5])
    >>> unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, margin_s=0.05).astype(int).tolist()  # 0.9 inside: kept going
    [1, 1, 1, 1, 1, 0, 0, 0, 0, 0]
    >>> unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, margin_s=0.15).astype(int).tolist()  # excess 1.1 < 1.5
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    >>> unmatched_body_ends(hf, ratio, 10.0, min_s=0.3, margin_s=0.05, pinned=[2]).astype(int).tolist()  # a pin
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    """
    h = np.asarray(hands_frame, dtype=np.float64)
    r = np.asarray(ratio, dtype=np.float64)
    if h.ndim != 1 or r.shape != h.shape:
        raise ValueError(f"hands_frame and ratio must have one shape (n,), got {h.shape}, {r.shape}")
    if not (fps > 0 and np.isfinite(fps)) or not all(x >= 0 and np.isfinite(x) for x in (min_s, ratio_above, margin_s,
                                                                                       beyond_s)):
        raise ValueError(f"fps must be positive and min_s, ratio_above, margin_s, beyond_s >= 0 (all finite), got "
                         f"{fps!r}, {min_s!r}, {ratio_above!r}, {margin_s!r}, {beyond_s!r}")
    n = len(h)
    out = np.zeros(n, dtype=bool)
    cov = np.flatnonzero(np.isfinite(h))
    if len(cov) == 0 or min_s == 0:
        return out
    a, b = int(cov[0]), int(cov[-1])
    need = max(1, int(round(min_s * fps)))
    excess = np.where(np.isfinite(r), r - ratio_above, 0.0)
    pins = _pin_mask(pinned, n)
    for past, step in ((a, 1), (n - 1 - b, -1)):
        if past > beyond_s * fps:
            continue
        idx = np.arange(a, b + 1)[::step]  # the span, walking inwards from this end
        stop = np.flatnonzero(pins[idx])
        walk = idx[:stop[0]] if len(stop) else idx[:-1]  # before the first pin; never the whole span
        if len(walk) < need:
            continue
        total = np.cumsum(excess[walk])
        k = int(np.argmax(total)) + 1
        if k >= need and total[k - 1] > margin_s * fps:
            out[walk[:k]] = True
    if (b - a + 1) - int(out.sum()) < need:  # the two ends leave too little: nothing the stretches lead to
        out[:] = False
    return out


def _pin_mask(pinned, n: int) -> np.ndarray:
    """Body frames of the pins as a mask over ``n`` frames (pins outside them ignored)."""
    pins = np.zeros(n, dtype=bool)
    pins[np.asarray([p for p in pinned if 0 <= p < n], dtype=np.int64)] = True
    return pins


def _edge_runs(h: np.ndarray, flag: np.ndarray, fps: float, min_s: float, pinned, beyond_s: float = 0.0) -> np.ndarray:
    """The runs of ``flag`` from an end of the covered span (finite ``h``) inside the body (more
    than ``beyond_s`` seconds of uncovered frames past it), at least ``min_s`` seconds, stopped
    by a covered frame not flagged and not pinned (:func:`unsure_edges`)."""
    if not (fps > 0 and np.isfinite(fps)) or not (min_s >= 0 and np.isfinite(min_s)):
        raise ValueError(f"fps must be positive and min_s >= 0, got {fps!r}, {min_s!r}")
    n = len(h)
    out = np.zeros(n, dtype=bool)
    cov = np.flatnonzero(np.isfinite(h))
    if len(cov) == 0 or min_s == 0:
        return out
    need = max(1, int(round(min_s * fps)))
    flag = np.isfinite(h) & flag
    pins = _pin_mask(pinned, n)
    flag &= ~pins
    a, b = int(cov[0]), int(cov[-1])
    past = beyond_s * fps  # uncovered frames past an end: more than this
    starts, stops = true_runs(flag)  # flagged runs [lo, hi); the frame past each end stops it
    for lo, hi in zip(starts.tolist(), stops.tolist()):
        at_start = lo == a and a > past and hi <= b  # from the span's first frame, stopped inside it
        at_end = hi == b + 1 and n - 1 - b > past and lo > a  # up to the span's last frame, stopped inside it
        stop = hi if at_start else lo - 1
        if (at_start or at_end) and hi - lo >= need and not pins[stop]:  # stopped by a kept, unpinned frame
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
    """Each side's :func:`unsure_edges`, then its :func:`unmatched_edges` and
    :func:`unmatched_body_ends`, taken as uncovered (after the risk stage, before
    :func:`mark_coverage_edges`).

    Parameters
    ----------
    sides : dict of str -> SideResult
    opts : SpliceOptions, optional
        ``unsure_edge_s``, ``unmatched_edge_s`` (0: that rule is off).
    log : Log, optional
        Receives one note per side and rule that changed it.

    Returns
    -------
    dict of str -> SideResult
        A side that changed has NaN in ``hands_frame`` there, its alignment's ``covered``
        span narrowed and its confidence uncovered there
        (:meth:`~splicer.align.confidence.Confidence.uncovered_at`); the others unchanged.
        The unmatched stretches need the check against the hands take played backwards
        (``alignment.evidence`` with its rows): without it, only the unsure ones are taken.
    """
    min_s = UNSURE_EDGE_S if opts is None else opts.unsure_edge_s
    unmatched_s = UNMATCHED_EDGE_S if opts is None else opts.unmatched_edge_s
    out = {}
    for s, r in sides.items():
        conf = r.alignment.confidence
        if conf is None or r.alignment.covered is None:
            out[s] = r
            continue
        fps = r.markers.spaces.body_fps
        pinned = [p.body for p in r.pins]
        hf = np.asarray(r.hands_frame, dtype=np.float64)
        take = unsure_edges(hf, conf.est_error_s, fps, min_s=min_s, error_s=error_s, pinned=pinned)
        notes = []
        if take.any():
            notes.append((take, f"the alignment there is unsure throughout (estimated error over {error_s:g} s for at "
                                f"least {min_s:g} s)"))
        ev, own, alike = r.alignment.evidence, None, []
        ratio = None if ev is None or not unmatched_s else ev.local_ratio(len(hf), fps, UNMATCHED_WINDOW_S)
        hf = np.where(take, np.nan, hf)  # the unsure stretches out: the unmatched ones start where they stop
        if ratio is not None:
            mis = _side_mismatch_once(r)  # read only where a ratio rule would take a stretch
            more = unmatched_edges(hf, ratio, fps, min_s=unmatched_s, ratio_above=UNMATCHED_RATIO,
                                   beyond_s=COVERAGE_EDGE_S, pinned=pinned)
            more = _unless_alike(more, mis, alike)
            if more.any():
                take = take | more
                hf = np.where(more, np.nan, hf)
                notes.append((more, f"the hands' material matched there fits the body no better than the hands take "
                                    f"played backwards (over {100 * UNMATCHED_RATIO:.0f}% of its cost for at least "
                                    f"{unmatched_s:g} s)"))
            own = _unless_alike(unmatched_body_ends(hf, ratio, fps, min_s=unmatched_s, pinned=pinned), mis, alike)
            if own.any():
                take = take | own
                hf = np.where(own, np.nan, hf)
                notes.append((own, f"the hands' material matched there fits the body worse than the hands take played "
                                   f"backwards (over {100 * UNMATCHED_OWN_RATIO:.0f}% of its cost on the whole, for at least "
                                   f"{unmatched_s:g} s)"))
        if log is not None:
            for a, b, m in alike:
                log.note(f"{s} side: the hands' material matched to body frames {a}-{b} ({(b - a + 1) / fps:.1f} s) fits "
                         f"the body no better than the hands take played backwards, but the hand moves relative to "
                         f"the forearm alike in both takes there (mismatch {m:.2f}, the median; under "
                         f"{JUDGE_UNCOVERED:g}): it stays covered")
        if not take.any():
            out[s] = r
            continue
        cov = np.flatnonzero(np.isfinite(hf))
        aln = replace(r.alignment, covered=(int(cov[0]), int(cov[-1])), confidence=conf.uncovered_at(take))
        out[s] = replace(r, hands_frame=hf, alignment=aln)
        if log is not None:
            from ..transfer.timemap import frame_ranges

            for mask, why in notes:
                spans = ", ".join(f"{a}-{b} ({(b - a + 1) / fps:.1f} s)" for a, b in frame_ranges(mask))
                where = "at the body's own start or end" if mask is own else "next to the uncovered ones"
                log.note(f"{s} side: body frames {spans} {where} are taken as uncovered: {why}, "
                         "as where the hands take holds material from outside the body's performance")
    return out


def _side_mismatch_once(r):
    """A call that reads the side's hand-in-forearm mismatch (:func:`splicer.stages.recheck.side_mismatch`)
    the first time it is made and returns it again after; None where that signal does not compare
    (:func:`splicer.stages.recheck.forearm_motion_compares`)."""
    from functools import cache

    from .recheck import forearm_motion_compares, side_mismatch

    return cache(lambda: side_mismatch(r) if forearm_motion_compares({"side": r.markers}) else None)


def _unless_alike(mask: np.ndarray, mismatch_of, kept: list) -> np.ndarray:
    """``mask`` without its runs along which the hand moves relative to the forearm alike in both
    takes (the median of the readable frames of ``mismatch_of()`` under
    :data:`~splicer.defaults.JUDGE_UNCOVERED`: material worth covering, as the judge prices it);
    each run kept is appended to ``kept`` as ``(first, last, median)``.  ``mismatch_of`` is called
    only when ``mask`` has a run; it returning None (the signal does not compare): ``mask`` as it is.

    Examples
    --------
    >>> kept = []
    >>> mask = np.array([1, 1, 1, 0, 1, 1], dtype=bool)
    >>> reads = np.array([0.1, np.nan, 0.2, 0.0, 0.9, 1.2])
    >>> _unless_alike(mask, lambda: reads, kept).astype(int).tolist()
    [0, 0, 0, 0, 1, 1]
    >>> [(a, b, round(m, 2)) for a, b, m in kept]
    [(0, 2, 0.15)]
    """
    if not mask.any():
        return mask
    mismatch = mismatch_of()
    if mismatch is None:
        return mask
    out = mask.copy()
    for a, b in zip(*true_runs(mask)):
        read = mismatch[a:b][np.isfinite(mismatch[a:b])]
        if len(read) and np.median(read) < JUDGE_UNCOVERED:
            out[a:b] = False
            kept.append((int(a), int(b - 1), float(np.median(read))))
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
