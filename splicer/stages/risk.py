"""Stage 6d, the error's 98th percentile: every signal of the alignment weighed together.

After the cross-check each side's estimated error is the larger of the expected path's spread
and the arms' disagreement.  Measured on the ground-truth protocol, that rule flags frames
whose arm wanders where its motion says little (good frames) and misses stretches where
every signal is a little raised but none is large (README *Accuracy*).  This stage replaces
it, where both arms were aligned with one pass 1 (the default for two sides), with the 98th
percentile of the frame's error estimated by an ordinal logistic model of those signals, the
time-map smoother's standard deviation and shift (:func:`splicer.stages.transfer.trend_time_maps`
runs first), the wrist's refinement's standard deviation and shift where it ran
(:func:`splicer.stages.transfer.refine_time_maps`; a side it did not run on gets the model
fitted without them) and the body's arm speeds (:mod:`splicer.align.risk`;
:data:`splicer.defaults.RISK_QUANTILE`).
The previous estimate stays in the confidence as ``evidence_error_s``.  One side, each arm
aligned on its own, or a take whose motion does not match the hands' at all (the floor of
:func:`splicer.stages.align.refine`) keep the previous estimate.  The output motion is not
changed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..align.risk import error_quantile, risk_score, risk_signals
from ..defaults import RISK_QUANTILE

__all__ = ["side_risk_signals", "estimate_risk"]


def side_risk_signals(r, other, speeds=None) -> dict | None:
    """The risk model's signals of side result ``r`` (:func:`splicer.align.risk.risk_signals`),
    with ``other`` the other side's result; None when the alignment lacks what they need (no
    confidence, no expected path, no own path of either arm, no time-map smoother: the stage
    runs after :func:`splicer.stages.transfer.trend_time_maps`).  ``speeds``: ``(this arm's,
    the other's)`` body speeds when already computed (the other side's signals, swapped)."""
    a, b = r.alignment, other.alignment
    conf = a.confidence
    if conf is None or a.posterior is None or a.own is None or b.own is None or r.trend is None:
        return None
    fps = float(r.markers.spaces.body_fps)
    mean = np.asarray(a.posterior.mean, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        own = np.abs(np.asarray(a.own, dtype=np.float64) - mean) / fps
        other_own = np.abs(np.asarray(b.own, dtype=np.float64) - mean) / fps
    n = len(conf.est_error_s)
    dis = conf.disagreement_s if conf.disagreement_s is not None else np.zeros(n)
    w = r.wrist  # the wrist's refinement, where it ran (splicer.align.wrist.WristEvidence)
    return risk_signals(spread_s=np.asarray(conf.spread_frames, dtype=np.float64) / fps, disagreement_s=dis,
                        evidence_s=conf.est_error_s if conf.evidence_error_s is None else conf.evidence_error_s, own_s=own, other_own_s=other_own,
                        trend_sd_s=r.trend.sd_s, trend_shift_s=r.trend.shift_s,
                        body_relative=None if speeds is not None else r.markers.body.relative(),
                        other_body_relative=None if speeds is not None else other.markers.body.relative(), speeds=speeds,
                        wrist_sd_s=None if w is None else w.sd_s, wrist_shift_s=None if w is None else w.shift_s)


def estimate_risk(sides: dict, model=None, q: float = RISK_QUANTILE) -> dict:
    """Replace each side's estimated error by the ``q`` quantile of its error under ``model``.

    Parameters
    ----------
    sides : dict of str -> SideResult
        The finished sides of a splice, after :func:`splicer.stages.crosscheck.cross_check`.
    model : RiskModel, optional
        Default :data:`splicer.align.risk_model.MODEL` for a side the wrist's refinement ran on,
        :data:`~splicer.align.risk_model.MODEL_NO_WRIST` for one it did not.
    q : float
        The quantile, in (0, 1).

    Returns
    -------
    dict of str -> SideResult
        With two sides aligned by one pass 1, each confidence is
        :meth:`~splicer.align.confidence.Confidence.with_estimate` of the quantile (uncovered
        frames stay NaN); otherwise the sides unchanged.
    """
    from .align import _unmatched

    if len(sides) != 2:
        return dict(sides)
    (sa, ra), (sb, rb) = sides.items()
    out = dict(sides)
    speeds = None  # the two arms' body speeds, computed once for both sides
    for s, r, other in ((sa, ra, rb), (sb, rb, ra)):
        if _unmatched(r.alignment.evidence):
            continue  # nothing in the motion matches: the floor of refine() stands
        sig = side_risk_signals(r, other, speeds)
        if sig is None:
            continue
        speeds = (sig["other_speed"], sig["speed"])
        fps = float(r.markers.spaces.body_fps)
        m = model
        if m is None:
            from ..align import risk_model

            m = risk_model.MODEL if "wrist_sd" in sig else risk_model.MODEL_NO_WRIST
        score = risk_score(m, sig, ~np.isfinite(np.asarray(r.hands_frame, dtype=np.float64)), fps)
        conf = r.alignment.confidence.with_estimate(error_quantile(m, score, q))
        out[s] = replace(r, alignment=replace(r.alignment, confidence=conf))
    return out
