"""Stages 5 and 6: the time map of one side, then its fingers onto the output."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion
from ..options import SpliceOptions
from .rig import Rig
from .markers import SideMarkers
from .log import Log
from .load import Inputs
from .align import Alignment

__all__ = ['Transfer', 'time_map', 'trend_time_maps', 'refine_time_maps', 'check_fingers', 'transfer_side']


# ---------------------------------------------------------------- stage 5: time map

def _covered_span(alignment: Alignment) -> tuple[int, int]:
    """First and last body frame the hands cover (inclusive): the whole body take unless open ends left some out."""
    return alignment.covered if alignment.covered is not None else (0, len(alignment.per_frame) - 1)


def _span_pins(pins, a: int, b: int) -> list:
    """The pins inside body frames ``a..b`` as (frame from ``a``, hands frame, tolerance), for the map of that span."""
    return [(p.body - a, float(p.hands), float(p.tolerance)) for p in pins if a <= p.body <= b]


def time_map(alignment: Alignment, markers: SideMarkers, opts: SpliceOptions) -> np.ndarray:
    """Hands-file frame for each body frame: smoothed, monotone, every pin held within its T.

    Body frames outside the covered range (open ends) have no hands material: NaN there.

    Returns
    -------
    np.ndarray [shape=(n_body,), dtype=float64]
        Non-decreasing over the covered frames, within ``[0, n_hands - 1]``; NaN elsewhere.
    """
    from ..transfer.timemap import pin_constraints, smooth_time_map

    sp = markers.spaces
    n = len(alignment.per_frame)
    a, b = _covered_span(alignment)
    hands_frames = sp.common_to_hands(alignment.per_frame[a:b + 1])
    pins = _span_pins(markers.pins, a, b)
    last = sp.n_hands - 1
    tm = np.full(n, np.nan)
    if opts.merge == "timemap":  # both keep every pin within its window (pin_constraints)
        tm[a:b + 1] = smooth_time_map(hands_frames, sigma_frames=opts.timemap_sigma_s * sp.body_fps, last=last,
                                      pins=pins)
    else:
        tm[a:b + 1] = np.clip(pin_constraints(hands_frames, pins), 0, last)
    return tm


def trend_time_maps(sides: dict, opts: SpliceOptions) -> dict:
    """Stage 6c, the time maps weighed by the alignment's uncertainty (:mod:`splicer.transfer.trend`).

    Each side's smooth time map is replaced by the most likely course of the hands time given
    how widely the near-best paths spread at each frame (the confidence's ``spread_frames``, the
    expected path's standard deviation) and a tempo that drifts by ``opts.tempo_var_per_s``:
    it keeps the map where the spread is small and bridges the uncertain stretches with the
    tempo of the sure frames around them; then it is made monotone again and every pin held
    (:func:`splicer.transfer.timemap.monotone_pinned`).  Measured on the ground-truth protocol
    (README *Accuracy*).  The smoother's standard deviation and how far it moved the map are
    kept for the risk stage (:func:`splicer.stages.risk.estimate_risk`), which runs next.

    Parameters
    ----------
    sides : dict of str -> SideResult
        After :func:`splicer.stages.crosscheck.cross_check`.
    opts : SpliceOptions
        ``merge="median"`` (its rotations come from the path, not the map), or
        ``tempo_var_per_s=0``: the maps unchanged (the smoother still runs, with
        :data:`splicer.defaults.TEMPO_VAR_PER_S`, for the risk stage's signals).

    Returns
    -------
    dict of str -> SideResult
        Where the side has a confidence: ``trend`` set (a
        :class:`~splicer.transfer.trend.TrendFit`) and, unless switched off, ``hands_frame``
        replaced; the confidence is kept.
    """
    from dataclasses import replace

    from ..defaults import TEMPO_VAR_PER_S
    from ..transfer.timemap import monotone_pinned
    from ..transfer.trend import trend_fit

    apply = opts.merge == "timemap" and bool(opts.tempo_var_per_s)
    out = {}
    for s, r in sides.items():
        conf = r.alignment.confidence
        if conf is None:
            out[s] = r
            continue
        sp = r.markers.spaces
        # the spread, not the estimated error: it is a smooth function of the input (the risk
        # model's signals include each arm's best path, which a float32 round trip can flip)
        sd_s = np.asarray(conf.spread_frames, dtype=np.float64) / sp.body_fps  # common frames: the body rate
        fit = trend_fit(r.hands_frame, sd_s, body_fps=sp.body_fps, hands_fps=sp.hands_fps,
                        tempo_var_per_s=opts.tempo_var_per_s if apply else TEMPO_VAR_PER_S,
                        held=getattr(r.alignment.pass1, "held_rows", None))  # body holds: the hands time stands still
        if not apply:
            out[s] = replace(r, trend=fit)
            continue
        tm = fit.hands_frame.copy()
        a, b = _covered_span(r.alignment)
        tm[a:b + 1] = monotone_pinned(tm[a:b + 1], last=sp.n_hands - 1, pins=_span_pins(r.markers.pins, a, b))
        out[s] = replace(r, hands_frame=tm, trend=fit)
    return out


def _held_frames(alignment: Alignment, a: int, b: int, fps: float) -> np.ndarray | None:
    """Body frames ``a..b`` the wrist's refinement does not read: pass 1's body holds and
    :data:`~splicer.defaults.WRIST_HOLD_MARGIN_S` either side; None without holds (or with the
    margin None)."""
    from ..align.holds import hold_ranges
    from ..defaults import WRIST_HOLD_MARGIN_S

    p1 = alignment.pass1
    holds = hold_ranges(getattr(p1, "held_rows", None)) if p1 is not None else []
    if WRIST_HOLD_MARGIN_S is None or not len(holds):
        return None
    pad = int(round(WRIST_HOLD_MARGIN_S * fps))
    still = np.zeros(b - a + 1, dtype=bool)
    for h0, h1 in holds:
        lo, hi = max(h0 - pad, a), min(h1 + pad, b)
        if lo <= hi:
            still[lo - a:hi - a + 1] = True
    return still if still.any() else None


def refine_time_maps(sides: dict, opts: SpliceOptions, log: Log | None = None) -> dict:
    """Stage 6c, continued: each time map moved by the hand's motion relative to the forearm (:mod:`splicer.align.wrist`).

    Within ``opts.wrist_radius_s`` of the map, the smooth offset whose hand-in-forearm rate of
    change best matches the body's is added to the covered frames' map (where the body holds
    still, nothing is read: :func:`_held_frames`); then the map is made
    monotone again and every pin held (:func:`splicer.transfer.timemap.monotone_pinned`).  Where
    the markers carry no measured noise this runs in rounds, each from the map the last one left:
    at least :data:`~splicer.defaults.WRIST_ROUNDS_MIN`, at most
    :data:`~splicer.defaults.WRIST_ROUNDS`, until a round moves the map by under
    :data:`~splicer.defaults.WRIST_SETTLE_S` on average (optical markers with noise: one round).
    Measured on the ground-truth protocol (README *Accuracy*).

    Parameters
    ----------
    sides : dict of str -> SideResult
        After :func:`trend_time_maps`.
    opts : SpliceOptions
        ``merge="median"`` (its rotations come from the path, not the map) or
        ``wrist_radius_s=0``: the maps unchanged.  A side keeps its map too where the two
        takes' markers are placed differently (``markers.placed``,
        :func:`splicer.align.wrist.comparable_placements`: a body without finger joints, finger
        bases of other fingers, a wrist-rooted hand file whose made-up forearm turns with its
        hand): the hand's direction in the forearm's frame would not compare.
    log : Log, optional
        Told each side's progress (a side of an hour-long take takes a second or two).

    Returns
    -------
    dict of str -> SideResult
        ``hands_frame`` replaced over each side's covered span; ``extra["wrist_shift_frames"]``:
        the mean absolute move, hands frames; ``wrist`` the refinement's
        :class:`~splicer.align.wrist.WristEvidence`.
    """
    from dataclasses import replace

    from ..align.wrist import STYLOID, WristEvidence, markers_compare, noise_share, refine_map
    from ..defaults import (WRIST_NOISE_SHARE_MAX, WRIST_OFFSET_SMOOTH_S, WRIST_ROUNDS, WRIST_ROUNDS_MIN,
                            WRIST_ROUNDS_NOISE_SHARE_MAX, WRIST_SETTLE_S, WRIST_SLOPE_S, WRIST_SMOOTH_S)
    from ..transfer.timemap import monotone_pinned

    if opts.merge != "timemap" or not opts.wrist_radius_s > 0:
        return dict(sides)
    log = log or Log()
    out = {}
    for s, r in sides.items():
        sp = r.markers.spaces
        a, b = _covered_span(r.alignment)
        tm = np.array(r.hands_frame, dtype=np.float64)
        span = tm[a:b + 1]
        body_pts, hands_pts = r.markers.body.points[a:b + 1], r.markers.hands.points
        if b - a < 2 or not np.isfinite(span).all() or not markers_compare(r.markers.placed, body_pts, hands_pts):
            out[s] = r
            continue
        log.progress(f"{s}: wrist", 0.0)
        noise, c = r.markers.noise, sp.hands_to_common(span)
        share = noise_share(body_pts, hands_pts, c, fps=sp.body_fps, smooth_s=WRIST_SMOOTH_S,
                            slope_s=WRIST_SLOPE_S, body_noise=noise["body"][a:b + 1] if "body" in noise else None,
                            hands_noise=noise.get("hands"))
        if share > WRIST_NOISE_SHARE_MAX:  # optical markers too noisy for the hand's motion in this take
            log.note(f"{s} side: the wrist's refinement left out: the optical markers' noise makes up {share:.0%} of the "
                     f"hand's motion relative to the forearm (over {WRIST_NOISE_SHARE_MAX:.0%}); the time map stays as "
                     "the passes made it")
            out[s] = replace(r, extra={**r.extra, "wrist_noise_share": float(f"{share:.3g}")})
            log.progress(f"{s}: wrist", 1.0)
            continue
        # a second round where the markers carry no noise: it reads the signal again from where the first
        # moved the map (measured: noisy optical markers lose by it, and so do optical markers against
        # virtual ones placed across the palm; benchmarks/HISTORY.md, 0.19.0 and 0.21.0)
        alike = set(r.markers.placed) in ({"optical"}, {"optical", STYLOID})
        quiet = alike and share < WRIST_ROUNDS_NOISE_SHARE_MAX
        rounds = WRIST_ROUNDS if not noise or quiet else 1
        offset = 0.0
        still = _held_frames(r.alignment, a, b, sp.body_fps)
        for done in range(1, rounds + 1):
            fit = refine_map(body_pts, hands_pts, c, fps=sp.body_fps, radius_s=opts.wrist_radius_s,
                             smooth_s=WRIST_SMOOTH_S, offset_smooth_s=WRIST_OFFSET_SMOOTH_S, slope_s=WRIST_SLOPE_S,
                             still=still)
            c, offset = fit.refined, offset + fit.offset
            # settled: past the first rounds, a round that moved the map by under WRIST_SETTLE_S on average
            if done >= WRIST_ROUNDS_MIN and float(np.mean(np.abs(fit.offset))) < WRIST_SETTLE_S * sp.body_fps:
                break
        rounds = done
        new = monotone_pinned(sp.common_to_hands(fit.refined), last=sp.n_hands - 1, pins=_span_pins(r.markers.pins, a, b))
        moved = float(np.mean(np.abs(new - span)))
        tm[a:b + 1] = new
        shift, sd = np.full(len(tm), np.nan), np.full(len(tm), np.nan)
        shift[a:b + 1], sd[a:b + 1] = np.abs(offset) / sp.body_fps, fit.sd / sp.body_fps  # common frames: the body rate
        more = {"wrist_noise_share": float(f"{share:.3g}")} if noise else {}
        out[s] = replace(r, hands_frame=tm, extra={**r.extra, "wrist_shift_frames": round(moved, 3), "wrist_rounds": rounds,
                                                   **more},
                         wrist=WristEvidence(shift_s=shift, sd_s=sd))
        log.progress(f"{s}: wrist", 1.0)
    return out


# ---------------------------------------------------------------- stage 6: transfer

@dataclass(frozen=True, eq=False)
class Transfer:
    """The output after one side's fingers were carried over.

    Attributes
    ----------
    motion : Motion
        The body take with this side's finger joints driven by the hands (and grafted joints).
    joints : dict
        Output joint name -> hands joint names driving it.
    """

    motion: Motion
    joints: dict
    arm: object = None  # ArmRoles of the side on the output skeleton
    extra: dict = field(default_factory=dict)  # JSON-ready report keys (e.g. the graft scale)


def check_fingers(transfer: Transfer, side: str, inputs: Inputs, rig: Rig, tm: np.ndarray, handedness: dict,
                  log: Log | None = None) -> dict:
    """Finger sanity (:mod:`splicer.sanity`): backward bending, joint ranges, DIP/PIP, of the output
    and of the hands frames it shows (read as the hand it really is), and odd hand frames.

    Returns the JSON-ready report keys and adds a warning per finger that bends worse than its source.
    """
    from ..rig.handgeom import hand_frame_warnings
    from ..transfer.sanity import finger_sanity, sanity_warnings

    log = log or Log()
    log.progress(f"{side}: finger check", 0.0)
    hm, harm = inputs.hands, rig.hands.sides[side]
    reading = handedness.get("body", {}).get(side, {}).get("geometric") or side
    san = finger_sanity(transfer.motion, transfer.arm, +1 if reading == "right" else -1)
    log.progress(f"{side}: finger check", 0.5)
    src_read = handedness.get("hands", {}).get(side, {}).get("geometric") or side
    if handedness.get("mirrored"):
        src_read = "left" if src_read == "right" else "right"
    shown = np.isfinite(tm)
    frames = np.clip(np.round(tm[shown]).astype(np.int64), 0, hm.n_frames - 1)
    src_san = finger_sanity(hm.frames(frames), harm, +1 if src_read == "right" else -1)
    transfer.motion.forget_rotations()  # the output's hand joints, converted for the check only
    for w in sanity_warnings(san, f"{side} side, output", src_san):
        log.note(w)
    if transfer.joints:
        for w in (hand_frame_warnings(transfer.motion.skeleton, transfer.arm, inputs.body.source or "body")
                  + hand_frame_warnings(hm.skeleton, harm, hm.source or "hands")):
            log.note(w)
    return {"finger_sanity": san, "finger_sanity_hands": src_san}


def transfer_side(out: Motion, inputs: Inputs, rig: Rig, side: str, alignment: Alignment, tm: np.ndarray,
                  opts: SpliceOptions, log: Log | None = None, *, pins: tuple = ()) -> Transfer:
    """Drive ``side``'s finger joints of ``out`` by the hands take sampled at the time map.

    A body without finger joints gets the hands' finger subtree grafted under its wrist.
    The median merge (the paper) takes rotation medians along the path and blends jumps.
    """
    from ..transfer.timemap import blend_jumps, coverage_weights, median_rotations
    from ..rig.roles import FINGERS, find_roles
    from ..model.rotations import quat_slerp
    from ..transfer.sampling import sample_rotations
    from ..rig.handgeom import graft_scale
    from ..rig.handonly import coincident_forearm, wrist_source_notes
    from ..transfer.fingers import FingerMap, carried_rotations, finger_map, graft_fingers

    log = log or Log()
    log.progress(f"{side}: transfer", 0.0)
    bm, hm, cfg = inputs.body, inputs.hands, inputs.config
    barm = find_roles(out.skeleton, source=bm.source, mapping=cfg.joints.get("body"), up=rig.body.up).sides[side]
    harm = rig.hands.sides[side]
    extra: dict = {}
    if not any(f in barm.fingers for f in FINGERS):
        gs = graft_scale(bm.skeleton, rig.body.sides[side], hm.skeleton, harm)  # hand size, else forearm
        out, barm = graft_fingers(out, barm, hm.skeleton, harm, gs.scale)
        log.note(f"{side} side: the body has no finger joints; grafted the hands' {len(barm.finger_joints)} finger "
                 f"joints under {out.skeleton.names[barm.wrist]} at scale {gs.scale:.4g} ({gs.method})")
        extra["graft"] = {"scale": gs.scale, "method": gs.method}
    fmap = finger_map(out.skeleton, barm, hm.skeleton, harm)
    if opts.wrist == "hands":
        forearm = coincident_forearm(hm.skeleton, harm)  # a forearm joint at the wrist's place (Leap) counts
        if forearm is None:
            raise SplicerError(f"{hm.source or 'hands'}: --wrist hands needs a forearm joint above the {side} "
                               "wrist in the hands file")
        for msg in wrist_source_notes(hm, harm, forearm):
            log.note(msg)
        fmap = FingerMap(fmap.body + (barm.wrist,), fmap.hands + ((harm.wrist,),), fmap.conj, fmap.bones)
    sub = sorted({j for g in fmap.hands for j in g})
    local = FingerMap(fmap.body, tuple(tuple(sub.index(j) for j in g) for g in fmap.hands), fmap.conj, fmap.bones)
    hq = hm.joint_rotations(sub, keep=False)  # the hands take's rotations are not kept (long takes)
    log.progress(f"{side}: transfer", 0.3)
    covered = np.flatnonzero(np.isfinite(tm))
    tm = np.interp(np.arange(len(tm)), covered, tm[covered])  # uncovered frames: the nearest covered one
    if opts.merge == "timemap":
        q = sample_rotations(hq, tm)
    else:
        ratio, last, n = inputs.spaces.ratio, hm.n_frames - 1, bm.n_frames
        path = alignment.path
        a, b = alignment.covered if alignment.covered is not None else (0, n - 1)
        keep = (path[:, 0] >= a) & (path[:, 0] <= b) & np.isfinite(path[:, 1])
        q = sample_rotations(hq, tm)  # uncovered rows: the time map held at its ends (weight 0 below)
        q[a:b + 1] = median_rotations(hq, np.clip(path[keep, 1] * ratio, 0, last),
                                      path[keep, 0].astype(np.int64) - a, b - a + 1)
        q = blend_jumps(q, tm, jump=3.0 * max(ratio, 1.0), window=opts.blend_window)
        fixed = np.array(sorted({p.body for p in pins}), dtype=np.int64)
        if len(fixed):  # pinned frames show exactly the time map's (pinned) hands frame
            q[fixed] = sample_rotations(hq, tm[fixed])
    log.progress(f"{side}: transfer", 0.6)
    if fmap.body:
        carried = carried_rotations(q, local)
        if alignment.covered is not None:  # uncovered body frames keep the body's own rotations
            w = coverage_weights(len(tm), alignment.covered, window=int(round(opts.uncovered_blend_s * bm.fps)))
            carried = quat_slerp(out.joint_rotations(list(fmap.body), keep=False), carried, w[:, None])
        log.progress(f"{side}: transfer", 0.8)
        out = out.with_rotations(list(fmap.body), carried)
    else:
        log.note(f"{side} side: no finger joints could be paired between body and hands")
    log.tick("transfer")
    return Transfer(out, {out.skeleton.names[b]: [hm.skeleton.names[j] for j in g]
                          for b, g in zip(fmap.body, fmap.hands)}, barm, extra)
