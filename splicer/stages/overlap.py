"""Stage 6c, first, a partial overlap checked: open ends that skipped both takes' heads (or tails) at once.

Open-ended, the takes may overlap partly: the hands take starts with extra material *and* after
the body's first frame (or likewise at the end).  Pass 1 may then start (end) past both takes'
first (last) frames at once, each hands frame skipped beside an uncovered body row costing a share
of the uncovered penalty (:data:`splicer.defaults.BOTH_SKIP_WEIGHT`, since 0.33.0;
:func:`splicer.align.dtw.dtw`'s ``both_skip_cost``).  Before, a path started on one take's first
frame, so the other take's extra head was squeezed onto the body (``SpliceOptions.both_skip``
``"off"``).  But where the hands performer is slow over the genuine start, dropping it can cost
less than covering it, and the path then starts seconds into the genuine material.  So with
``both_skip="auto"`` (the default), where the first alignment skipped both at either end
(:func:`skipped_both`), the pair is aligned again with ``"off"``'s ends, and the alignment along
which the hand moves relative to the forearm more alike in both takes (a signal pass 1 does not
read), judged frame by frame over the body frames either covers, a frame left uncovered at a fixed
price (:func:`splicer.stages.recheck.coverage_mismatch`, since 0.34.0; before, each along the frames
it covered itself), is kept; the rest of the splice (its second opinions) aligns as the kept one did.  Where that
cannot be read (a hand-only file, optical markers, markers that do not compare:
:func:`splicer.stages.recheck.forearm_motion_compares`), the pair is aligned on one take's ends from the start
(:func:`both_skip_options`), as before 0.33.0.  Measured on the ground-truth protocol
(benchmarks/HISTORY.md, 0.33.0).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import defaults as D
from ..options import SpliceOptions
from .log import Log
from .recheck import coverage_mismatch, forearm_motion_compares

__all__ = ["skipped_both", "both_skip_options", "check_both_skip"]


def skipped_both(sides: dict) -> bool:
    """Whether some side's pass 1 (its full-rate pass or its locating pass) started or ended past
    both takes' first or last frames at once (:meth:`splicer.align.passes.PassResult.skipped_both`)."""
    for r in sides.values():
        p = r.alignment.pass1
        for q in (p, getattr(p, "located", None)):
            if q is not None and q.skipped_both():
                return True
    return False


def both_skip_options(markers: dict, opts: SpliceOptions) -> SpliceOptions:
    """The first alignment's options: ``both_skip="auto"`` becomes ``"on"`` where the check can be
    read (:func:`splicer.stages.recheck.forearm_motion_compares`; then :func:`check_both_skip`), else
    ``"off"``, as before 0.33.0.
    (The alignment stages read ``"auto"`` as ``"off"``: :func:`splicer.stages.align.both_skip_weight`.)"""
    if opts.both_skip != "auto":
        return opts
    return replace(opts, both_skip="on" if forearm_motion_compares(markers) else "off")


def check_both_skip(sides: dict, opts: SpliceOptions, log: Log, *, realign, finish,
                    since: int) -> tuple[dict, SpliceOptions, int]:
    """Keep an alignment that skipped both takes' heads (tails) at once, or the one-take ends' one.

    Parameters
    ----------
    sides : dict of str -> SideResult
        The first alignment's time maps (:func:`splicer.stages.transfer.refine_time_maps`), aligned
        with ``opts`` (``both_skip="on"`` from :func:`both_skip_options`; else nothing to check).
    opts : SpliceOptions
    log : Log
        Its warnings from ``since`` on (the first alignment's) are replaced by the kept one's.
    realign, finish : callable
        As :func:`splicer.stages.recheck.position_second_opinion`'s.
    since : int

    Returns
    -------
    sides : dict of str -> SideResult
        ``sides`` itself, or the pair aligned with ``both_skip="off"``.
    opts : SpliceOptions
        The options the rest of the splice aligns with: ``opts``, or ``both_skip="off"``'s.
    since : int
        Where the kept alignment's own notes now start: the check's note goes before them (a
        second opinion that replaces them keeps it).
    """
    if opts.both_skip != "on" or not skipped_both(sides):
        return sides, opts, since
    off = replace(opts, both_skip="off")
    lg = log.aside("one take's ends")
    other = finish(realign(off, lg), lg)
    both, one = coverage_mismatch([sides, other])
    keep_both = bool(np.isfinite(both) and (not np.isfinite(one) or both <= one))
    log.tick("partial-overlap check")
    what = ("the open ends skipped both takes' first (or last) frames at once (the takes overlap partly); along "
            "that alignment the hand moves relative to the forearm {} alike in both takes than along one starting "
            f"and ending on one take's first and last frames (mismatch {both:.3f} against {one:.3f}, frame by frame "
            f"over the body frames either covers, a frame left uncovered counting {D.JUDGE_UNCOVERED:g}): ")
    if keep_both:
        log.warnings.insert(since, what.format("more") + "it is kept")
        return sides, opts, since + 1
    del log.warnings[since:]
    log.warnings.append(what.format("less") + "the other is kept")
    log.warnings.extend(lg.warnings)
    return other, off, since + 1
