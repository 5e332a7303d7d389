"""The whole job as stages: load -> rig -> markers -> align -> time map -> transfer -> report.

:func:`splice` composes the stages; each stage is a function with a typed, frozen result,
usable on its own (notebooks, other tools).  Frame-space conversions live in
:mod:`splicer.frames`; options in :mod:`splicer.options`.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import defaults as D
from .errors import BandError, ConstraintError, SplicerError, SplicerWarning
from .align.frames import FrameSpaces, Pin, pins_from_config
from .model.motion import Motion
from .options import SpliceOptions, resolve_options
from .report import Report, SideReport

__all__ = ["Inputs", "Rig", "Conditioned", "SideMarkers", "Alignment", "Transfer", "SideResult", "SpliceResult", "Log",
           "load_inputs", "find_rig", "condition_hands", "side_markers", "align_side", "time_map", "transfer_side",
           "check_fingers", "build_report", "splice"]


class Log:
    """Warnings, stage timings and progress of one splice (the only mutable piece, kept here)."""

    def __init__(self, progress=None):
        self.warnings: list[str] = []
        self.timings: dict[str, float] = {}
        self._progress = progress
        self._t0 = time.perf_counter()
        self._start = self._t0

    def note(self, msg: str) -> None:
        """Add a warning for the report and the summary."""
        self.warnings.append(msg)

    def progress(self, stage: str, fraction: float) -> None:
        if self._progress is not None:
            self._progress(stage, fraction)

    def tick(self, stage: str) -> None:
        """Charge the time since the last tick to ``stage``."""
        t1 = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + (t1 - self._t0)
        self._t0 = t1

    def total(self) -> float:
        return time.perf_counter() - self._start


# ---------------------------------------------------------------- stage 1: load

@dataclass(frozen=True, eq=False)
class Inputs:
    """Both takes and the constraints/config file."""

    body: Motion
    hands: Motion
    config: object  # SpliceConfig
    # --- issue 14: optical markers (Trajectories) sharing each take's timeline, or None ---
    body_markers: object = None
    hands_markers: object = None

    @property
    def spaces(self) -> FrameSpaces:
        return FrameSpaces(self.body.n_frames, self.hands.n_frames, self.body.fps, self.hands.fps)


def load_inputs(body, hands, config=None, log: Log | None = None, *, body_markers=None,
                hands_markers=None) -> Inputs:
    """Read both takes (paths or :class:`~splicer.model.Motion`) and the config (path or SpliceConfig).

    ``body_markers``, ``hands_markers``: optional marker files (C3D, TRC, CSV; paths or
    :class:`~splicer.trajectories.Trajectories`) captured with each take, used for the alignment."""
    from .io.config import SpliceConfig, read_config
    from .io.motion_io import read_motion  # BVH or FBX by suffix

    log = log or Log()
    log.progress("read", 0.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SplicerWarning)
        bm = body if isinstance(body, Motion) else read_motion(body)
        hm = hands if isinstance(hands, Motion) else read_motion(hands)
    for w in caught:
        if issubclass(w.category, SplicerWarning):
            log.note(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    cfg = read_config(config) if isinstance(config, (str, Path)) else (config or SpliceConfig())
    # --- issue 14: optical markers ---
    mks = []
    for mk in (body_markers, hands_markers):
        if isinstance(mk, (str, Path)):
            from .io.trajectories import read_trajectories

            mk = read_trajectories(mk)
        for w in getattr(mk, "warnings", ()):
            log.note(w)
        mks.append(mk)
    log.tick("read")
    return Inputs(bm, hm, cfg, *mks)


# ---------------------------------------------------------------- stage 2: rig

@dataclass(frozen=True)
class Rig:
    """Skeleton roles of both takes, the sides to splice, and how each up axis was decided."""

    body: object  # Roles
    hands: object  # Roles
    sides: tuple[str, ...]
    up: dict = field(default_factory=dict)  # {"body": UpAxis, "hands": UpAxis}


def find_rig(inputs: Inputs, opts: SpliceOptions, log: Log | None = None) -> Rig:
    """Find each take's arms and hands; keep the sides both takes have (others: a warning).

    Raises
    ------
    SplicerError
        No side can be spliced.
    """
    from .io.limits import check_takes
    from .rig.roles import FINGERS, SIDES, find_roles
    from .rig.upaxis import detect_up

    log = log or Log()
    bm, hm, cfg = inputs.body, inputs.hands, inputs.config
    hands_side = opts.hands_side or cfg.hands_side
    # the up axis from the animated motion (head above hips...); the config's up: overrides
    up = {"body": detect_up(bm, override=cfg.up.get("body")), "hands": detect_up(hm, override=cfg.up.get("hands"))}
    for u, src in ((up["body"], bm.source or "body"), (up["hands"], hm.source or "hands")):
        if u.source == "motion" and u.axis != u.rest_axis:
            log.note(f"{src}: the rest skeleton stands along {'xyz'[u.rest_axis]} but the motion along "
                     f"{'xyz'[u.axis]} ({u.why}); using {'xyz'[u.axis]} as up")
    broles = find_roles(bm.skeleton, source=bm.source or "body", mapping=cfg.joints.get("body"), up=up["body"].axis)
    hroles = find_roles(hm.skeleton, source=hm.source or "hands", mapping=cfg.joints.get("hands"),
                        up=up["hands"].axis, side=hands_side)
    todo = []
    for s in (SIDES if opts.side == "both" else (opts.side,)):
        if s not in broles.sides:
            log.note(f"{bm.source or 'body'}: no {s} arm found; the {s} side is skipped")
        elif s not in hroles.sides:
            log.note(f"{hm.source or 'hands'}: no {s} hand found; the {s} side is skipped")
        elif not any(f in hroles.sides[s].fingers for f in FINGERS):
            log.note(f"{hm.source or 'hands'}: the {s} hand has no finger joints; the {s} side is skipped")
        else:
            todo.append(s)
    if not todo:
        raise SplicerError(
            f"no side can be spliced: body sides {sorted(broles.sides) or 'none'}, hands sides "
            f"{sorted(hroles.sides) or 'none'} (requested: {opts.side})")
    check_takes(bm, hm)  # frame counts and durations the splice can handle (splicer.limits)
    log.tick("roles")
    return Rig(broles, hroles, tuple(todo), up)


# ---------------------------------------------------------------- stage 2b: condition the hands take

@dataclass(frozen=True, eq=False)
class Conditioned:
    """The inputs after the hands take was checked and, where needed, converted.

    Attributes
    ----------
    inputs : Inputs
        With the hands motion mirrored (a mirror-image export) when that was decided.
    report : dict
        JSON-ready: ``{"handedness": {...}, "hands_repairs": [...]}``.
    """

    inputs: Inputs
    report: dict


def condition_hands(inputs: Inputs, rig: Rig, opts: SpliceOptions, log: Log | None = None) -> Conditioned:
    """Check the hands take before aligning: dropouts and gaps are repaired (listed in the report),
    and a mirror-image take is mirrored back, each with a warning.

    Raises
    ------
    SplicerError
        The handedness cannot be decided in ``auto`` mode (contradicting geometry).
    """
    from .rig.handedness import resolve_handedness
    from .rig.repair import hand_joints, repair_motion, repairs_summary

    log = log or Log()
    hm, repairs = inputs.hands, []
    if opts.repair == "on":  # dropouts and gaps of the hand capture, repaired before aligning (and listed)
        hm, repairs = repair_motion(hm, hand_joints(hm.skeleton, [rig.hands.sides[s] for s in rig.sides]))
        if repairs:
            log.note(repairs_summary(repairs, hm.source or "hands"))
    mode = opts.mirror_hands or inputs.config.mirror_hands or "auto"
    hm, handedness = resolve_handedness(inputs.body, rig.body, hm, rig.hands, rig.sides, mode=mode, note=log.note)
    log.tick("checks")
    return Conditioned(replace(inputs, hands=hm),
                       {"handedness": handedness, "hands_repairs": [r.as_dict() for r in repairs]})


# ---------------------------------------------------------------- stage 3: markers

@dataclass(frozen=True, eq=False)
class SideMarkers:
    """One side's markers at the common (body) rate, and its pins.

    Attributes
    ----------
    side : str
    body, hands : Markers
        Body markers (``n`` frames) and hands markers resampled to the body rate (``m`` frames).
    spaces : FrameSpaces
    pins : tuple of Pin
        The user's pins for this side, in file frames.
    """

    side: str
    body: object
    hands: object
    spaces: FrameSpaces
    pins: tuple
    real: dict = field(default_factory=dict)  # issue 14: "body"/"hands" -> optical marker report


def _align_up(markers, up_to: int):
    """Relabel axes cyclically (a proper rotation) so the vertical axis becomes ``up_to``."""
    from .rig.markers import Markers

    if markers.up == up_to:
        return markers
    shift = (up_to - markers.up) % 3
    perm = [(k - shift) % 3 for k in range(3)]  # new axis k takes old axis perm[k]
    return Markers(markers.points[..., perm], markers.shoulder[..., perm], markers.heading,
                   up_to, markers.fps, markers.side)


def side_markers(inputs: Inputs, rig: Rig, side: str, log: Log | None = None) -> SideMarkers:
    """Virtual markers of ``side`` in both takes, the hands brought to the body's rate and up axis."""
    from .align.passes import resample_markers
    from .rig.handonly import coincident_forearm, hand_only_view, is_hand_only
    from .rig.markers import arm_markers

    log = log or Log()
    log.progress(f"{side}: markers", 0.0)
    bm, hm = inputs.body, inputs.hands
    bmk = arm_markers(bm, rig.body.sides[side], rig.body.up)
    harm = rig.hands.sides[side]
    if is_hand_only(harm) and not is_hand_only(rig.body.sides[side]):
        # a hand-only file has no shoulder nor elbow: the body's markers are made the same way
        # (from its root, with the same virtual forearm)
        bmk = hand_only_view(bm, rig.body.sides[side], bmk, forearm_joint=coincident_forearm(hm.skeleton, harm) is not None)
    hmk = _align_up(arm_markers(hm, rig.hands.sides[side], rig.hands.up), rig.body.up)
    # --- issue 14: real optical markers replace the virtual ones of the take that has them ---
    real = {}
    for take, traj, motion in (("body", inputs.body_markers, bm), ("hands", inputs.hands_markers, hm)):
        if traj is None:
            continue
        from .rig.marker_arm import arm_from_trajectories, on_frames

        arm = arm_from_trajectories(traj, side, mapping=inputs.config.markers.get(take))
        if not arm.roles.sided and len(rig.sides) > 1 and inputs.config.hands_side != side:
            log.note(f"{traj.source}: the marker names tell no side; not used for the {side} side (name the side "
                     f"with hands_side: or under markers: in the constraints file)")
            continue
        mk, notes = on_frames(arm.markers, motion.n_frames, motion.fps, what=f"{traj.source} ({side} side)")
        for msg in arm.notes + notes:
            log.note(msg)
        real[take] = arm.report(traj)
        if take == "body":
            bmk = _align_up(mk, rig.body.up)
        else:
            hmk = _align_up(mk, rig.body.up)
    # --- end issue 14 ---
    pins = pins_from_config(inputs.config, side, inputs.spaces)
    out = SideMarkers(side, bmk, resample_markers(hmk, bm.fps), inputs.spaces, pins, real)
    log.tick("markers")
    return out


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

    def __repr__(self) -> str:
        return f"Alignment(body_frames={len(self.per_frame)}, passes={[p.name for p in (self.pass1, self.pass2) if p]})"


def _pin_error(e: SplicerError, pins: tuple[Pin, ...], side: str) -> SplicerError:
    """A band/constraint error in terms of the user's pins (file, line, numbers)."""
    seg = getattr(e, "segment", None)
    if isinstance(e, BandError) and seg is not None and pins:
        before = "the start of both takes" if seg == 0 else pins[seg - 1].describe()
        after = "the end of both takes" if seg >= len(pins) else pins[seg].describe()
        w = getattr(e, "min_width", None)
        wtxt = f"; a band of at least {w:.0f} body frames would (--band {int(np.ceil(w))})" if w else ""
        return type(e)(f"{side} side: the band cannot connect {before} to {after}{wtxt}")
    pair = getattr(e, "pair", None)
    if pair is not None and pins:
        a, b = pins[pair[0]], pins[pair[1]]
        return type(e)(f"{side} side: {b.describe()} cannot follow {a.describe()}: adjacent body frames cannot "
                       "match hands frames further apart than their tolerances allow")
    return type(e)(f"{side} side: {e}")


def align_side(markers: SideMarkers, opts: SpliceOptions, log: Log | None = None, *, ends: str = "auto",
               offset_s: float | None = None) -> Alignment:
    """Pass 1 (phase metric D1) and pass 2 (palm metric D2) of one side, composed, with a confidence.

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

    Raises
    ------
    SplicerError
        A band that cannot reach the pins, named by their file and line.
    """
    from .align.passes import compose, hold_ends, pass1, pass2, path_median, remap_constraints, warp_markers
    from .align.band import band_frames
    from .align.confidence import pass_confidence
    from .align.costs import matched_smoothing

    log = log or Log()
    s, bmk, hmk = markers.side, markers.body, markers.hands
    n, m = bmk.n_frames, hmk.n_frames
    fps = markers.spaces.body_fps

    smooth_s, noisier = matched_smoothing(bmk, hmk, smooth_s=opts.smooth_s, dead_zone=opts.dead_zone,
                                          ratio=opts.noise_ratio)
    if smooth_s != opts.smooth_s:
        log.note(f"{s} side: one take's arm is noisier (its motion changes direction {noisier:.1f}x as often, "
                 f"tempo allowed for): markers smoothed over {smooth_s:g} s instead of {opts.smooth_s:g} s "
                 "for the phase metric")
    elif noisier > D.NOISE_WARN:
        log.note(f"{s} side: one take's arm looks noisier (its motion changes direction {noisier:.1f}x as often, "
                 "tempo allowed for; a second performance or a jittery solve?): if the alignment is off, "
                 "try --noise-ratio 1.2")

    def run_pass1(mode: str):
        open_ends = mode == "open"
        band1 = opts.band1 if opts.band1 is not None else (D.OPEN_BAND1 if open_ends else D.BAND1)
        w1 = band_frames(band1, n=n, fps=fps)
        cons = tuple(markers.spaces.dtw_constraints(markers.pins, m, open_ends=open_ends))
        guided = opts.coarse == "on" or (opts.coarse == "auto" and n / fps > opts.coarse_above_s)
        p = pass1(bmk, hmk, width=w1, constraints=cons, smooth_s=smooth_s, dead_zone=opts.dead_zone,
                  theta=opts.theta, ends=mode, offset_s=offset_s if open_ends else None,
                  uncovered_quantile=opts.uncovered_quantile,
                  coarse_fps=None if open_ends else (opts.coarse_fps if guided else None),
                  coarse_width=None if open_ends else band_frames("30%", n=n, fps=fps),
                  progress=lambda f: log.progress(f"{s}: pass 1", f))
        return p, w1, cons

    p1 = p2 = None
    covered = None
    used = "fixed" if ends == "fixed" else "open"
    try:
        if opts.passes in ("pass1", "both"):
            log.progress(f"{s}: pass 1", 0.0)
            p1, w1, cons = run_pass1(used)
            if ends == "auto":
                why = _choose_ends(p1, n, m, fps, markers.pins)
                if why is not None:
                    used = "fixed"
                    p1, w1, cons = run_pass1("fixed")
                    if why.startswith("!"):
                        log.note(f"{s} side: {why[1:]}")
            for msg in getattr(p1, "notes", ()):
                log.note(f"{s} side: {msg}")
            path, per_frame = p1.path, path_median(p1.path, n)
            if used == "open":
                covered = _cover_pins(tuple(int(v) for v in p1.covered), markers.pins, n)
                if covered != tuple(p1.covered):
                    per_frame = hold_ends(per_frame)
                    per_frame[:covered[0]] = np.nan
                    per_frame[covered[1] + 1:] = np.nan
            log.tick("pass1")
        else:
            w1 = band_frames(opts.band1 if opts.band1 is not None else D.BAND1, n=n, fps=fps)
            cons = tuple(markers.spaces.dtw_constraints(markers.pins, m))
        w2 = w1 * D.BAND2_PER_BAND1 if opts.band2 is None else band_frames(opts.band2, n=n, fps=fps)
        if opts.passes == "both":
            log.progress(f"{s}: pass 2", 0.0)
            filled = hold_ends(per_frame)
            p2 = pass2(bmk, warp_markers(hmk, filled), width=w2, constraints=remap_constraints(cons, filled),
                       diagonal_weight=opts.pass2_weight, d1_weight=opts.pass2_d1_weight, smooth_s=smooth_s,
                       dead_zone=opts.dead_zone, theta=opts.theta, covered=covered,
                       progress=lambda f: log.progress(f"{s}: pass 2", f))
            path = np.stack([p2.path[:, 0], np.interp(p2.path[:, 1], np.arange(n), filled)], axis=1)
            per_frame = compose(filled, p2.path, n)
            if covered is not None:
                per_frame[:covered[0]] = np.nan
                per_frame[covered[1] + 1:] = np.nan
            log.tick("pass2")
        elif opts.passes == "pass2":
            p2 = pass2(bmk, hmk, width=w1, constraints=cons, diagonal_weight=0.0)
            path, per_frame = p2.path, path_median(p2.path, n)
            log.tick("pass2")
    except (BandError, ConstraintError) as e:
        raise _pin_error(e, markers.pins, s) from None
    except SplicerError as e:
        raise type(e)(f"{s} side: {e}") from None
    conf = None
    if p1 is not None:
        conf = pass_confidence(p1, fps)
        log.tick("confidence")
    if covered is not None and covered[1] - covered[0] + 1 < 0.1 * n:
        log.note(f"{s} side: the hands take covers only body frames {covered[0]}-{covered[1]} "
                 f"({(covered[1] - covered[0] + 1) / fps:.1f} s of {n / fps:.1f} s): check that both takes show the "
                 "same performance, or pin a matching pair")
    return Alignment(per_frame, path, p1, p2, cons, covered, conf, used)


#: ends="auto": an open-ended path starting and ending within this of the corners means the
#: takes start and end together (seconds)
_TOGETHER_S = 1.0
#: ends="auto": an overlap shorter than this share of what both takes allow is not trusted
_PLAUSIBLE_SHARE = 0.5


def _choose_ends(p1, n: int, m: int, fps: float, pins) -> str | None:
    """ends="auto": None to keep the open-ended pass 1, else why to align end to end instead
    (a leading ``!`` marks a reason worth a warning).

    * The open-ended path starts within :data:`_TOGETHER_S` of both first frames and ends within
      it of both last frames: the takes start and end together, and fixed ends (the paper) are
      measured more accurate there (README, *Accuracy*).
    * The covered span is shorter than :data:`_PLAUSIBLE_SHARE` of the shorter take although no
      pin says so and the takes last about as long (2/3 to 3/2): with noisy or repetitive
      motion, an open end can lock onto a short stretch that happens to match; aligning end to
      end is the safer answer, with a warning.  A hands take much shorter or longer than the
      body keeps the open-ended answer (stretching it end to end would be worse).
    """
    tol = _TOGETHER_S * fps
    (i0, j0), (i1, j1) = p1.path[0], p1.path[-1]
    if i0 <= tol and j0 <= tol and (n - 1 - i1) <= tol and (m - 1 - j1) <= tol:
        return "the takes start and end together"
    a, b = p1.covered
    comparable = 2.0 / 3.0 <= m / n <= 1.5  # end to end needs no more than the protocol's 0.5x-2x local speeds
    if not pins and comparable and (b - a + 1) < _PLAUSIBLE_SHARE * min(n, m):
        return (f"!the open-ended alignment found an overlap of only {(b - a + 1) / fps:.1f} s (body frames {a}-{b}) "
                f"although both takes last {min(n, m) / fps:.1f} s or more; it is not trusted and the takes are aligned "
                "end to end (--ends open keeps it, --ends fixed says so)")
    return None


def _cover_pins(covered: tuple, pins, n: int) -> tuple:
    """The covered body range widened to every pinned body frame (a pin says that frame has hands material)."""
    a, b = covered
    for p in pins:
        a, b = min(a, p.body), max(b, p.body)
    return (max(a, 0), min(b, n - 1))


# ---------------------------------------------------------------- stage 5: time map

def time_map(alignment: Alignment, markers: SideMarkers, opts: SpliceOptions) -> np.ndarray:
    """Hands-file frame for each body frame: smoothed, monotone, every pin held within its T.

    Body frames outside the covered range (open ends) have no hands material: NaN there.

    Returns
    -------
    np.ndarray [shape=(n_body,), dtype=float64]
        Non-decreasing over the covered frames, within ``[0, n_hands - 1]``; NaN elsewhere.
    """
    from .transfer.timemap import pin_constraints, smooth_time_map

    sp = markers.spaces
    n = len(alignment.per_frame)
    a, b = alignment.covered if alignment.covered is not None else (0, n - 1)
    hands_frames = sp.common_to_hands(alignment.per_frame[a:b + 1])
    pins = [(p.body - a, float(p.hands), float(p.tolerance)) for p in markers.pins if a <= p.body <= b]
    last = sp.n_hands - 1
    tm = np.full(n, np.nan)
    if opts.merge == "timemap":  # both keep every pin within its window (pin_constraints)
        tm[a:b + 1] = smooth_time_map(hands_frames, sigma_frames=opts.timemap_sigma_s * sp.body_fps, last=last,
                                      pins=pins)
    else:
        tm[a:b + 1] = np.clip(pin_constraints(hands_frames, pins), 0, last)
    return tm


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
    from .rig.handgeom import hand_frame_warnings
    from .transfer.sanity import finger_sanity, sanity_warnings

    log = log or Log()
    hm, harm = inputs.hands, rig.hands.sides[side]
    reading = handedness.get("body", {}).get(side, {}).get("geometric") or side
    san = finger_sanity(transfer.motion, transfer.arm, +1 if reading == "right" else -1)
    src_read = handedness.get("hands", {}).get(side, {}).get("geometric") or side
    if handedness.get("mirrored"):
        src_read = "left" if src_read == "right" else "right"
    shown = np.isfinite(tm)
    frames = np.clip(np.round(tm[shown]).astype(np.int64), 0, hm.n_frames - 1)
    src_san = finger_sanity(hm.with_channels(hm.channels[frames]), harm, +1 if src_read == "right" else -1)
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
    from .transfer.timemap import blend_jumps, coverage_weights, median_rotations
    from .rig.roles import FINGERS, find_roles
    from .model.rotations import quat_slerp
    from .transfer.sampling import sample_rotations
    from .rig.handgeom import graft_scale
    from .rig.handonly import coincident_forearm, wrist_source_notes
    from .transfer.fingers import FingerMap, carried_rotations, finger_map, graft_fingers

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
    hq = hm.joint_rotations(sub)
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
    if fmap.body:
        carried = carried_rotations(q, local)
        if alignment.covered is not None:  # uncovered body frames keep the body's own rotations
            w = coverage_weights(len(tm), alignment.covered, window=int(round(opts.uncovered_blend_s * bm.fps)))
            carried = quat_slerp(out.joint_rotations(list(fmap.body)), carried, w[:, None])
        out = out.with_rotations(list(fmap.body), carried)
    else:
        log.note(f"{side} side: no finger joints could be paired between body and hands")
    log.tick("transfer")
    return Transfer(out, {out.skeleton.names[b]: [hm.skeleton.names[j] for j in g]
                          for b, g in zip(fmap.body, fmap.hands)}, barm, extra)


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


def _coverage_report(r: SideResult, n: int, log: Log) -> dict:
    """Report keys for covered/uncovered frames and confidence; warnings for the summary."""
    from .transfer.timemap import frame_ranges

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
        log.note(f"{r.side} side: no hands material covers body frames {spans}; they keep the body's own "
                 "fingers, blended in and out")
    conf = aln.confidence
    if conf is not None:
        from .report import _round_list

        out["confidence"] = _round_list(conf.confidence, 3)
        out["est_error_s"] = _round_list(conf.est_error_s, 4)
        low = frame_ranges(np.nan_to_num(conf.est_error_s, nan=0.0) > LOW_CONFIDENCE_S, min_gap=2)
        out["low_confidence"] = low
        if low:
            fps = r.markers.spaces.body_fps
            worst = sorted(low, key=lambda ab: -float(np.nanmax(conf.est_error_s[ab[0]:ab[1] + 1])))[:3]
            where = ", ".join(f"{a}-{b} (~{np.nanmax(conf.est_error_s[a:b + 1]):.2f} s)" for a, b in worst)
            share = sum(b - a + 1 for a, b in low) / n
            log.note(f"{r.side} side: low confidence in {100 * share:.0f}% of body frames; worst {where}; a pin "
                     f"(constraints file) near frame {(worst[0][0] + worst[0][1]) // 2} would help most")
    return out


def build_report(inputs: Inputs, opts: SpliceOptions, sides: dict, log: Log, extra: dict | None = None) -> Report:
    """The typed report of a finished splice (``extra``: further top-level keys)."""
    from . import __version__

    def pass_info(p):
        return None if p is None else {"band_frames": round(float(p.band.width), 3), "cost": float(p.cost)}

    side_reports = {}
    for s, r in sides.items():
        pins = tuple({"body": p.body, "hands": p.hands, "tolerance": p.tolerance, "line": p.line} for p in r.pins)
        real = {"markers": r.markers.real} if r.markers.real else {}  # optical markers used (file, roles, gaps)
        side_reports[s] = SideReport(s, r.hands_frame, pass_info(r.pass1), pass_info(r.pass2), pins, r.joints,
                                     {**r.extra, **real, **_coverage_report(r, inputs.body.n_frames, log)})
    bm, hm = inputs.body, inputs.hands
    timings = dict(log.timings, total=log.total())
    return Report(__version__, {"path": bm.source, "frames": bm.n_frames, "fps": bm.fps},
                  {"path": hm.source, "frames": hm.n_frames, "fps": hm.fps},
                  {f: getattr(opts, f) for f in opts.__dataclass_fields__}, side_reports, timings,
                  tuple(log.warnings), dict(extra or {}))


# ---------------------------------------------------------------- the whole job

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
    for s in rig.sides:
        markers = side_markers(inputs, rig, s, log)
        alignment = align_side(markers, opts, log, ends=opts.ends or inputs.config.ends or "auto",
                               offset_s=opts.offset_s if opts.offset_s is not None else inputs.config.offset_s)
        tm = time_map(alignment, markers, opts)
        transfer = transfer_side(out, inputs, rig, s, alignment, tm, opts, log, pins=markers.pins)
        sanity = check_fingers(transfer, s, inputs, rig, tm, checked.report["handedness"], log)
        out = transfer.motion
        sides[s] = SideResult(s, tm, markers, alignment, transfer.joints, {**transfer.extra, **sanity})
    report = build_report(inputs, opts, sides, log,
                          extra={**checked.report, "up": {k: u.as_dict() for k, u in rig.up.items()}})
    log.progress("done", 1.0)
    return SpliceResult(out, report, sides)
