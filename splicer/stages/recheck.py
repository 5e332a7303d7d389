"""Stage 6c, a second opinion: a noisy pair aligned again with the arms' positions weighed more.

Where noise matching smoothed the pair (a second performance, a jittery solve), pass 1 weighs
the arms' shoulder-relative positions by :data:`splicer.defaults.POSITION_WEIGHT_NOISY` beside
D1's direction signs (:func:`splicer.stages.align.position_weights`).  Where the arm's noise
leaves the signs little to go by (a slow gesture: the noise per frame is as large as the
motion), a larger weight can be far better, and elsewhere a little worse.  So the pair is aligned
again at :data:`splicer.defaults.POSITION_WEIGHT_RECHECK`, its time maps made as the first's
were (smoothed, refined by the wrist), and the pair of maps along which the hand moves relative
to the forearm more alike in both takes (:func:`splicer.align.wrist.rate_mismatch`: a signal
pass 1 does not read, which the arm's noise leaves clean) is kept, with a note.  Measured on the
ground-truth protocol (benchmarks/HISTORY.md, 0.18.0).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import defaults as D
from ..options import SpliceOptions
from .log import Log

__all__ = ["wants_second_opinion", "map_mismatch", "position_second_opinion"]


def wants_second_opinion(sides: dict, opts: SpliceOptions) -> bool:
    """Whether the pair gets a second opinion: two sides whose pass 1 weighed positions by
    noise matching's weight (``position_weight="auto"``: no hand-only file, no optical markers),
    whose hand-in-forearm motion compares (:func:`splicer.align.wrist.markers_compare`), whose takes may show one performance (the check against the hands played
    backwards did not find the alignment no better than unrelated material: another weight
    would not make it so), and the check not switched off (``POSITION_WEIGHT_RECHECK`` 0)."""
    from ..align.wrist import markers_compare
    from .align import _unmatched

    if len(sides) != 2 or opts.position_weight != "auto" or not D.POSITION_WEIGHT_RECHECK > 0:
        return False
    for r in sides.values():
        p1, mk = r.alignment.pass1, r.markers
        if p1 is None or getattr(p1, "position_weight", None) != D.POSITION_WEIGHT_NOISY:
            return False
        if _unmatched(getattr(r.alignment, "evidence", None)):
            return False
        if mk.hand_only or mk.real or not markers_compare(mk.placed, mk.body.points, mk.hands.points):
            return False
    return True


def map_mismatch(sides: dict, frames: np.ndarray) -> float:
    """Mean over the sides of :func:`splicer.align.wrist.rate_mismatch` along each side's time
    map over the body frames ``frames`` (a contiguous run every side covers; NaN: too few)."""
    from ..align.wrist import rate_mismatch

    vals = []
    for r in sides.values():
        sp = r.markers.spaces
        c = sp.hands_to_common(np.asarray(r.hands_frame, dtype=np.float64)[frames])
        vals.append(rate_mismatch(r.markers.body.points[frames], r.markers.hands.points, c, fps=sp.body_fps,
                                  smooth_s=D.WRIST_SMOOTH_S))
    return float(np.mean(vals)) if vals else float("nan")


def position_second_opinion(sides: dict, opts: SpliceOptions, log: Log, *, realign, finish, since: int) -> dict:
    """Keep the first pair of time maps or the second opinion's, whichever the hand's motion
    relative to the forearm matches better along.

    Parameters
    ----------
    sides : dict of str -> SideResult
        The pair's time maps after the wrist's refinement (:func:`splicer.stages.transfer.refine_time_maps`).
    opts : SpliceOptions
    log : Log
        Its warnings from ``since`` on (the first alignment's) are replaced by the second's when
        that is kept.
    realign : callable
        ``realign(opts, log) -> dict of Alignment``: the pair aligned with ``opts``
        (:func:`splicer.stages.align.align_pair`).
    finish : callable
        ``finish(aligned, log) -> dict of SideResult``: the time-map stages that made ``sides``.

    Returns
    -------
    dict of str -> SideResult
        ``sides`` itself when the pair does not qualify (:func:`wants_second_opinion`) or the
        second opinion matches no better.
    """
    if not wants_second_opinion(sides, opts):
        return sides
    second = Log(log._progress)  # the other choice's own notes, kept only with its alignment
    other = finish(realign(replace(opts, position_weight=D.POSITION_WEIGHT_RECHECK), second), second)
    log.tick("position second opinion")
    both = None
    for pair in (sides, other):
        for r in pair.values():
            f = np.isfinite(np.asarray(r.hands_frame, dtype=np.float64))
            both = f if both is None else both & f
    frames = np.flatnonzero(both)
    if len(frames) < 3 or frames[-1] - frames[0] + 1 != len(frames):
        return sides
    first, again = map_mismatch(sides, frames), map_mismatch(other, frames)
    if not again < first:
        return sides
    del log.warnings[since:]
    log.warnings.extend(second.warnings)
    log.note(f"the arms' motion looked noisy, so the pair was also aligned with the arms' positions weighed "
             f"{D.POSITION_WEIGHT_RECHECK:g} instead of {D.POSITION_WEIGHT_NOISY:g}; along that alignment the hand "
             f"moves relative to the forearm more alike in both takes (mismatch {again:.3f} against {first:.3f}), "
             f"and it is kept")
    return other
