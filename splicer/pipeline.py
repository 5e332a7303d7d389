"""The whole job as stages: load -> rig -> markers -> align -> time map -> cross-check -> time map
weighed by the expected path's spread -> the wrist's refinement -> (a noisy pair: a second opinion)
-> risk -> coverage edges -> transfer -> report.

:func:`splice` composes the stages of :mod:`splicer.stages` (one module each); each stage is
a function with a typed, frozen result, usable on its own (notebooks, other tools), and
importable from here.  Frame-space conversions live in :mod:`splicer.align.frames`; options
in :mod:`splicer.options`.
"""

from __future__ import annotations

from dataclasses import replace

from .options import SpliceOptions, resolve_options
# the private names are used by splice-markers, pairing, the plot and the tests
from .stages.align import Alignment, _choose_ends, _cover_pins, _pin_error, agree_ends, align_pair, align_side, phase_smoothing  # noqa: F401
from .stages.coverage import coverage_edges, mark_coverage_edges, uncover_unsure_edges, unsure_edges
from .stages.crosscheck import cross_check, hands_disagreement
from .stages.overlap import both_skip_options, check_both_skip
from .stages.recheck import position_second_opinion
from .stages.risk import estimate_risk
from .stages.load import Inputs, load_inputs
from .stages.log import Log
from .stages.markers import SideMarkers, _align_up, side_markers  # noqa: F401
from .stages.report import LOW_CONFIDENCE_S, SideResult, SpliceResult, _coverage_report, build_report  # noqa: F401
from .stages.rig import Conditioned, Rig, condition_hands, find_rig
from .stages.transfer import Transfer, check_fingers, refine_time_maps, time_map, transfer_side, trend_time_maps

__all__ = ["Inputs", "Rig", "Conditioned", "SideMarkers", "Alignment", "Transfer", "SideResult", "SpliceResult", "Log",
           "load_inputs", "find_rig", "condition_hands", "side_markers", "phase_smoothing", "align_side", "align_pair", "agree_ends", "time_map", "trend_time_maps", "refine_time_maps", "transfer_side",
           "check_fingers", "cross_check", "hands_disagreement", "position_second_opinion", "estimate_risk", "unsure_edges", "uncover_unsure_edges", "coverage_edges", "mark_coverage_edges", "build_report",
           "splice"]



def splice(body, hands, *, config=None, options: SpliceOptions | None = None, progress=None,
           body_markers=None, hands_markers=None, **overrides) -> SpliceResult:
    """Splice the hands capture's finger motion onto the body capture.

    Parameters
    ----------
    body, hands : Motion or path
        The full-body take and the hand take (a full skeleton, a forearm-rooted or a
        wrist-rooted hand).
    config : SpliceConfig or path, optional
        Pins, joint mappings and up axes (the constraints file, see :mod:`splicer.constraints`).
    options : SpliceOptions, optional
        All options at once; keyword ``overrides`` (fields of :class:`SpliceOptions`) win.
    progress : callable, optional
        ``progress(stage: str, fraction: float)``, called often during long stages.
    body_markers, hands_markers : path or Trajectories, optional
        Optical markers (C3D, TRC, CSV) captured with a take, on its timeline (row 0 at its
        frame 0, at their own rate): the alignment uses them instead of that take's virtual
        markers (:mod:`splicer.marker_roles`); the fingers still come from the BVH.

    Returns
    -------
    SpliceResult
        ``.motion``: the body take with the hands' fingers; ``.report``: a :class:`Report`
        (``.to_dict()`` is the JSON); ``.sides``: each side's markers and alignment.

    Examples
    --------
    >>> import splicer
    >>> r = splicer.splice("motions/sample_body.bvh", "motions/sample_hands.bvh", side="left")  # doctest: +SKIP
    """
    opts = resolve_options(options, overrides)
    log = Log(progress)
    inputs = load_inputs(body, hands, config, log, body_markers=body_markers, hands_markers=hands_markers)
    rig = find_rig(inputs, opts, log)
    checked = condition_hands(inputs, rig, opts, log)
    inputs, out, sides = checked.inputs, checked.inputs.body, {}
    ends = opts.ends or inputs.config.ends or "auto"
    offset_s = opts.offset_s if opts.offset_s is not None else inputs.config.offset_s
    marks = {s: side_markers(inputs, rig, s, log) for s in rig.sides}

    def realign(o, lg, markers=None):  # both arms; one noise decision
        return align_pair(marks if markers is None else markers, o, lg, ends=ends, offset_s=offset_s)

    def finish(aligned, lg):
        sides = {s: SideResult(s, time_map(aligned[s], marks[s], opts), marks[s], aligned[s]) for s in rig.sides}
        lg.tick("time map")
        sides = cross_check(sides, lg)  # both hands come from one take: where their time maps part, one is off
        lg.tick("cross-check")
        sides = trend_time_maps(sides, opts)  # each map weighed by the expected path's spread, the tempo drifting smoothly
        lg.tick("trend")
        sides = refine_time_maps(sides, opts, lg)  # the hand's motion relative to the forearm: the last frame or two
        lg.tick("wrist")
        return sides

    since = len(log.warnings)
    first = both_skip_options(marks, opts)  # open ends past both takes' heads only where they can be checked
    sides = finish(realign(first, log), log)
    if opts.both_skip == "auto":  # the takes overlapping partly (both heads or tails skipped): checked
        sides, first, since = check_both_skip(sides, first, log, realign=realign, finish=finish, since=since)
    # a noisy pair: aligned again with the positions weighed more, the better-matching maps kept
    sides = position_second_opinion(sides, first, log, realign=realign, finish=finish, since=since)
    sides = estimate_risk(sides)  # every signal weighed together: the error's 98th percentile per frame
    sides = uncover_unsure_edges(sides, opts, log)  # unsure stretches next to uncovered frames: other material
    sides = mark_coverage_edges(sides)  # where the hands' material starts or stops: located to a few frames
    log.tick("risk")
    for s, r in sides.items():
        transfer = transfer_side(out, inputs, rig, s, r.alignment, r.hands_frame, opts, log, pins=r.pins)
        sanity = check_fingers(transfer, s, inputs, rig, r.hands_frame, checked.report["handedness"], log)
        out = transfer.motion
        sides[s] = replace(r, joints=transfer.joints, extra={**r.extra, **transfer.extra, **sanity})
    report = build_report(inputs, opts, sides, log,
                          extra={**checked.report, "up": {k: u.as_dict() for k, u in rig.up.items()}})
    log.progress("done", 1.0)
    return SpliceResult(out, report, sides)
