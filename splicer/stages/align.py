"""Stage 4, align: pass 1 (open or fixed ends; one side, or both arms at once), pass 2 and the
confidence per side.

:func:`locate` runs pass 1 and its expected path, :func:`refine` pass 2 and the confidence;
:func:`align_side` is both for one side, :func:`align_pair` for the pair (one pass 1 for both
arms when :func:`arms_together`)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import defaults as D
from ..errors import BandError, ConstraintError, SplicerError
from ..align.frames import Pin
from ..options import SpliceOptions
from .markers import SideMarkers
from .log import Log

__all__ = ['Alignment', 'Located', 'phase_smoothing', 'locate', 'passes_of', 'refine', 'align_side', 'arms_together',
           'agree_ends', 'align_pair']


# ---------------------------------------------------------------- stage 4: align

@dataclass(frozen=True, eq=False)
class Alignment:
    """Both passes of one side.

    Attributes
    ----------
    per_frame : np.ndarray [shape=(n,)]
        Hands frame (common rate, fractional) matched to each body frame.
    path : np.ndarray [shape=(K, 2)]
        The final correspondence (body frame, common hands frame), for the median merge.
    pass1, pass2 : PassResult or None
    constraints : tuple of Constraint
        The pins as DTW constraints (body frame, common hands frame).
    """

    per_frame: np.ndarray
    path: np.ndarray
    pass1: object
    pass2: object
    constraints: tuple
    covered: tuple | None = None  # (first, last) body frames the hands cover; None: all
    confidence: object = None  # per-frame confidence and estimated error, when computed
    ends: str = "fixed"  # the end conditions used: "open" or "fixed"
    posterior: object = None  # pass 1's expected path and its spread (splicer.align.posterior), when used
    own: np.ndarray | None = None  # pass 1 over both arms: this arm's own path in its band, per body frame
    evidence: object = None  # pass 1 against the hands take played backwards (splicer.align.evidence)

    def __repr__(self) -> str:
        return f"Alignment(body_frames={len(self.per_frame)}, passes={[p.name for p in (self.pass1, self.pass2) if p]})"


def _pin_error(e: SplicerError, pins: tuple[Pin, ...], who: str) -> SplicerError:
    """A band/constraint error in terms of the user's pins (file, line, numbers); ``who``: e.g. ``"left side"``."""
    seg = getattr(e, "segment", None)
    if isinstance(e, BandError) and seg is not None and pins:
        before = "the start of both takes" if seg == 0 else pins[seg - 1].describe()
        after = "the end of both takes" if seg >= len(pins) else pins[seg].describe()
        w = getattr(e, "min_width", None)
        wtxt = f"; a band of at least {w:.0f} body frames would (--band {int(np.ceil(w))})" if w else ""
        return type(e)(f"{who}: the band cannot connect {before} to {after}{wtxt}")
    pair = getattr(e, "pair", None)
    if pair is not None and pins:
        a, b = pins[pair[0]], pins[pair[1]]
        return type(e)(f"{who}: {b.describe()} cannot follow {a.describe()}: adjacent body frames cannot "
                       "match hands frames further apart than their tolerances allow")
    return type(e)(f"{who}: {e}")


def phase_smoothing(markers: dict, opts: SpliceOptions, log: Log | None = None) -> dict:
    """The marker smoothing each side's phase metric uses (noise matching, ``opts.noise_ratio``).

    A second performance or a jittery solve leaves one take's arm noisier than the other's,
    and D1 then matches noise (:func:`splicer.align.noise.matched_smoothing`).  Both hands come
    from one hands take, so with ``noise_ratio="auto"`` (the default) whether a take is noisier
    is decided once for the pair: when either side's direction changes differ by more than
    :data:`splicer.defaults.NOISE_TRIGGER`, each side is smoothed until its two rates agree
    within :data:`splicer.defaults.NOISE_RATIO`.  A number ``R`` matches each side whenever its
    rates differ by more than ``R``; ``None`` keeps ``opts.smooth_s``.

    Parameters
    ----------
    markers : dict of str -> SideMarkers
    opts : SpliceOptions
    log : Log, optional
        Gets a note for each side smoothed more (or, with noise matching off, that looks noisier).

    Returns
    -------
    dict of str -> float
        Each side's smoothing, seconds.
    """
    from ..align.noise import matched_smoothing

    log = log or Log()
    auto = opts.noise_ratio == "auto"
    ratio = D.NOISE_RATIO if auto else opts.noise_ratio
    plain, excess = {}, {}
    for s, mk in markers.items():  # the rates at the default smoothing: no search yet
        plain[s], excess[s] = matched_smoothing(mk.body, mk.hands, smooth_s=opts.smooth_s, dead_zone=opts.dead_zone,
                                                ratio=None)
    noisy = auto and max(excess.values(), default=1.0) > D.NOISE_TRIGGER
    out = {}
    for s, mk in markers.items():
        if noisy or (ratio is not None and not auto):
            out[s], _ = matched_smoothing(mk.body, mk.hands, smooth_s=opts.smooth_s, dead_zone=opts.dead_zone,
                                          ratio=ratio, trigger=1.0 if noisy else None)
        else:
            out[s] = plain[s]
        if out[s] != opts.smooth_s:
            log.note(f"{s} side: one take's arm is noisier (its motion changes direction {excess[s]:.1f}x as often, "
                     f"tempo allowed for; a second performance or a jittery solve?): markers smoothed over "
                     f"{out[s]:g} s instead of {opts.smooth_s:g} s for the phase metric"
                     + (" (--noise-ratio off keeps them)" if auto else ""))
        elif opts.noise_ratio is None and excess[s] > D.NOISE_WARN:  # noise matching switched off
            log.note(f"{s} side: one take's arm looks noisier (its motion changes direction {excess[s]:.1f}x as "
                     "often, tempo allowed for; a second performance or a jittery solve?): if the alignment is "
                     "off, try --noise-ratio auto")
    return out


def position_weights(opts: SpliceOptions, markers: SideMarkers, noisy: bool) -> tuple[float, float]:
    """Pass 1's position weights for one side: (a pass with fixed ends, an open-ended pass).

    ``opts.position_weight`` when a number (both).  ``"auto"``:
    :data:`splicer.defaults.POSITION_WEIGHT_NOISY` for both where noise matching smoothed the
    pair (``noisy``: a noisier take, whose derivative signs are less to be trusted; one decision
    for both hands, as they come from one take); otherwise
    :data:`splicer.defaults.POSITION_WEIGHT` with fixed ends and 0 open-ended.  Open-ended,
    the position term also enters the uncovered penalty, and on clean pairs it moved where
    the overlap starts and ends: a calibration pose resembling the body's first frames was
    taken for the performance (held-out synthetic *extra*, seed 102: 0.58 s off over the first
    2 s), and a short hands take's path ran 3.7 s past its end or started 0.7 s late, whichever
    the penalty was taken from (README, *How it works*).  0 for both where positions do not
    compare: a hand-only hands file (measured from the capture's origin, against the body's
    root: on tuning seeds 0-2 of the paper's protocol a wrist-rooted file went from 0.74 to 7.5
    frames with the term).  Optical markers (``markers.real``) have no root heading to turn
    the coordinates by: their term holds the hand-in-forearm signs alone
    (:func:`position_coordinates`), weighed :data:`splicer.defaults.OPTICAL_SIGN_WEIGHT` (or
    ``opts.position_weight`` when a number) where the signs compare (:func:`wrist_signs_compare`:
    both takes optical, or the other's virtual markers on the styloids), else 0 (0.31.0; before,
    0 throughout).
    """
    if markers.real:  # no root heading: the signs alone, where they compare
        if not wrist_signs_compare(markers):
            return 0.0, 0.0
        w = D.OPTICAL_SIGN_WEIGHT if opts.position_weight == "auto" else float(opts.position_weight)
        return w, w
    if opts.position_weight != "auto":
        return float(opts.position_weight), float(opts.position_weight)
    if markers.hand_only:
        return 0.0, 0.0
    if noisy:
        return D.POSITION_WEIGHT_NOISY, D.POSITION_WEIGHT_NOISY
    return D.POSITION_WEIGHT, 0.0


@dataclass(frozen=True, eq=False)
class Located:
    """Pass 1 of one side, or of both hands together, before pass 2.

    Attributes
    ----------
    pass1 : PassResult or None
        None when only pass 2 runs (``passes="pass2"``).
    per_frame : np.ndarray [shape=(n,)] or None
        Pass 1's expected path: the hands frame (common rate) per body frame; NaN where uncovered.
    posterior : object or None
        Its spread (:mod:`splicer.align.posterior`).
    covered : tuple or None
        ``(first, last)`` body frames the hands cover (open ends); None: all.
    ends : {"open", "fixed"}
    width1, width2 : float
        The passes' band widths, body frames.
    constraints : tuple of Constraint
        The pins as DTW constraints (body frame, common hands frame).
    own : dict of str -> np.ndarray
        Pass 1 over several arms: each side's own best path in the same band, per body frame
        (:func:`splicer.align.passes.arm_paths`), for the cross-check; empty for one side.
    evidence : Evidence or None
        Pass 1 against the hands take played backwards (:mod:`splicer.align.evidence`); None
        without pass 1, or when the check could not run.
    """

    pass1: object
    per_frame: np.ndarray | None
    posterior: object
    covered: tuple | None
    ends: str
    width1: float
    width2: float
    constraints: tuple
    own: dict = field(default_factory=dict)
    evidence: object = None

    def release(self) -> None:
        """Free pass 1's kept costs (:mod:`splicer.align.costcache`): no later stage reads them."""
        if self.pass1 is not None and self.pass1.kept_cost is not None:
            self.pass1.kept_cost.release()


def _no_evidence_error_s(hands_frames: int, fps: float) -> float:
    """The error to expect when nothing says where in the hands take a body frame belongs: the
    standard deviation of a place drawn uniformly over the whole hands take (its length / sqrt(12)),
    seconds.  Not the span the path covers: on unrelated takes that span means nothing either."""
    return max(float(hands_frames) - 1.0, 1.0) / fps / np.sqrt(12.0)


def _other_arms(extra: list, open_ends: bool) -> tuple:
    """Pass 1's other arms (``(SideMarkers, smooth_s, fixed-ends weight, open-ends weight, wrist signs,
    coordinates)`` each) as :class:`splicer.align.passes.Arm`, with the position weight of the end condition."""
    from ..align.passes import Arm

    return tuple(Arm(o.body, o.hands, osm, w_open if open_ends else w_fixed, wrist, coords)
                 for o, osm, w_fixed, w_open, wrist, coords in extra)


def position_coordinates(markers: SideMarkers) -> bool:
    """Whether pass 1's position term reads the positions' coordinates (shoulder-relative, turned by
    the root's heading: :func:`splicer.align.costs.position_features`): not with optical markers,
    which have no root heading; their term is the hand-in-forearm signs alone (:func:`position_weights`)."""
    return not markers.real


def wrist_signs_compare(markers: SideMarkers) -> bool:
    """Whether pass 1's position term may read this side's hand-in-forearm signs
    (:func:`splicer.align.costs.wrist_sign_features`, :data:`splicer.defaults.WRIST_SIGN_SCALE`):
    both takes' markers placed alike and the hand's direction in the forearm readable in both
    (:func:`splicer.align.wrist.markers_compare`, the wrist's refinement's rule).  The signs are
    components in each take's own forearm frame, so unlike the refinement no fixed turn between
    two placements is taken out: placements must be the same, or optical markers against virtual
    ones put on the styloids as optical ones are (:data:`splicer.align.wrist.STYLOID`; 0.31.0:
    the markers' protocol's hands C3D with the body's virtual markers, tuning seeds 0-9, 0.232 ->
    0.226 and 0.281 -> 0.269 frames on ZEGGS, 0.576 -> 0.551 and 0.596 -> 0.567 on the synthetic
    speaker, every seed better or equal).  The term itself is on only where the position term is
    (:func:`position_weights`)."""
    from ..align.wrist import STYLOID, markers_compare

    body, hands = markers.placed
    alike = body == hands or {body, hands} == {"optical", STYLOID}
    return bool(D.WRIST_SIGN_SCALE > 0 and alike
                and markers_compare(markers.placed, markers.body.points, markers.hands.points))


def _unmatched(evidence) -> bool:
    """The check against the hands played backwards ran and found nothing better than unrelated material."""
    return evidence is not None and evidence.ratio >= D.BACKWARDS_RATIO


def both_skip_weight(opts: SpliceOptions) -> float | None:
    """Open-ended passes' ``both_skip_weight`` (:func:`splicer.align.passes.pass1`):
    :data:`splicer.defaults.BOTH_SKIP_WEIGHT` with ``opts.both_skip == "on"``, else None (``"auto"``
    is resolved by the splice, :func:`splicer.stages.overlap.both_skip_options`; a stage called
    alone reads it as ``"off"``)."""
    return D.BOTH_SKIP_WEIGHT if opts.both_skip == "on" else None


def _evidence(bmk, hmk, extra: list, ends: str, smooth_s: float, position_weight: float, opts: SpliceOptions,
              log: Log, who: str, label: str):
    """Pass 1 against the hands take played backwards (:func:`splicer.align.evidence.match_evidence`), with
    pass 1's arms and options."""
    from ..align.evidence import match_evidence

    try:
        return match_evidence(bmk, hmk, ends=ends, others=_other_arms(extra, ends == "open"), smooth_s=smooth_s,
                              dead_zone=opts.dead_zone, sign_ramp=opts.sign_ramp, theta=opts.theta,
                              position_weight=position_weight,
                              uncovered_quantile=opts.uncovered_quantile, both_skip_weight=both_skip_weight(opts),
                              progress=lambda f: log.progress(f"{label}: backwards check", f))
    except (SplicerError, ValueError) as e:  # takes too short at the check's rate: no verdict, never a failed splice
        log.note(f"{who}: the check against the hands take played backwards could not run ({e}); nothing says "
                 "whether the takes show the same performance")
        return None


def _body_holds(arms, fps: float, opts: SpliceOptions) -> tuple:
    """Stretches where the body holds still on every arm given (:func:`splicer.align.holds.body_holds`);
    none with ``opts.body_holds == "off"``."""
    from ..align.holds import body_holds

    if opts.body_holds == "off":
        return ()
    return body_holds([a.body.relative() for a in arms], fps)


def locate(markers: SideMarkers, opts: SpliceOptions, log: Log | None = None, *, others: tuple = (),
           ends: str = "auto", offset_s: float | None = None, guide: np.ndarray | None = None,
           smooth_s: float | None = None, noisy: bool | None = None, other_smooth: tuple = ()) -> Located:
    """Pass 1 (phase metric D1) of one side, or of several arms sharing one time map, and its expected path.

    Parameters
    ----------
    markers : SideMarkers
        The first arm (its pins, frame spaces and band).
    others : tuple of SideMarkers
        More arms weighed in pass 1 (the other hand of the same hands take: :func:`align_pair`);
        same frames and pins as ``markers``.
    other_smooth : tuple of float
        Their ``smooth_s``, one each (default: ``smooth_s``).
    ends, offset_s, guide, smooth_s, noisy
        As :func:`align_side`.

    Raises
    ------
    SplicerError
        A band that cannot reach the pins, named by their file and line.
    """
    from ..align.passes import arm_paths, hold_ends, pass1, path_median, weight_without_signs
    from ..align.band import band_frames
    from ..align.band_width import pass_widths
    from ..align.posterior import expected_frames
    from ..align.holds import held_rows

    log = log or Log()
    sides = [markers.side] + [o.side for o in others]
    who = f"{markers.side} side" if not others else " and ".join(sides) + " sides"
    label = markers.side if not others else "both hands"
    bmk, hmk = markers.body, markers.hands
    n, m = bmk.n_frames, hmk.n_frames
    fps = markers.spaces.body_fps

    if smooth_s is None:  # one side alone: its own noise matching
        smooth_s = phase_smoothing({markers.side: markers}, opts, log)[markers.side]
    if noisy is None:
        noisy = smooth_s > opts.smooth_s
    pos_fixed, pos_open = position_weights(opts, markers, noisy)
    wrist, coords = wrist_signs_compare(markers), position_coordinates(markers)
    extra = []
    for k, o in enumerate(others):
        o_fixed, o_open = position_weights(opts, o, noisy)
        osm = other_smooth[k] if k < len(other_smooth) else smooth_s
        extra.append((o, osm, o_fixed, o_open, wrist_signs_compare(o), position_coordinates(o)))

    # a second performance's noise (not optical markers' measured noise: measured worse there)
    soft = noisy and not markers.noise and not any(o.noise for o in others)

    holds = _body_holds([markers] + list(others), fps, opts)
    held = held_rows(n, holds)
    if holds:
        where = ", ".join(f"{a}-{b} ({a / fps:.1f}-{b / fps:.1f} s)" for a, b in holds)
        log.note(f"{who}: the body holds still over frames {where}: the time map stays on one hands frame "
                 "there (the hands performer went on meanwhile, or held too)")

    def run_pass1(mode: str, guide_path=None, stage: str = "pass 1"):
        open_ends = mode == "open"
        cons = tuple(markers.spaces.dtw_constraints(markers.pins, m, open_ends=open_ends))
        guided = opts.coarse == "on" or (opts.coarse == "auto" and n / fps > opts.coarse_above_s)
        w1, w2 = pass_widths(opts.band1, opts.band2, n=n, fps=fps, open_ends=open_ends, guided=guided)
        arms = _other_arms(extra, open_ends)
        p = pass1(bmk, hmk, width=w1, constraints=cons, smooth_s=smooth_s, dead_zone=opts.dead_zone,
                  sign_ramp=opts.sign_ramp_noisy if soft and not open_ends else opts.sign_ramp,
                  position_weight=pos_open if open_ends else pos_fixed,
                  theta=opts.theta, ends=mode, offset_s=offset_s if open_ends else None,
                  uncovered_quantile=opts.uncovered_quantile,
                  coarse_fps=None if open_ends else (opts.coarse_fps if guided else None),
                  coarse_width=None if open_ends else band_frames("30%", n=n, fps=fps),
                  guide=None if open_ends else guide_path, others=arms, held_rows=held, wrist_signs=wrist,
                  coordinates=coords, both_skip_weight=both_skip_weight(opts),
                  progress=lambda f: log.progress(f"{label}: {stage}", f))
        return p, w1, w2, cons

    p1 = posterior = per_frame = evidence = None
    covered = None
    own = {}
    used = "fixed" if ends == "fixed" else "open"
    try:
        if opts.passes != "pass2":  # "auto", "both", "pass1": pass 1 runs
            log.progress(f"{label}: pass 1", 0.0)
            p1, w1, w2, cons = run_pass1(used, guide)
            check = lambda f: log.progress(f"{label}: check", f)  # noqa: E731
            own_paths = None  # each arm's own path in pass 1's band, once the pass is kept (or to choose ends)
            if ends == "auto":
                why = _choose_ends(p1, n, m, fps, markers.pins)
                together = p1.path
                if why is None and others:  # an arm's own path corner to corner: the takes start and end together
                    own_paths = arm_paths(p1, progress=lambda f: log.progress(f"{label}: check (ends)", f))
                    arm, together, kept = _arm_together(p1, own_paths, sides, n, m, fps, opts.coarse_above_s)
                    for msg in kept:
                        log.note(f"{who}: {msg}")
                    if together is not None:
                        why = _TOGETHER_WHY
                        log.note(f"{who}: the {arm} arm's own alignment runs from the takes' first frames to their "
                                 "last; both arms' takes start and end together, so they are aligned end to end "
                                 "(--ends open keeps the open ends)")
                if why is None:  # hands material left at an end that continues the performance
                    closed, note = _close_ends(p1, n, m, fps, _fixed_constraints(markers, m), markers.pins)
                    if closed is not None:
                        why, together = _TOGETHER_WHY, closed
                    if note is not None:
                        log.note(f"{who}: {note}")
                if why is not None:
                    used = "fixed"
                    if p1.kept_cost is not None:
                        p1.kept_cost.release()  # the open-ended pass is dropped: free its kept costs first
                    # takes that start and end together: the open-ended path (corner to corner) guides
                    # the band; an overlap too short to trust: the diagonal's band (the paper)
                    # its own bar: the open-ended pass's reached 100 %
                    p1, w1, w2, cons = run_pass1("fixed", together if why == _TOGETHER_WHY else guide,
                                                 stage="pass 1, end to end")
                    own_paths = None  # the dropped pass's paths do not describe this one
                    if why.startswith("!"):
                        log.note(f"{who}: {why[1:]}")
            for msg in p1.notes:
                log.note(f"{who}: {msg}")
            log.tick("pass1")
            log.progress(f"{label}: backwards check", 0.0)
            evidence = _evidence(bmk, hmk, extra, used, smooth_s,  # the check reads no hand-in-forearm signs
                                 weight_without_signs(pos_open if used == "open" else pos_fixed, coords), opts,
                                 log, who, label)
            log.tick("backwards check")
            if _unmatched(evidence):
                log.note(f"{who}: the takes may not show the same performance: the alignment costs "
                         f"{100 * evidence.ratio:.0f}% of what it costs with the hands take played backwards (from "
                         f"{100 * D.BACKWARDS_RATIO:.0f}% on it is no better than unrelated material), so every covered "
                         "frame is low confidence; check that the two files belong together")
            # the expected path over the near-best ones, not the best path alone: smooth in the input
            per_frame, posterior = expected_frames(p1, temperature=opts.temperature_s * bmk.fps,
                                                   radius=int(round(opts.posterior_radius_s * bmk.fps)),
                                                   progress=lambda f: log.progress(f"{label}: expected", f))
            if used == "open":
                covered = _cover_pins(tuple(int(v) for v in p1.covered), markers.pins, n)
                if covered != tuple(p1.covered):
                    per_frame = hold_ends(per_frame)
                    per_frame[:covered[0]] = np.nan
                    per_frame[covered[1] + 1:] = np.nan
            # each arm's own path in the same band: where they part, one arm says little (stages.crosscheck)
            if own_paths is None:
                own_paths = arm_paths(p1, progress=check) if others else []
            own = {side: path_median(q, n) for side, q in zip(sides, own_paths)}
            log.tick("pass1")
        else:  # pass 2 alone runs in pass 1's band (the paper's 30 % unless given)
            w1, _ = pass_widths(opts.band1, opts.band2, n=n, fps=fps, open_ends=False, guided=False)
            w2 = w1
            cons = tuple(markers.spaces.dtw_constraints(markers.pins, m))
    except (BandError, ConstraintError) as e:
        raise _pin_error(e, markers.pins, who) from None
    except SplicerError as e:
        raise type(e)(f"{who}: {e}") from None
    return Located(p1, per_frame, posterior, covered, used, w1, w2, cons, own, evidence)


def passes_of(opts: SpliceOptions, markers: SideMarkers) -> str:
    """The passes a side runs: ``opts.passes``, with ``"auto"`` (:data:`splicer.defaults.PASSES`)
    read as ``"pass1"`` for a side aligned on optical markers (``markers.real``) and ``"both"``
    otherwise."""
    if opts.passes != "auto":
        return opts.passes
    return "pass1" if markers.real else "both"


def refine(markers: SideMarkers, located: Located, opts: SpliceOptions, log: Log | None = None, *,
           smooth_s: float | None = None) -> Alignment:
    """Pass 2 (palm metric D2) of one side after :func:`locate`, composed, with a confidence.

    ``located`` may be shared with the other hand (:func:`align_pair`); it is not released here.

    Raises
    ------
    SplicerError
        A band that cannot reach the pins, named by their file and line.
    """
    from ..align.passes import compose, hold_ends, pass2, path_median, remap_constraints, warp_markers
    from ..align.confidence import pass_confidence, posterior_confidence

    log = log or Log()
    s, bmk, hmk = markers.side, markers.body, markers.hands
    n = bmk.n_frames
    fps = markers.spaces.body_fps
    smooth_s = opts.smooth_s if smooth_s is None else smooth_s
    p1, covered, cons = located.pass1, located.covered, located.constraints
    per_frame = None if located.per_frame is None else np.array(located.per_frame)
    path = None if p1 is None else p1.path
    p2 = None
    try:
        passes = passes_of(opts, markers)
        if passes == "both":
            log.progress(f"{s}: pass 2", 0.0)
            filled = hold_ends(per_frame)
            p2 = pass2(bmk, warp_markers(hmk, filled), width=located.width2,
                       constraints=remap_constraints(cons, filled),
                       diagonal_weight=opts.pass2_weight, d1_weight=opts.pass2_d1_weight, smooth_s=smooth_s,
                       dead_zone=opts.dead_zone, sign_ramp=opts.sign_ramp, theta=opts.theta, covered=covered,
                       progress=lambda f: log.progress(f"{s}: pass 2", f))
            path = np.stack([p2.path[:, 0], np.interp(p2.path[:, 1], np.arange(n), filled)], axis=1)
            per_frame = compose(filled, p2.path, n)
            if covered is not None:
                per_frame[:covered[0]] = np.nan
                per_frame[covered[1] + 1:] = np.nan
            log.tick("pass2")
        elif passes == "pass2":
            p2 = pass2(bmk, hmk, width=located.width1, constraints=cons, diagonal_weight=0.0)
            path, per_frame = p2.path, path_median(p2.path, n)
            log.tick("pass2")
    except (BandError, ConstraintError) as e:
        raise _pin_error(e, markers.pins, f"{s} side") from None
    except SplicerError as e:
        raise type(e)(f"{s} side: {e}") from None
    conf = None
    if located.posterior is not None:  # the expected path's own spread (measured: benchmarks/HISTORY.md)
        conf = posterior_confidence(located.posterior, fps)
    elif p1 is not None:  # the best path alone (temperature 0): the cost landscape around it
        log.progress(f"{s}: confidence", 0.0)
        conf = pass_confidence(p1, fps)
    if conf is not None and _unmatched(located.evidence):
        conf = conf.with_floor(_no_evidence_error_s(markers.hands.n_frames, markers.hands.fps))
    if p1 is not None:
        log.tick("confidence")
    if covered is not None and covered[1] - covered[0] + 1 < 0.1 * n:
        log.note(f"{s} side: the hands take covers only body frames {covered[0]}-{covered[1]} "
                 f"({(covered[1] - covered[0] + 1) / fps:.1f} s of {n / fps:.1f} s): check that both takes show the "
                 "same performance, or pin a matching pair")
    return Alignment(per_frame, path, p1, p2, cons, covered, conf, located.ends, located.posterior,
                     located.own.get(s), located.evidence)


def align_side(markers: SideMarkers, opts: SpliceOptions, log: Log | None = None, *, ends: str = "auto",
               offset_s: float | None = None, guide: np.ndarray | None = None,
               smooth_s: float | None = None, noisy: bool | None = None) -> Alignment:
    """Pass 1 (phase metric D1) and pass 2 (palm metric D2) of one side, composed, with a confidence
    (:func:`locate`, then :func:`refine`).

    Parameters
    ----------
    ends : {"auto", "open", "fixed"}
        ``"open"``: the overlap of the two takes is found (the body's span anywhere inside
        the hands take, or the hands covering part of the body); ``"fixed"``: first frames
        match and last frames match (the paper).  ``"auto"`` (the default): open, except that
        takes found to start and end together are aligned end to end (fixed), and an overlap
        far shorter than both takes allow is not trusted: the takes are then aligned end to
        end, with a warning (:func:`_choose_ends`).
    offset_s : float, optional
        Open ends: body frame 0 shows hands time ``offset_s`` (a starting guess, e.g. timecode).
    guide : np.ndarray [shape=(K, 2)], optional
        Fixed ends: a pass-1 path (body frame, common hands frame) whose neighbourhood pass 1
        searches instead of the diagonal's (:func:`splicer.align.passes.pass1`).  With
        ``ends="auto"``, an open-ended pass 1 that found both corners guides the end-to-end one.

    smooth_s : float, optional
        The phase metric's marker smoothing, seconds (:func:`phase_smoothing` of the pair);
        default: this side's own noise matching.
    noisy : bool, optional
        Noise matching smoothed the pair (either side): pass 1 weighs positions more
        (:func:`position_weights`); default: this side's ``smooth_s`` says.

    Raises
    ------
    SplicerError
        A band that cannot reach the pins, named by their file and line.
    """
    log = log or Log()
    if smooth_s is None:  # one side alone: its own noise matching
        smooth_s = phase_smoothing({markers.side: markers}, opts, log)[markers.side]
    located = locate(markers, opts, log, ends=ends, offset_s=offset_s, guide=guide, smooth_s=smooth_s, noisy=noisy)
    try:
        return refine(markers, located, opts, log, smooth_s=smooth_s)
    finally:
        located.release()


def agree_ends(aligned: dict, markers: dict, opts: SpliceOptions, log: Log | None = None, *, ends: str = "auto",
               offset_s: float | None = None, smooth: dict | None = None) -> dict:
    """One end condition for both hands (``ends="auto"``): the takes' overlap is the takes', not an arm's.

    Both hands come from one hands take, so whether it starts and ends with the body is one
    question.  When ``ends="auto"`` let one side align end to end (its open-ended path found
    both corners, or an overlap too short to trust: :func:`_choose_ends`) and the other keep an
    open-ended path, the open one is aligned again end to end, its band following the other
    side's pass-1 path (both hands share one time map when all is well).  Measured on the ground-truth
    protocol (tuning seeds 0-3, README *Accuracy*; benchmarks/HISTORY.md): the sides differed in 2 of 60 runs (speed
    and imitation), and aligning both end to end cut those runs' mean error from 0.18 to
    0.05 s and from 3.4 to 1.4 s; the bundled sample's left side goes from 0.12 to 0.09 s.

    Parameters
    ----------
    aligned : dict of str -> Alignment
        Each side's :func:`align_side` result.
    markers : dict of str -> SideMarkers
        Each side's markers (to align a side again).
    opts, log, ends, offset_s
        As given to :func:`align_side`.
    smooth : dict of str -> float, optional
        Each side's ``smooth_s`` as given to :func:`align_side` (:func:`phase_smoothing`).

    Returns
    -------
    dict of str -> Alignment
        ``aligned`` itself when the sides agree (or ``ends`` is not ``"auto"``); otherwise a
        new dict with the open-ended sides aligned end to end.
    """
    if ends != "auto" or {a.ends for a in aligned.values()} != {"open", "fixed"}:
        return aligned
    log = log or Log()
    out = dict(aligned)
    fixed = [s for s, a in aligned.items() if a.ends == "fixed"]
    for s, a in aligned.items():
        if a.ends == "open":
            log.note(f"{s} side: the {' and '.join(fixed)} side's alignment runs end to end; both hands come from one "
                     "take, so this side is aligned end to end too (--ends open keeps its open ends)")
            out[s] = align_side(markers[s], opts, log, ends="fixed", offset_s=offset_s,
                                guide=aligned[fixed[0]].pass1.path, smooth_s=(smooth or {}).get(s),
                                noisy=_noisy(smooth, opts))
    return out


#: ends="auto": an open-ended path starting and ending within this of the corners means the
#: takes start and end together (seconds)
_TOGETHER_S = 1.0
#: _choose_ends' reason for aligning end to end when the open-ended path runs corner to corner
_TOGETHER_WHY = "the takes start and end together"
#: ends="auto": an overlap shorter than this share of what both takes allow is not trusted
_PLAUSIBLE_SHARE = 0.5


def _choose_ends(p1, n: int, m: int, fps: float, pins) -> str | None:
    """ends="auto": None to keep the open-ended pass 1, else why to align end to end instead
    (a leading ``!`` marks a reason worth a warning).

    * The open-ended path starts within :data:`_TOGETHER_S` of both first frames and ends within
      it of both last frames: the takes start and end together, and fixed ends (the paper) are
      measured more accurate there (README *Accuracy*; benchmarks/HISTORY.md).
    * The covered span is shorter than :data:`_PLAUSIBLE_SHARE` of the shorter take although no
      pin says so and the takes last about as long (2/3 to 3/2): with noisy or repetitive
      motion, an open end can lock onto a short stretch that happens to match; aligning end to
      end is the safer answer, with a warning.  A hands take much shorter or longer than the
      body keeps the open-ended answer (stretching it end to end would be worse).
    """
    if _corner_to_corner(p1.path, n, m, fps):
        return _TOGETHER_WHY
    a, b = p1.covered
    comparable = 2.0 / 3.0 <= m / n <= 1.5  # end to end needs no more than the protocol's 0.5x-2x local speeds
    if not pins and comparable and (b - a + 1) < _PLAUSIBLE_SHARE * min(n, m):
        return (f"!the open-ended alignment found an overlap of only {(b - a + 1) / fps:.1f} s (body frames {a}-{b}) "
                f"although both takes last {min(n, m) / fps:.1f} s or more; it is not trusted and the takes are aligned "
                "end to end (--ends open keeps it, --ends fixed says so)")
    return None


def _arm_together(p1, own_paths: list, sides: list, n: int, m: int, fps: float, long_s: float):
    """After an open-ended pass 1 over both arms that did not run corner to corner: the first
    arm (name, full-rate path) whose own path does and that the other arms do not contradict,
    else ``(None, None)``; and a note for each such path not trusted (:func:`_contradicted`).

    Each arm's own path in the pass's band is asked first; then (takes up to ``long_s`` seconds,
    where the coarse matrix is small) each arm aligned as if alone
    (:func:`splicer.align.passes.arm_alone`: its own locating pass and penalty).  The shared
    path can lose a corner that one arm alone finds (held-out zeggs *speed*, seed 102: the
    hands run 3x slower over the last 7.6 s, and the shared locating path skipped them);
    aligned each on its own, the pair went end to end by :func:`agree_ends`, and so it does here.

    Returns
    -------
    (str or None, np.ndarray or None, list of str)
    """
    from ..align.passes import arm_alone

    notes: list = []

    def trusted(k, q):
        why = _contradicted(p1, k, q, sides, n, m, fps)
        if why is not None:
            notes.append(why)
        return why is None

    for k, (side, q) in enumerate(zip(sides, own_paths)):
        if _corner_to_corner(q, n, m, fps) and trusted(k, q):
            return side, q, notes
    if p1.located is None or n / fps > long_s or not p1.located.arm_costs:
        return None, None, notes
    for k, side in enumerate(sides):
        q = arm_alone(p1, k)
        if _corner_to_corner(q, n, m, fps) and trusted(k, q):
            return side, q, notes
    return None, None, notes


def _contradicted(p1, k: int, q: np.ndarray, sides: list, n: int, m: int, fps: float) -> str | None:
    """Why arm ``k``'s corner-to-corner path ``q`` is not trusted, or None.

    Where the shared open-ended path leaves at least :data:`_TOGETHER_S` of body frames
    uncovered, ``q`` gives them hands material.  If another arm's local cost along ``q`` over
    those frames averages at least that arm's uncovered penalty (the cost above which its own
    alignment would rather leave a frame uncovered), that arm says the material there is not
    the body's performance: the takes do not start and end together.  On the protocol's
    *all* scenario (hands covering 59-81 % of the body, tuning seeds 0-7 and 200-219) the other
    arm's cost there was 1.9-4.3x its penalty; where the shared path covered every body frame
    (the rule's genuine cases) there is nothing to check.
    """
    a, b = (int(v) for v in p1.covered)
    rows = np.zeros(n, bool)
    rows[:a] = True
    rows[b + 1:] = True
    rows &= np.bincount(np.asarray(q)[:, 0], minlength=n) > 0
    if rows.sum() < _TOGETHER_S * fps:
        return None
    from ..align.evidence import costs_along
    from ..transfer.timemap import frame_ranges

    for o in range(len(p1.arm_costs)):
        if o == k:
            continue
        u = float(p1.arm_uncovered[o]) if o < len(p1.arm_uncovered) else float(p1.uncovered_cost)
        c = costs_along(p1.arm_costs[o], q, n, m)[rows]
        if np.mean(c) >= u:
            spans = ", ".join(f"{i}-{j}" for i, j in frame_ranges(rows))
            return (f"the {sides[k]} arm's own alignment runs from the takes' first frames to their last, but over "
                    f"body frames {spans}, which the open ends leave uncovered, the {sides[o]} arm's motion matches it "
                    f"no better than unrelated material ({np.mean(c) / u:.1f}x its uncovered penalty): the open ends "
                    "are kept")
    return None


def _fixed_constraints(markers: SideMarkers, m: int):
    """The side's pins as constraints of a pass with fixed ends (common frames), or None when a pin
    on a first or last frame contradicts fixed ends (the pair then keeps its open ends)."""
    try:
        return tuple(markers.spaces.dtw_constraints(markers.pins, m, open_ends=False))
    except ConstraintError:
        return None


def _close_ends(p1, n: int, m: int, fps: float, constraints=(), pins=()):
    """ends="auto", after an open-ended pass 1 that neither ran corner to corner nor found too short
    an overlap: a corner-to-corner guide when the path covers the whole body (within
    :data:`_TOGETHER_S`) and the hands material it leaves at either end continues the performance
    (:func:`splicer.align.openend.close_end`, :data:`splicer.defaults.CLOSE_ENDS_EXCESS`), with a
    note for the summary; else ``(None, None)``.

    ``constraints``: the pins as constraints of a pass with fixed ends
    (:func:`_fixed_constraints`); the guide must pass every one within its tolerance (the open
    path does; a re-aligned end may not), else the ends stay open, with a note naming the pin
    (from ``pins``, the side's :class:`~splicer.align.frames.Pin` list) that kept them open:
    ``(None, note)``.  None (a pin that fixed ends contradict): ``(None, None)``.

    The open end is free, so wherever the hands take runs slower than the body near an end, the
    open path stops short of real material (held-out synthetic *speed + imitation*, seed 101: 2.3 s
    of hands material left, errors up to 1 s over the body's last 1.5 s).
    """
    from ..align.openend import close_end

    if constraints is None:
        return None, None
    path = np.asarray(p1.path, dtype=np.int64)
    tol = _TOGETHER_S * fps
    (i0, j0), (i1, j1) = path[0], path[-1]
    if i0 > tol or (n - 1 - i1) > tol or p1.local_cost is None:
        return None, None  # body frames without hands material: the hands take is shorter, not slower
    rows = max(1, int(round(D.CLOSE_ENDS_S * fps)))
    said = []
    for end, left in (("head", int(j0)), ("tail", int(m - 1 - j1))):
        if left <= tol:
            continue
        if left > D.CLOSE_ENDS_MAX_S * fps:
            return None, None
        c = close_end(path, p1.local_cost, n, m, end, rows)
        z = c.excess(p1.uncovered_cost)
        if not z < D.CLOSE_ENDS_EXCESS:
            return None, None
        joint = c.path[-1] if end == "head" else c.path[0]
        k = int(np.flatnonzero((path[:, 0] == joint[0]) & (path[:, 1] == joint[1]))[0])
        path = np.concatenate([c.path, path[k + 1:]]) if end == "head" else np.concatenate([path[:k], c.path])
        said.append(f"{c.left_hands / fps:.1f} s at the {'start' if end == 'head' else 'end'} (costs "
                    f"{100 * max(z, 0.0):.0f}% of the way to unrelated material)")
    if not said:
        return None, None
    found = "the open-ended alignment left hands material that matches the performance: " + " and ".join(said)
    missed = _missed_constraint(path, constraints)
    if missed is not None:
        named = [p.describe() for p in pins if p.body == missed.x] or [f"the pin at body frame {missed.x}"]
        return None, (f"{found}, but aligned end to end that end would miss {named[0]}, so the ends stay open "
                      "(the frames near that end may be off: check the pin, or pin a frame near the end)")
    return path, (found + "; the hands take runs slower there, so the takes are aligned end to end "
                  "(--ends open keeps the open ends)")


def _missed_constraint(path: np.ndarray, constraints):
    """The first constraint whose row has no cell of ``path`` within its window ``[y - T, y + T]``,
    or None when the path passes every one."""
    for c in constraints:
        cols = path[path[:, 0] == c.x, 1]
        if not np.any(np.abs(cols - c.y) <= c.tolerance):
            return c
    return None


def _corner_to_corner(path: np.ndarray, n: int, m: int, fps: float) -> bool:
    """The path starts within :data:`_TOGETHER_S` of both first frames and ends within it of both last frames."""
    tol = _TOGETHER_S * fps
    (i0, j0), (i1, j1) = path[0], path[-1]
    return bool(i0 <= tol and j0 <= tol and (n - 1 - i1) <= tol and (m - 1 - j1) <= tol)


def _cover_pins(covered: tuple, pins, n: int) -> tuple:
    """The covered body range widened to every pinned body frame (a pin says that frame has hands material)."""
    a, b = covered
    for p in pins:
        a, b = min(a, p.body), max(b, p.body)
    return (max(a, 0), min(b, n - 1))


def _disagreement(aligned: dict, fps: float) -> tuple[float, float]:
    """Mean seconds between the two sides' time maps (or, after one pass 1 for both arms, the
    larger of that and the shared path's departure from either arm's own path:
    :func:`splicer.stages.crosscheck.arms_departure`), and the share of frames over
    :data:`LOW_CONFIDENCE_S`, over the body frames both cover (NaN, NaN: none)."""
    from .crosscheck import sides_disagreement
    from .report import LOW_CONFIDENCE_S

    x, y = aligned.values()
    d, _ = sides_disagreement(x.per_frame, y.per_frame, fps, x, y, fps)  # per_frame: common frames, the body rate
    d = d[np.isfinite(d)]
    if not d.size:
        return float("nan"), float("nan")
    return float(d.mean()), float(np.mean(d > LOW_CONFIDENCE_S))


def align_pair(markers: dict, opts: SpliceOptions, log: Log | None = None, *, ends: str = "auto",
               offset_s: float | None = None) -> dict:
    """Align every side (:func:`phase_smoothing`; one :func:`locate` for both arms when
    :func:`arms_together`, then :func:`refine` per side; otherwise :func:`align_side` per side
    and :func:`agree_ends`), with a second opinion on the smoothing when the two hands disagree.

    Both hands come from one hands take, so where their time maps part, one of them is off
    (:mod:`splicer.stages.crosscheck`).  With ``noise_ratio="auto"``, two sides whose time maps
    are more than 0.1 s (:data:`~splicer.stages.report.LOW_CONFIDENCE_S`) apart in over
    :data:`splicer.defaults.RECHECK_SHARE` of the body frames, and noise matching not
    triggered, the pair is aligned again with each side matched at
    :data:`splicer.defaults.NOISE_RATIO` (a second performance whose excess stayed under the
    trigger), and the alignment whose hands agree better (smaller mean disagreement) is kept,
    with a note.

    Returns
    -------
    dict of str -> Alignment
    """
    from .report import LOW_CONFIDENCE_S

    log = log or Log()
    before = len(log.warnings)
    smooth = phase_smoothing(markers, opts, log)
    aligned = _align_all(markers, smooth, opts, log, ends, offset_s)
    if opts.noise_ratio != "auto" or len(markers) != 2 or opts.passes == "pass2":
        return aligned
    fps = next(iter(markers.values())).spaces.body_fps
    mean, share = _disagreement(aligned, fps)
    if not share > D.RECHECK_SHARE:
        return aligned
    if any(v != opts.smooth_s for v in smooth.values()):
        return aligned  # matched already: going back to the default smoothing by agreement was right 1 of 3 times
    second = log.aside("smoothed again")  # the other choice's own notes, kept only with its alignment
    other = phase_smoothing(markers, replace(opts, noise_ratio=D.NOISE_RATIO), second)
    if other == smooth:
        return aligned
    again = _align_all(markers, other, opts, second, ends, offset_s)
    log.tick("second opinion")
    mean2, _ = _disagreement(again, fps)
    widths = ", ".join(f"{s} {other[s]:g} s" for s in other)
    if mean2 < mean:
        del log.warnings[before:]
        log.warnings.extend(second.warnings)
        log.note(f"the hands' time maps disagreed by over {LOW_CONFIDENCE_S:g} s in {share:.0%} of body frames "
                 f"(mean {mean:.2f} s); aligned again with the phase metric's markers smoothed over {widths}, they "
                 f"agree better (mean {mean2:.2f} s), and that alignment is kept")
        return again
    return aligned


def _noisy(smooth: dict | None, opts: SpliceOptions) -> bool | None:
    """Noise matching smoothed either side of the pair (None: no pair's smoothing given)."""
    return None if not smooth else any(v > opts.smooth_s for v in smooth.values())


def arms_together(markers: dict, opts: SpliceOptions) -> bool:
    """Pass 1 weighs both arms at once (``opts.pass1_arms == "both"``): two sides with the same
    frames (they share the body and hands takes) and the same pins; otherwise each side alone."""
    if opts.pass1_arms != "both" or len(markers) != 2 or opts.passes == "pass2":
        return False
    a, b = markers.values()
    return (a.body.n_frames, a.hands.n_frames, a.body.fps, a.hands.fps) == \
        (b.body.n_frames, b.hands.n_frames, b.body.fps, b.hands.fps) and a.pins == b.pins


def _align_all(markers, smooth, opts, log, ends, offset_s) -> dict:
    noisy = _noisy(smooth, opts)
    if arms_together(markers, opts):  # one clock in each take: one pass 1 for both hands, pass 2 per side
        first, *rest = markers
        located = locate(markers[first], opts, log, others=tuple(markers[s] for s in rest), ends=ends,
                         offset_s=offset_s, smooth_s=smooth[first], noisy=noisy,
                         other_smooth=tuple(smooth[s] for s in rest))
        try:
            return {s: refine(mk, located, opts, log, smooth_s=smooth[s]) for s, mk in markers.items()}
        finally:
            located.release()
    aligned = {s: align_side(mk, opts, log, ends=ends, offset_s=offset_s, smooth_s=smooth[s], noisy=noisy)
               for s, mk in markers.items()}
    return agree_ends(aligned, markers, opts, log, ends=ends, offset_s=offset_s, smooth=smooth)
