"""Stage 7, report: each side's result and the typed report."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..defaults import COVERAGE_EDGE_S
from ..align.holds import hold_ranges
from ..model.motion import Motion
from ..options import SpliceOptions
from ..report import Report, SideReport
from .markers import SideMarkers
from .log import Log
from .load import Inputs
from .align import Alignment

__all__ = ['SideResult', 'SpliceResult', 'LOW_CONFIDENCE_S', 'LOW_CONFIDENCE_JOIN_S', 'low_confidence_ranges',
           'build_report', 'estimate_text']


# ---------------------------------------------------------------- stage 7: report

@dataclass(frozen=True, eq=False)
class SideResult:
    """Everything about one side: markers, alignment, time map.

    Attributes
    ----------
    hands_frame : np.ndarray [shape=(n_body,)]
        0-based, possibly fractional hands-file frame used for each body frame.
    """

    side: str
    hands_frame: np.ndarray
    markers: SideMarkers
    alignment: Alignment
    joints: dict = field(default_factory=dict)  # output joint -> hands joints driving it
    extra: dict = field(default_factory=dict)  # JSON-ready report keys of later stages
    trend: object = None  # the time map's smoother (splicer.transfer.trend.TrendFit), once the trend stage ran
    wrist: object = None  # the wrist's refinement (splicer.align.wrist.WristEvidence), where it ran

    @property
    def pass1(self):
        return self.alignment.pass1

    @property
    def pass2(self):
        return self.alignment.pass2

    @property
    def pins(self) -> tuple:
        return self.markers.pins

    @property
    def body_markers(self):
        return self.markers.body

    @property
    def hands_markers(self):
        return self.markers.hands

    @property
    def rate_ratio(self) -> float:
        return self.markers.spaces.ratio

    def __repr__(self) -> str:
        return f"SideResult(side={self.side!r}, body_frames={len(self.hands_frame)}, pins={len(self.pins)})"


@dataclass(frozen=True, eq=False)
class SpliceResult:
    """The output motion, the report, and each side's intermediate results."""

    motion: Motion
    report: Report
    sides: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        return (f"SpliceResult(motion={self.motion.n_frames} frames x {self.motion.skeleton.n_joints} joints, "
                f"sides={sorted(self.sides)}, warnings={len(self.report.warnings)})")


#: estimated alignment error above which a body frame is "low confidence", seconds: the
#: finger-to-body desynchronisation viewers notice (Joerg, Hodgins & O'Sullivan 2010)
LOW_CONFIDENCE_S = 0.1
#: ... and low-confidence stretches less than this apart (seconds of covered body frames) are one
#: range (0.30.0; before, 2 frames): an island of a few frames whose estimate dips under the limit
#: between two flagged stretches is no alignment to trust (synthetic *all*, tuning seed 28: 16
#: frames between two flagged stretches, up to 1.7 s off, at confidence 0.51).  Tuning seeds 0-4
#: and 5-9, the nine scenarios, of the frames over 0.1 s off flagged 87.1 / 85.2 -> 92.9 / 90.3 %
#: (synthetic) and 87.8 / 91.0 -> 94.3 / 92.2 % (zeggs), of those under 0.05 s 7.6 / 7.4 -> 8.7 /
#: 8.6 % and 5.3 / 7.4 -> 6.0 / 8.7 % (0.5 s: about half of each change; benchmarks/HISTORY.md, 0.30.0).
LOW_CONFIDENCE_JOIN_S = 1.0


def low_confidence_ranges(est_error_s: np.ndarray, fps: float) -> list[list[int]]:
    """The ``[first, last]`` body-frame ranges whose estimated error exceeds :data:`LOW_CONFIDENCE_S`,
    those less than :data:`LOW_CONFIDENCE_JOIN_S` apart joined, never across an uncovered frame
    (NaN estimate).

    Examples
    --------
    >>> est = np.array([0.2, 0.0, 0.0, 0.3, 0.0, np.nan, 0.2, 0.0, 0.0, 0.0, 0.0, 0.2])
    >>> low_confidence_ranges(est, fps=3.0)  # joined across 2 covered frames (< 1 s), not across the NaN
    [[0, 4], [6, 6], [11, 11]]
    """
    from ..transfer.timemap import frame_ranges

    est = np.asarray(est_error_s, dtype=np.float64)
    covered = np.isfinite(est)
    gap = max(int(round(LOW_CONFIDENCE_JOIN_S * fps)) - 1, 0)  # at most this many frames between: under the join
    joined = np.zeros(len(est), dtype=bool)
    for a, b in frame_ranges(np.nan_to_num(est, nan=0.0) > LOW_CONFIDENCE_S, min_gap=gap):
        joined[a:b + 1] = True
    return frame_ranges(joined & covered)


def estimate_text(error_s: float) -> str:
    """An estimated error as the summary states it: ``"~0.25 s"``, or ``"over 0.4 s"`` past the
    risk model's largest error (its top rung, :data:`splicer.align.risk_model.MODEL`): the model
    gives the probability of exceeding 0.4 s, and any number beyond it is the fit's
    extrapolation (a body hold spliced 1.5 s off once read "~54.25 s").

    Examples
    --------
    >>> estimate_text(0.2549), estimate_text(0.4), estimate_text(54.25)
    ('~0.25 s', '~0.40 s', 'over 0.4 s')
    """
    from ..align.risk_model import MODEL

    top = float(MODEL.thresholds_s[-1])
    return f"~{error_s:.2f} s" if error_s <= top else f"over {top:g} s"


def _worst_ranges(ranges: list, values: np.ndarray, k: int = 3) -> list:
    """The ``k`` ``[first, last]`` ranges whose largest value (NaN ignored) is largest, largest first."""
    return sorted(ranges, key=lambda ab: -float(np.nanmax(values[ab[0]:ab[1] + 1])))[:k]


def _coverage_report(r: SideResult, n: int, log: Log) -> dict:
    """Report keys for covered/uncovered frames and confidence; warnings for the summary."""
    from ..transfer.timemap import frame_ranges

    out: dict = {}
    aln = r.alignment
    uncovered = frame_ranges(~np.isfinite(r.hands_frame))
    cov = aln.covered if aln.covered is not None else (0, n - 1)
    out["ends"] = aln.ends
    out["covered"] = [int(cov[0]), int(cov[1])]
    out["uncovered"] = uncovered
    if uncovered:
        fps = r.markers.spaces.body_fps
        spans = ", ".join(f"{a}-{b} ({(b - a + 1) / fps:.1f} s)" for a, b in uncovered)
        edges = (f"; the covered frames within {COVERAGE_EDGE_S:.2g} s of them count as low confidence (where the "
                 "hands material starts and stops is located only to within a few frames)") if aln.confidence is not None else ""
        log.note(f"{r.side} side: no hands material covers body frames {spans}; they keep the body's own "
                 f"fingers, blended in and out{edges}")
    conf = aln.confidence
    if conf is not None:
        from ..report import _round_list

        out["confidence"] = _round_list(conf.confidence, 3)
        out["est_error_s"] = _round_list(conf.est_error_s, 4)
        low = low_confidence_ranges(conf.est_error_s, r.markers.spaces.body_fps)
        out["low_confidence"] = low
        if conf.disagreement_s is not None:  # the other hand's time map (stages.crosscheck)
            out["disagree"] = frame_ranges(np.nan_to_num(conf.disagreement_s, nan=0.0) > LOW_CONFIDENCE_S, min_gap=2)
        if low:
            worst = _worst_ranges(low, conf.est_error_s)
            where = ", ".join(f"{a}-{b} ({estimate_text(float(np.nanmax(conf.est_error_s[a:b + 1])))})"
                              for a, b in worst)
            share = sum(b - a + 1 for a, b in low) / n
            log.note(f"{r.side} side: low confidence in {100 * share:.0f}% of body frames; worst {where}; a pin "
                     f"(constraints file) near frame {(worst[0][0] + worst[0][1]) // 2} would help most")
    return out


def build_report(inputs: Inputs, opts: SpliceOptions, sides: dict, log: Log, extra: dict | None = None) -> Report:
    """The typed report of a finished splice (``extra``: further top-level keys)."""
    from .. import __version__

    def pass_info(p):
        if p is None:
            return None
        info = {"band_frames": round(float(p.band.width), 3), "cost": float(p.cost)}
        if p.name == "pass1":
            info["position_weight"] = p.position_weight
            info["arms"] = p.arms  # 2: one pass 1 for both hands (stages.align.arms_together)
            info["body_holds"] = [list(h) for h in hold_ranges(getattr(p, "held_rows", None))]  # align.holds
            info["tempo_matched"] = bool(getattr(p, "tempo_matched", False))  # align.tempo (a second opinion)
            info["wrist_signs"] = bool(getattr(p, "wrist_signs", False))  # the hand-in-forearm signs (align.costs)
        return info

    side_reports = {}
    for s, r in sides.items():
        pins = tuple({"body": p.body, "hands": p.hands, "tolerance": p.tolerance, "line": p.line} for p in r.pins)
        real = {"markers": r.markers.real} if r.markers.real else {}  # optical markers used (file, roles, gaps)
        p1 = pass_info(r.pass1)
        ev = r.alignment.evidence
        if p1 is not None and ev is not None:  # against the hands take played backwards (align.evidence)
            p1["backwards_ratio"] = round(float(ev.ratio), 4) if np.isfinite(ev.ratio) else None
        side_reports[s] = SideReport(s, r.hands_frame, p1, pass_info(r.pass2), pins, r.joints,
                                     {**r.extra, **real, **_coverage_report(r, inputs.body.n_frames, log)})
    bm, hm = inputs.body, inputs.hands
    timings = dict(log.timings, total=log.total())
    return Report(__version__, {"path": bm.source, "frames": bm.n_frames, "fps": bm.fps},
                  {"path": hm.source, "frames": hm.n_frames, "fps": hm.fps},
                  {f: getattr(opts, f) for f in opts.__dataclass_fields__}, side_reports, timings,
                  tuple(log.warnings), dict(extra or {}))
