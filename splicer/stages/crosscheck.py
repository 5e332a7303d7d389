"""Stage 6b, cross-check: the two hands' time maps checked against each other.

Both hands come from one hands take, on one clock.  Aligned each on its own arm (the paper,
``pass1_arms="each"``), where their time maps disagree at least one of them is off: measured on
the ground-truth protocol (README *Accuracy*; benchmarks/HISTORY.md), the strongest sign of a badly aligned frame
such an alignment has.  Aligned with one pass 1 for both arms (the default), the sides' maps
part only where pass 2 does, and the check is how far that shared path lies from each arm's
own path in its band (:func:`arms_departure`).  Each side's estimated error becomes the larger
of its own (the expected path's spread) and the disagreement; after one pass 1 for both arms,
the next stage (:mod:`splicer.stages.risk`) weighs it with the other signals into the error's
95th percentile.  The report's ``disagree`` ranges name the stretches where the hands part; the
output motion is not changed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .log import Log
from .report import LOW_CONFIDENCE_S, _worst_ranges

__all__ = ["hands_disagreement", "arms_departure", "sides_disagreement", "cross_check"]


def hands_disagreement(hands_frame_a, hands_frame_b, hands_fps: float) -> np.ndarray:
    """Per body frame, seconds of hands time between two sides' time maps.

    Parameters
    ----------
    hands_frame_a, hands_frame_b : np.ndarray [shape=(n,)]
        Hands-file frame (fractional; NaN where uncovered) of each body frame, per side.
    hands_fps : float
        Frame rate of the hands take, frames per second.

    Returns
    -------
    np.ndarray [shape=(n,)]
        ``|a - b| / hands_fps``; NaN where either side is uncovered.

    Examples
    --------
    >>> hands_disagreement(np.array([0.0, 12.0, np.nan]), np.array([0.0, 24.0, 5.0]), 120.0).tolist()
    [0.0, 0.1, nan]
    """
    a = np.asarray(hands_frame_a, dtype=np.float64)
    b = np.asarray(hands_frame_b, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"both time maps must have one shape (n,), got {a.shape} and {b.shape}")
    if not (hands_fps > 0 and np.isfinite(hands_fps)):
        raise ValueError(f"hands_fps must be positive and finite, got {hands_fps!r}")
    return np.abs(a - b) / float(hands_fps)


def arms_departure(a, b, body_fps: float) -> np.ndarray | None:
    """Per body frame, seconds between pass 1's expected path over both arms and the farther
    of the two arms' own paths in its band (:func:`splicer.align.passes.arm_paths`).

    One pass 1 for both hands gives both sides the same pass-1 time map, so the two sides'
    final maps part only where pass 2 does; what each arm's motion says alone is the check
    that remains.  Where the shared path lies far from one arm's own path, that arm's motion
    says otherwise there, and one of them is wrong.  Measured on the ground-truth protocol
    (tuning seeds 0-3, all nine scenarios, both takes): with this departure, 72 % / 82 % of the
    frames whose true error exceeds 0.1 s are flagged (zeggs / synthetic), against 25 % / 31 %
    with the sides' final maps alone; 18 % / 21 % of those within 0.05 s are (README *Accuracy*; benchmarks/HISTORY.md).

    Parameters
    ----------
    a, b : Alignment
        The two sides' alignments (``own`` and ``posterior`` set when pass 1 weighed both arms).
    body_fps : float
        The common frames' rate (pass 1 aligns at the body rate).

    Returns
    -------
    np.ndarray [shape=(n,)] or None
        NaN where neither arm's path or the expected path covers the frame; None when either
        side has no own path (each side had its own pass 1) or no expected path.
    """
    if a.own is None or b.own is None or a.posterior is None:
        return None
    mean = np.asarray(a.posterior.mean, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.fmax(np.abs(a.own - mean), np.abs(b.own - mean)) / float(body_fps)


def sides_disagreement(map_a, map_b, map_fps: float, a, b, body_fps: float) -> tuple[np.ndarray, bool]:
    """Per body frame, seconds by which the two sides disagree: their time maps ``map_a``, ``map_b``
    (frames at ``map_fps``) apart (:func:`hands_disagreement`) or, after one pass 1 for both arms
    (alignments ``a``, ``b``), the larger of that and :func:`arms_departure`.

    Returns
    -------
    (np.ndarray [shape=(n,)], bool)
        The disagreement, and whether the arms' departure is part of it.
    """
    d = hands_disagreement(map_a, map_b, map_fps)
    dev = arms_departure(a, b, body_fps)
    if dev is None:
        return d, False
    return np.fmax(d, dev), True  # one pass 1 for both arms: the sides part only in pass 2; the arms' own paths tell


def cross_check(sides: dict, log: Log | None = None) -> dict:
    """Fold the hands' disagreement into each side's confidence (two sides, both with one).

    Parameters
    ----------
    sides : dict of str -> SideResult
        The finished sides of a splice (:func:`splicer.pipeline.splice`).
    log : Log, optional
        Receives a summary note when the hands disagree by more than
        :data:`splicer.stages.report.LOW_CONFIDENCE_S` (the report's ``disagree`` ranges).

    Returns
    -------
    dict of str -> SideResult
        The same sides; with two sides that both have a confidence, each alignment's
        confidence is :meth:`~splicer.align.confidence.Confidence.with_disagreement` of the
        other side's time map.  One side, or a side without a confidence: unchanged.
    """
    from ..transfer.timemap import frame_ranges

    log = log or Log()
    if len(sides) != 2 or any(r.alignment.confidence is None for r in sides.values()):
        return dict(sides)
    (sa, ra), (sb, rb) = sides.items()
    fps = ra.markers.spaces.hands_fps
    d, shared = sides_disagreement(ra.hands_frame, rb.hands_frame, fps, ra.alignment, rb.alignment,
                                   ra.markers.spaces.body_fps)
    out = {}
    for s, r in ((sa, ra), (sb, rb)):
        conf = r.alignment.confidence.with_disagreement(d)
        out[s] = replace(r, alignment=replace(r.alignment, confidence=conf))
    apart = frame_ranges(np.nan_to_num(d, nan=0.0) > LOW_CONFIDENCE_S, min_gap=2)
    if apart:
        n = len(d)
        worst = _worst_ranges(apart, d)
        where = ", ".join(f"{a}-{b} (up to {np.nanmax(d[a:b + 1]):.2f} s)" for a, b in worst)
        share = sum(b - a + 1 for a, b in apart) / n
        if not shared:
            log.note(f"the {sa} and {sb} hands' alignments disagree by more than {LOW_CONFIDENCE_S:g} s in "
                     f"{100 * share:.0f}% of body frames ({where}): one of them is off there; both sides count "
                     "those frames as low confidence")
        else:
            log.note(f"the {sa} and {sb} arms' motions disagree about the timing by more than {LOW_CONFIDENCE_S:g} s "
                     f"in {100 * share:.0f}% of body frames ({where}): the alignment weighs both, and may be off "
                     "there (the estimated error weighs this with the other signals)")
    return out
