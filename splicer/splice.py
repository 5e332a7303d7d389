"""The whole job: read, find roles, align each side in two passes, merge, carry the fingers over.

:func:`splice` is the library entry point (the ``splice`` command only parses its options and
calls it).  It returns a :class:`SpliceResult`: the output motion (the body's skeleton, frame
count and timing, finger joints driven by the hands capture) and the report.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .align import (PassResult, compose, pass1, pass2, path_median, remap_constraints, resample_markers,
                    warp_markers)
from .bvh import read_bvh
from .constraints import SpliceConfig, frame_number, read_config
from .dtw import Constraint, band_frames
from .errors import ConstraintError, SplicerError, SplicerWarning
from .handonly import coincident_forearm, hand_only_view, is_hand_only, wrist_source_notes
from .repair import hand_joints, repair_motion, repairs_summary
from .markers import Markers, arm_markers
from .merge import blend_jumps, median_rotations, pin_constraints, smooth_time_map
from .model import Motion
from .roles import FINGERS, SIDES, find_roles
from .timewarp import sample_rotations
from .transfer import FingerMap, carried_rotations, finger_map, graft_fingers

__all__ = ["SpliceOptions", "SideResult", "SpliceResult", "splice"]


@dataclass(frozen=True)
class SpliceOptions:
    """Options of :func:`splice` (all keyword arguments there).

    Band widths accept frames (int), a fraction of the body length (0.3 or ``"30%"``) or
    seconds (``"20s"``).
    """

    side: str = "both"
    band1: float | str = "30%"
    band2: float | str | None = None  # None: a third of band1 (the paper: 30% and 10%)
    theta: str = "window"  # or "heading"
    passes: str = "both"  # "pass1", "pass2" (pass 2 alone, for comparison) or "both"
    pass2_weight: float = 2.0  # radians per band width of departure from the pass-1 warp; 0 = literal
    pass2_d1_weight: float = 0.0  # weight of D1 (normalised) added to D2 in pass 2; 0 = literal
    merge: str = "timemap"  # or "median"
    smooth_s: float = 0.025  # marker smoothing before derivatives, seconds
    dead_zone: float = 0.01  # sign dead zone, fraction of the motion's RMS speed
    timemap_sigma_s: float = 0.2  # time-map smoothing, seconds
    blend_window: int = 4  # median merge: frames blended each side of a jump
    wrist: str = "body"  # or "hands": the wrist rotation comes from the hands capture too
    coarse: str = "auto"  # "on", "off", or "auto": on for takes over coarse_above_s seconds
    coarse_fps: float = 5.0  # rate of the coarse guide pass, frames per second
    coarse_above_s: float = 120.0
    hands_side: str | None = None  # side of a hand-only file whose names do not say
    repair: str = "on"  # "on": dropouts and gaps of the hands capture repaired (and reported) first; "off"


@dataclass(frozen=True, eq=False)
class SideResult:
    """Alignment of one side.

    Attributes
    ----------
    hands_frame : np.ndarray [shape=(n_body,)]
        0-based, possibly fractional hands-file frame used for each body frame.
    pass1, pass2 : PassResult or None
        Paths at the common (body) rate.
    constraints : list of dict
        The constraints as applied (body frame, hands frame, tolerance, file line).
    body_markers, hands_markers : Markers
        Hands markers at the body rate.
    """

    side: str
    hands_frame: np.ndarray
    pass1: PassResult | None
    pass2: PassResult | None
    constraints: list
    body_markers: Markers
    hands_markers: Markers
    rate_ratio: float


@dataclass(frozen=True, eq=False)
class SpliceResult:
    motion: Motion
    report: dict
    sides: dict = field(default_factory=dict)


def _load(m) -> Motion:
    if isinstance(m, Motion):
        return m
    return read_bvh(m)


def _align_up(markers: Markers, up_to: int) -> Markers:
    """Relabel axes cyclically (a proper rotation) so the vertical axis becomes ``up_to``."""
    if markers.up == up_to:
        return markers
    shift = (up_to - markers.up) % 3
    perm = [(k - shift) % 3 for k in range(3)]  # new axis k takes old axis perm[k]
    return Markers(markers.points[..., perm], markers.shoulder[..., perm], markers.heading,
                   up_to, markers.fps, markers.side)


def _constraints_for(cfg: SpliceConfig, side: str, body: Motion, hands: Motion) -> list[dict]:
    out = []
    for p in cfg.pairs:
        if p.side not in (side, "both"):
            continue
        where = f"{cfg.source}, line {p.line}: pair {p.index + 1}"
        x = frame_number(p.body, body.fps, what=f"{where}, body")
        y = frame_number(p.hands, hands.fps, what=f"{where}, hands")
        tol_spec = cfg.tolerance if p.tolerance is None else p.tolerance
        t = frame_number(tol_spec, hands.fps, what=f"{where}, tolerance")
        if not 0 <= x < body.n_frames:
            raise ConstraintError(f"{where}: body frame {x} is outside the body take (frames 0..{body.n_frames - 1})")
        if not 0 <= y < hands.n_frames:
            raise ConstraintError(f"{where}: hands frame {y} is outside the hands take (frames 0..{hands.n_frames - 1})")
        out.append({"body": x, "hands": y, "tolerance": t, "line": p.line, "where": where})
    for a, b in zip(out, out[1:]):
        if not (b["body"] > a["body"] and b["hands"] > a["hands"]):
            raise ConstraintError(
                f"{b['where']}: pairs must increase in both files: (body {a['body']}, hands {a['hands']}) at line "
                f"{a['line']} is followed by (body {b['body']}, hands {b['hands']})")
    return out


def _dtw_constraints(cons: list[dict], n: int, m: int, ratio: float) -> list[Constraint]:
    """User pairs in the frames of the common-rate sequences; pairs on the first/last frames are
    the DTW's own end points and are dropped (they must match those end points)."""
    out = []
    for c in cons:
        x = c["body"]
        y = int(round(c["hands"] / ratio))
        t = int(math.ceil(c["tolerance"] / ratio))
        if x in (0, n - 1) or y <= 0 or y >= m - 1:
            ends_ok = (x == 0 and y <= t) or (x == n - 1 and y >= m - 1 - t)
            if not ends_ok:
                raise ConstraintError(
                    f"{c['where']}: (body {c['body']}, hands {c['hands']}) conflicts with the alignment's end points: "
                    "the first frames of both takes match each other, and so do the last frames")
            continue
        out.append(Constraint(x, min(max(y, 1), m - 2), t))
    return out


def _hand_scale(body_sk, barm, hands_sk, harm) -> float | None:
    from .kinematics import rest_positions

    if barm.elbow is None or harm.elbow is None:
        return None
    rb, rh = rest_positions(body_sk), rest_positions(hands_sk)
    lb = np.linalg.norm(rb[barm.wrist] - rb[barm.elbow])
    lh = np.linalg.norm(rh[harm.wrist] - rh[harm.elbow])
    return float(lb / lh) if lh > 0 else None


def splice(body, hands, *, config: SpliceConfig | str | Path | None = None, progress=None,
           **options) -> SpliceResult:
    """Splice the hands capture's finger motion onto the body capture.

    Parameters
    ----------
    body, hands : Motion or path
        The full-body take and the hand take (a full skeleton, a forearm-rooted or a
        wrist-rooted hand).
    config : SpliceConfig or path, optional
        Constraints and joint mappings (see :mod:`splicer.constraints`).
    progress : callable, optional
        ``progress(stage: str, fraction: float)``; called often during long stages.
    **options
        Fields of :class:`SpliceOptions`.

    Returns
    -------
    SpliceResult
        ``.motion``: the body take with the hands' fingers; ``.report``: the JSON-ready report.
    """
    try:
        opts = SpliceOptions(**options)
    except TypeError as e:
        raise TypeError(f"splice(): {e}") from None
    _check_options(opts)
    t_start = time.perf_counter()
    timings: dict[str, float] = {}
    warn_list: list[str] = []

    def note(msg: str) -> None:
        warn_list.append(msg)

    def tick(stage: str, t0: float) -> float:
        t1 = time.perf_counter()
        timings[stage] = timings.get(stage, 0.0) + (t1 - t0)
        return t1

    def report_progress(stage: str, frac: float) -> None:
        if progress is not None:
            progress(stage, frac)

    t0 = time.perf_counter()
    report_progress("read", 0.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SplicerWarning)
        bm = _load(body)
        hm = _load(hands)
    for w in caught:
        if issubclass(w.category, SplicerWarning):
            note(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if isinstance(config, (str, Path)):
        cfg = read_config(config)
    else:
        cfg = config or SpliceConfig()
    t0 = tick("read", t0)

    hands_side = opts.hands_side or cfg.hands_side
    broles = find_roles(bm.skeleton, source=bm.source or "body", mapping=cfg.joints.get("body"), up=cfg.up.get("body"))
    hroles = find_roles(hm.skeleton, source=hm.source or "hands", mapping=cfg.joints.get("hands"),
                        up=cfg.up.get("hands"), side=hands_side)
    sides = list(SIDES) if opts.side == "both" else [opts.side]
    todo = []
    for s in sides:
        if s not in broles.sides:
            note(f"{bm.source or 'body'}: no {s} arm found; the {s} side is skipped")
        elif s not in hroles.sides:
            note(f"{hm.source or 'hands'}: no {s} hand found; the {s} side is skipped")
        elif not any(f in hroles.sides[s].fingers for f in FINGERS):
            note(f"{hm.source or 'hands'}: the {s} hand has no finger joints; the {s} side is skipped")
        else:
            todo.append(s)
    if not todo:
        raise SplicerError(
            f"no side can be spliced: body sides {sorted(broles.sides) or 'none'}, hands sides "
            f"{sorted(hroles.sides) or 'none'} (requested: {opts.side})")
    # --- issue 9 (c-handonly): dropouts and gaps of the hand capture, repaired before aligning ---
    hand_repairs = []
    if opts.repair == "on":
        t0 = time.perf_counter()
        hm, hand_repairs = repair_motion(hm, hand_joints(hm.skeleton, [hroles.sides[s] for s in todo]))
        if hand_repairs:
            note(repairs_summary(hand_repairs, hm.source or "hands"))
        tick("repair", t0)
    # --- end issue 9 ---
    n = bm.n_frames
    ratio = hm.fps / bm.fps
    w1 = band_frames(opts.band1, n=n, fps=bm.fps)
    w2 = w1 / 3.0 if opts.band2 is None else band_frames(opts.band2, n=n, fps=bm.fps)

    out = bm
    side_results: dict[str, SideResult] = {}
    report_sides: dict[str, dict] = {}
    for s in todo:
        t0 = time.perf_counter()
        report_progress(f"{s}: markers", 0.0)
        barm = find_roles(out.skeleton, source=bm.source, mapping=cfg.joints.get("body"), up=broles.up).sides[s]
        harm = hroles.sides[s]
        bmk = arm_markers(bm, broles.sides[s], broles.up)
        # --- issue 9 (c-handonly): a hand-only file has no shoulder nor elbow; the body's markers
        # are made the same way (from its root, with the same virtual forearm) ---
        if is_hand_only(harm) and not is_hand_only(broles.sides[s]):
            bmk = hand_only_view(bm, broles.sides[s], bmk,
                                 forearm_joint=coincident_forearm(hm.skeleton, harm) is not None)
        # --- end issue 9 ---
        hmk = _align_up(arm_markers(hm, harm, hroles.up), broles.up)
        hmk_c = resample_markers(hmk, bm.fps)
        m = hmk_c.n_frames
        cons = _constraints_for(cfg, s, bm, hm)
        dcons = _dtw_constraints(cons, n, m, ratio)
        t0 = tick("markers", t0)

        p1 = p2 = None
        try:
            if opts.passes in ("pass1", "both"):
                report_progress(f"{s}: pass 1", 0.0)
                guided = opts.coarse == "on" or (opts.coarse == "auto" and bm.duration > opts.coarse_above_s)
                p1 = pass1(bmk, hmk_c, width=w1, constraints=dcons, smooth_s=opts.smooth_s,
                           dead_zone=opts.dead_zone, theta=opts.theta,
                           coarse_fps=opts.coarse_fps if guided else None,
                           coarse_width=band_frames("30%", n=n, fps=bm.fps),
                           progress=lambda f, s=s: report_progress(f"{s}: pass 1", f))
                path = p1.path
                per_frame = path_median(path, n)
                t0 = tick("pass1", t0)
            if opts.passes == "both":
                report_progress(f"{s}: pass 2", 0.0)
                p2 = pass2(bmk, warp_markers(hmk_c, per_frame), width=w2,
                           constraints=remap_constraints(dcons, per_frame), diagonal_weight=opts.pass2_weight,
                           d1_weight=opts.pass2_d1_weight, smooth_s=opts.smooth_s, dead_zone=opts.dead_zone,
                           theta=opts.theta, progress=lambda f, s=s: report_progress(f"{s}: pass 2", f))
                cells = np.interp(p2.path[:, 1], np.arange(n), per_frame)
                path = np.stack([p2.path[:, 0], cells], axis=1)
                per_frame = compose(per_frame, p2.path, n)
                t0 = tick("pass2", t0)
            elif opts.passes == "pass2":
                report_progress(f"{s}: pass 2", 0.0)
                p2 = pass2(bmk, hmk_c, width=w1, constraints=dcons, diagonal_weight=0.0)
                path = p2.path
                per_frame = path_median(path, n)
                t0 = tick("pass2", t0)
        except SplicerError as e:
            raise type(e)(f"{s} side: {e}") from None

        # merge: hands-file frames
        hands_frames = per_frame * ratio
        pins = [(c["body"], float(c["hands"]), float(c["tolerance"])) for c in cons]
        last = hm.n_frames - 1
        report_progress(f"{s}: merge", 0.0)
        if not any(f in barm.fingers for f in FINGERS):
            scale = _hand_scale(bm.skeleton, broles.sides[s], hm.skeleton, harm)
            if scale is None:
                scale = 1.0
                note(f"{s} side: body has no finger joints and no forearm length to compare; "
                     "the hands' fingers are grafted at their own size")
            out, barm = graft_fingers(out, barm, hm.skeleton, harm, scale)
            note(f"{s} side: the body has no finger joints; grafted the hands' {len(barm.finger_joints)} finger joints under {out.skeleton.names[barm.wrist]}")
        fmap = finger_map(out.skeleton, barm, hm.skeleton, harm)
        if opts.wrist == "hands":
            # --- issue 9 (c-handonly): a forearm joint at the wrist's place (Leap) counts ---
            forearm = coincident_forearm(hm.skeleton, harm)
            if forearm is None:
                raise SplicerError(f"{hm.source or 'hands'}: --wrist hands needs a forearm joint above the {s} wrist in the hands file")
            for msg in wrist_source_notes(hm, harm, forearm):
                note(msg)
            fmap = FingerMap(fmap.body + (barm.wrist,), fmap.hands + ((harm.wrist,),), fmap.conj)
        sub = sorted({j for g in fmap.hands for j in g})
        local = FingerMap(fmap.body, tuple(tuple(sub.index(j) for j in g) for g in fmap.hands), fmap.conj)
        hq = hm.joint_rotations(sub)
        if opts.merge == "timemap":
            tm = smooth_time_map(hands_frames, sigma_frames=opts.timemap_sigma_s * bm.fps, last=last, pins=pins)
            q = sample_rotations(hq, tm)
        else:
            tm = np.clip(pin_constraints(hands_frames, pins), 0, last)
            q = median_rotations(hq, np.clip(path[:, 1] * ratio, 0, last), path[:, 0].astype(np.int64), n)
            q = blend_jumps(q, tm, jump=3.0 * max(ratio, 1.0), window=opts.blend_window)
            for x, y, t in pins:
                if t == 0:
                    q[x] = sample_rotations(hq, np.array([y]))[0]
        carried = carried_rotations(q, local)
        if fmap.body:
            out = out.with_rotations(list(fmap.body), carried)
        else:
            note(f"{s} side: no finger joints could be paired between body and hands")
        t0 = tick("merge", t0)
        side_results[s] = SideResult(s, tm, p1, p2, cons, bmk, hmk_c, ratio)
        report_sides[s] = {
            "hands_frame": [round(float(v), 4) for v in tm],
            "pass1": None if p1 is None else {"band_frames": round(float(p1.band.width), 3), "cost": float(p1.cost)},
            "pass2": None if p2 is None else {"band_frames": round(float(p2.band.width), 3), "cost": float(p2.cost)},
            "constraints": [{k: c[k] for k in ("body", "hands", "tolerance", "line")} for c in cons],
            "joints": {out.skeleton.names[b]: [hm.skeleton.names[j] for j in g] for b, g in zip(fmap.body, fmap.hands)},
        }
    timings["total"] = time.perf_counter() - t_start
    report = {
        "splicer": __version__,
        "body": {"path": bm.source, "frames": bm.n_frames, "fps": bm.fps},
        "hands": {"path": hm.source, "frames": hm.n_frames, "fps": hm.fps},
        "options": {k: getattr(opts, k) for k in opts.__dataclass_fields__},
        "sides": report_sides,
        "hands_repairs": [r.as_dict() for r in hand_repairs],
        "timings_s": {k: round(v, 4) for k, v in timings.items()},
        "warnings": warn_list,
    }
    report_progress("done", 1.0)
    return SpliceResult(out, report, side_results)


def _check_options(o: SpliceOptions) -> None:
    choices = {"side": ("left", "right", "both"), "theta": ("window", "heading"), "passes": ("pass1", "pass2", "both"),
               "merge": ("timemap", "median"), "wrist": ("body", "hands"), "hands_side": (None, "left", "right"),
               "coarse": ("auto", "on", "off"), "repair": ("on", "off")}
    for k, allowed in choices.items():
        if getattr(o, k) not in allowed:
            raise SplicerError(f"{k} must be one of {', '.join(str(a) for a in allowed)}, not {getattr(o, k)!r}")
    for k in ("smooth_s", "dead_zone", "timemap_sigma_s", "pass2_weight", "pass2_d1_weight", "coarse_fps",
              "coarse_above_s"):
        v = getattr(o, k)
        if not (isinstance(v, (int, float)) and v >= 0 and np.isfinite(v)):
            raise SplicerError(f"{k} must be a number >= 0, not {v!r}")
    if not (isinstance(o.blend_window, int) and o.blend_window >= 0):
        raise SplicerError(f"blend_window must be a whole number of frames >= 0, not {o.blend_window!r}")
