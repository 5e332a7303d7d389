"""Stage 6c, a second opinion: a noisy pair aligned again with the arms' positions weighed more.

Where noise matching smoothed the pair (a second performance, a jittery solve), pass 1 weighs the
arms' shoulder-relative positions by :data:`splicer.defaults.POSITION_WEIGHT_NOISY` beside D1's
direction signs (:func:`splicer.stages.align.position_weights`).  Where the arm's noise leaves the
signs little to go by (a slow gesture: the noise per frame is as large as the motion), a larger
weight can be far better, and elsewhere a little worse.  So the pair is aligned again at
:data:`splicer.defaults.POSITION_WEIGHT_RECHECK`, and (0.27.0) once more at that weight with each
take's phase markers smoothed to the tempo the first maps show (:func:`tempo_markers`,
:mod:`splicer.align.tempo`: noise matching's smoothing blurs the faster take over more of the
performance), their time maps made as the first's were (smoothed, refined by the wrist), and the
pair of maps along which the hand moves relative to the forearm most alike in both takes (a signal
pass 1 does not read, which the arm's noise leaves clean) is kept, with a note.  Where the first
pair's overlap was located (open ends), a third second opinion (0.32.0) aligns it with a cheaper
uncovered penalty (:data:`splicer.defaults.SHORTER_OPINION_QUANTILE`), a candidate only when it
covers clearly less (:func:`covered_frames`): the first may have stretched the hands' last genuine
material over body frames past its end.  Since 0.34.0 the alignments are judged frame by frame over
every body frame any of them covers (:func:`coverage_mismatch`): the mismatch over the second around
the frame where an alignment covers it, a fixed price where it does not
(:data:`splicer.defaults.JUDGE_UNCOVERED`), so that an alignment that drops genuine material, or
covers unrelated material, pays for it.  A second opinion that placed the hands' material elsewhere
altogether (:data:`splicer.defaults.SECOND_OPINION_RELOCATED_S`, 0.29.1) is kept whole or left out.
Since 0.28.0 the kept pair's time maps are then combined frame by frame with the others near it
(:func:`blend_maps`): each map weighed by that mismatch over the second around the frame
(:func:`splicer.align.wrist.local_rate_mismatch`), as the alignment best along one stretch is not
always the best along the next.  Since 0.35.0 the combination first chooses which map to follow
at each frame, the path of least mismatch that never steps back to a map behind (:func:`_follow`),
and weighs only the maps near it: a map seconds away that reads better for a few frames (where
the followed one's window reaches unrelated material) no longer pulls the non-decreasing
combination seconds ahead.  Measured on the ground-truth protocol (benchmarks/HISTORY.md, 0.18.0,
0.27.0, 0.28.0, 0.32.0, 0.34.0 and 0.35.0).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import defaults as D
from ..options import SpliceOptions
from .log import Log

__all__ = ["wants_second_opinion", "coverage_mismatch", "side_mismatch", "map_distance_s", "tempo_markers", "covered_frames",
           "forearm_motion_compares", "position_second_opinion", "blend_maps"]

#: How each second opinion was made, for its notes: a relocated one's, and the kept one's (longer).
_HOW = {"positions": "", "tempo": ", its markers tempo-matched",
        "shorter": ", an uncovered body frame costing less (a shorter overlap)"}
_HOW_KEPT = {**_HOW, "tempo": ", its markers smoothed further where one take ran faster than the other (so that "
                              "both are blurred over the same span of the performance)"}


def wants_second_opinion(sides: dict, opts: SpliceOptions) -> bool:
    """Whether the pair gets a second opinion: two sides whose pass 1 weighed positions by
    noise matching's weight (``position_weight="auto"``: no hand-only file, no optical markers),
    whose hand-in-forearm motion compares (:func:`splicer.align.wrist.markers_compare`), and the
    check not switched off (``POSITION_WEIGHT_RECHECK`` 0).

    A pair whose first alignment looked no better than unrelated material (the check against the
    hands played backwards) gets one too since 0.29.1: the tempo-matched one found the
    performance where the first had lost it (*all*, tuning seeds 19 and 21: 0.654 -> 0.204 s and
    0.087 -> 0.024 s mean error); each alignment's confidence comes from its own check, so a pair
    of two performances stays low confidence throughout whichever is kept."""
    if len(sides) != 2 or opts.position_weight != "auto" or not D.POSITION_WEIGHT_RECHECK > 0:
        return False
    for r in sides.values():
        p1 = r.alignment.pass1
        if p1 is None or getattr(p1, "position_weight", None) != D.POSITION_WEIGHT_NOISY:
            return False
    return forearm_motion_compares({s: r.markers for s, r in sides.items()})


def forearm_motion_compares(markers: dict) -> bool:
    """Whether the hand's motion relative to the forearm, the signal the second opinions are judged
    by, compares in both takes on every side (dict of str -> :class:`~splicer.stages.markers.SideMarkers`:
    BVH skeletons on both sessions, no hand-only file, no optical markers, their markers placed
    alike: :func:`splicer.align.wrist.markers_compare`)."""
    from ..align.wrist import markers_compare

    for mk in markers.values():
        if mk.hand_only or mk.real or not markers_compare(mk.placed, mk.body.points, mk.hands.points):
            return False
    return True


def coverage_mismatch(pairs: list, *, uncovered: float | None = None, cap: float | None = None,
                      window_s: float | None = None) -> np.ndarray:
    """How unlike the hand moves relative to the forearm along each of several alignments of one pair,
    judged over every body frame any of them covers.

    On each side, over the body frames some alignment covers, an alignment's cost per frame is
    :func:`splicer.align.wrist.local_rate_mismatch` along its map over the ``window_s`` around the
    frame (0 alike in both takes, about 2 for unrelated motion), at most ``cap``, where it covers
    the frame, and ``uncovered`` where it does not.  A frame some alignment covers where the body's
    hand moves too little in its forearm to read the mismatch
    (:data:`~splicer.defaults.SECOND_OPINION_MIN_MOTION`) is left out for all.  So an alignment that
    leaves genuine material uncovered pays ``uncovered`` for each frame the others match well, and
    one that covers unrelated material pays more than one that leaves it uncovered.

    Parameters
    ----------
    pairs : list of dict of str -> SideResult
        The alignments (their ``hands_frame`` and ``markers``; the same sides).
    uncovered, cap, window_s : float, optional
        Default :data:`~splicer.defaults.JUDGE_UNCOVERED`, :data:`~splicer.defaults.JUDGE_MISMATCH_CAP`,
        :data:`~splicer.defaults.SECOND_OPINION_BLEND_S`.

    Returns
    -------
    np.ndarray [shape=(len(pairs),)]
        The mean cost per judged frame over all sides; NaN for all when no frame can be judged.

    Examples
    --------
    Worked on costs (the mismatch stubbed): frames 0-3; alignment A covers all four, reading 0.1,
    0.1, 3.0 (capped at 2) and 0.2; B covers frames 0-1 alone, reading 0.2 each.  A: (0.1 + 0.1 +
    2 + 0.2) / 4 = 0.6; B: (0.2 + 0.2 + 0.5 + 0.5) / 4 = 0.35 (tests/test_recheck.py).
    """
    uncovered = D.JUDGE_UNCOVERED if uncovered is None else uncovered
    cap = D.JUDGE_MISMATCH_CAP if cap is None else cap
    window_s = D.SECOND_OPINION_BLEND_S if window_s is None else window_s
    total, count = np.zeros(len(pairs)), 0
    for s in pairs[0]:
        cov = np.stack([np.isfinite(np.asarray(p[s].hands_frame, dtype=np.float64)) for p in pairs])
        loc = np.stack([_local_mismatch(p[s], cov[k], window_s) for k, p in enumerate(pairs)])
        judged = cov.any(axis=0) & ~(cov & ~np.isfinite(loc)).any(axis=0)
        total += np.where(cov, np.minimum(loc, cap), uncovered)[:, judged].sum(axis=1)
        count += int(judged.sum())
    return total / count if count else np.full(len(pairs), np.nan)


def side_mismatch(r, *, window_s: float | None = None) -> np.ndarray:
    """How unlike the hand moves relative to the forearm in both takes along one side's own time
    map, per body frame (:func:`splicer.align.wrist.local_rate_mismatch` over the ``window_s``
    around the frame, default :data:`~splicer.defaults.SECOND_OPINION_BLEND_S`: 0 alike, about 2
    unrelated); NaN where the map leaves the frame uncovered or the body's hand moves too little
    in its forearm to read it.  Meaningful only where :func:`forearm_motion_compares`."""
    window_s = D.SECOND_OPINION_BLEND_S if window_s is None else window_s
    return _local_mismatch(r, np.isfinite(np.asarray(r.hands_frame, dtype=np.float64)), window_s)


def _local_mismatch(r, covered: np.ndarray, window_s: float) -> np.ndarray:
    """:func:`_mismatch_along` one side's map over the body frames it covers, taken in order (a gap
    inside the covered frames is closed up); NaN elsewhere."""
    out = np.full(len(covered), np.nan)
    idx = np.flatnonzero(covered)
    if len(idx) >= 3:
        out[idx] = _mismatch_along(r.markers, idx, np.asarray(r.hands_frame, dtype=np.float64)[idx], window_s)
    return out


def _mismatch_along(markers, frames: np.ndarray, hands_frame: np.ndarray, window_s: float) -> np.ndarray:
    """:func:`splicer.align.wrist.local_rate_mismatch` over the body frames ``frames``, each shown by
    the hands-file frame ``hands_frame`` (the judge's and the combination's one reading)."""
    from ..align.wrist import local_rate_mismatch

    sp = markers.spaces
    return local_rate_mismatch(markers.body.points[frames], markers.hands.points, sp.hands_to_common(hands_frame),
                               fps=sp.body_fps, smooth_s=D.WRIST_SMOOTH_S, window_s=window_s,
                               min_motion=D.SECOND_OPINION_MIN_MOTION)


def map_distance_s(sides: dict, other: dict) -> float:
    """How far apart two pairs of time maps lie: the median, over both sides' body frames that
    both maps cover, of their distance in seconds of the hands take (at its normal speed: common
    frames at the body's rate); NaN where they share no frame.

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> sp = NS(body_fps=30.0, hands_to_common=lambda h: h / 4.0)  # hands at 120 fps
    >>> side = lambda h: NS(hands_frame=np.asarray(h, dtype=float), markers=NS(spaces=sp))
    >>> map_distance_s({"left": side([0, 4, 8, np.nan])}, {"left": side([120, 124, 128, 132])})
    1.0
    """
    d = []
    for s, r in sides.items():
        sp = r.markers.spaces
        a = np.asarray(r.hands_frame, dtype=np.float64)
        b = np.asarray(other[s].hands_frame, dtype=np.float64)
        ok = np.isfinite(a) & np.isfinite(b)
        d.append(np.abs(sp.hands_to_common(a[ok]) - sp.hands_to_common(b[ok])) / sp.body_fps)
    d = np.concatenate(d) if d else np.zeros(0)
    return float(np.median(d)) if len(d) else float("nan")


def tempo_markers(sides: dict) -> dict:
    """Each side's markers with the tempo-matched smoothing of :mod:`splicer.align.tempo`, read
    from ``sides``' time maps (both sides' slopes averaged: they share one hands take, so one blur
    serves both)."""
    from ..align.tempo import map_tempo, tempo_blur
    from ..transfer.timemap import mean_map

    maps = [r.markers.spaces.hands_to_common(np.asarray(r.hands_frame, dtype=np.float64)) for r in sides.values()]
    first = next(iter(sides.values())).markers
    body_blur, hands_blur = tempo_blur(map_tempo(maps, first.spaces.body_fps), mean_map(maps), first.hands.n_frames)
    out = {}
    for s, r in sides.items():
        mk = r.markers
        out[s] = replace(mk, body=replace(mk.body, blur=body_blur), hands=replace(mk.hands, blur=hands_blur))
    return out


def covered_frames(sides: dict) -> int:
    """Body frames with hands material, summed over the sides (a finite ``hands_frame``)."""
    return sum(int(np.isfinite(np.asarray(r.hands_frame, dtype=np.float64)).sum()) for r in sides.values())


def _common_frames(*pairs) -> np.ndarray | None:
    """The body frames every side of every pair of maps covers, when they are one run of at
    least 3 frames; else None."""
    both = None
    for pair in pairs:
        for r in pair.values():
            f = np.isfinite(np.asarray(r.hands_frame, dtype=np.float64))
            both = f if both is None else both & f
    frames = np.flatnonzero(both)
    if len(frames) < 3 or frames[-1] - frames[0] + 1 != len(frames):
        return None
    return frames


def position_second_opinion(sides: dict, opts: SpliceOptions, log: Log, *, realign, finish, since: int) -> dict:
    """Keep the first pair of time maps or a second opinion's, whichever the hand's motion
    relative to the forearm matches best along (:func:`coverage_mismatch`).

    The second opinions: the pair aligned with the arms' positions weighed
    :data:`~splicer.defaults.POSITION_WEIGHT_RECHECK`; and (:data:`~splicer.defaults.TEMPO_MATCHED`)
    the same with the phase metric's markers smoothed to the tempo the first maps show
    (:func:`tempo_markers`); and, where the first pair's overlap was located (open ends), the pair
    aligned at that weight with :data:`~splicer.defaults.SHORTER_OPINION_QUANTILE` as the uncovered
    penalty's quantile, a candidate only when it covers at least
    :data:`~splicer.defaults.SHORTER_OPINION_LESS_S` of body frames per side fewer, and combined
    with the others only when it is the one kept.

    Parameters
    ----------
    sides : dict of str -> SideResult
        The pair's time maps after the wrist's refinement (:func:`splicer.stages.transfer.refine_time_maps`).
    opts : SpliceOptions
    log : Log
        Its warnings from ``since`` on (the first alignment's) are replaced by the kept one's.
    realign : callable
        ``realign(opts, log, markers=None) -> dict of Alignment``: the pair aligned with ``opts``
        (:func:`splicer.stages.align.align_pair`), on ``markers`` (dict of str -> SideMarkers)
        when given.
    finish : callable
        ``finish(aligned, log) -> dict of SideResult``: the time-map stages that made ``sides``.

    Returns
    -------
    dict of str -> SideResult
        ``sides`` itself when the pair does not qualify (:func:`wants_second_opinion`) or no
        second opinion matches better (a tie keeps the first).  A second opinion that placed the
        hands' material elsewhere (:func:`map_distance_s` over
        :data:`~splicer.defaults.SECOND_OPINION_RELOCATED_S`) is kept whole (never combined) or
        left out, with a note.  Otherwise the kept pair's maps are combined frame by frame with
        the others near the first (:func:`blend_maps`; not a shorter overlap's that is not kept).
    """
    if not wants_second_opinion(sides, opts):
        return sides
    heavier = replace(opts, position_weight=D.POSITION_WEIGHT_RECHECK)
    candidates = []  # (label, maps, their own log)
    second = log.aside("positions weighed")  # each choice's own notes, kept only with its alignment
    candidates.append(("positions", finish(realign(heavier, second), second), second))
    log.tick("position second opinion")
    if D.TEMPO_MATCHED:
        third = log.aside("tempo-matched")
        candidates.append(("tempo", finish(realign(heavier, third, markers=tempo_markers(sides)), third), third))
        log.tick("tempo-matched second opinion")
    if D.SHORTER_OPINION_QUANTILE > 0 and any(r.alignment.ends == "open" for r in sides.values()):
        fourth = log.aside("shorter overlap")
        maps = finish(realign(replace(heavier, uncovered_quantile=D.SHORTER_OPINION_QUANTILE), fourth), fourth)
        fps = next(iter(sides.values())).markers.spaces.body_fps
        if covered_frames(maps) <= covered_frames(sides) - D.SHORTER_OPINION_LESS_S * fps * len(sides):
            candidates.append(("shorter", maps, fourth))
        log.tick("shorter-overlap second opinion")
    cost = coverage_mismatch([sides] + [maps for _, maps, _ in candidates])
    best = int(np.argmin(np.where(np.isfinite(cost), cost, np.inf)))  # the first on a tie, or when none is read
    apart = [map_distance_s(sides, maps) for _, maps, _ in candidates]  # NaN: not one body frame in common
    moved = [k for k, d in enumerate(apart) if not d <= D.SECOND_OPINION_RELOCATED_S]
    notes = []  # the relocated ones left out, after the kept alignment's own notes
    for k in moved:
        if k + 1 == best:
            continue
        where = (f"its time maps {apart[k]:.1f} s from the first's, the median over the body frames both cover"
                 if np.isfinite(apart[k]) else "on body frames the first's maps do not cover")
        notes.append(f"the arms' motion looked noisy, so the pair was also aligned with the arms' positions weighed "
                     f"{D.POSITION_WEIGHT_RECHECK:g}{_HOW[candidates[k][0]]}; that alignment placed the hands' material "
                     f"elsewhere ({where}) and matches less well ({_judged(cost[k + 1], cost[0])}): it is left out")
    blend = opts.merge == "timemap" and D.SECOND_OPINION_BLEND_S > 0
    kept, whole = sides, best - 1 in moved
    if best > 0:
        label, kept, lg = candidates[best - 1]
        del log.warnings[since:]
        log.warnings.extend(lg.warnings)
        log.note(f"the arms' motion looked noisy, so the pair was also aligned with the arms' positions weighed "
                 f"{D.POSITION_WEIGHT_RECHECK:g} instead of {D.POSITION_WEIGHT_NOISY:g}{_HOW_KEPT[label]}; along that "
                 f"alignment the hand moves relative to the forearm more alike in both takes "
                 f"({_judged(cost[best], cost[0])}), and it is kept" + (
                     f" whole (it placed the hands' material elsewhere: " + (
                         f"its time maps {apart[best - 1]:.1f} s from the first's)" if np.isfinite(apart[best - 1])
                         else "on body frames the first's maps do not cover)")
                     if whole else " as the frame-by-frame combination's base" if blend else ""))
    for msg in notes:
        log.note(msg)
    if whole:
        return kept
    near = [maps for k, (label, maps, _) in enumerate(candidates)
            if k not in moved and (label != "shorter" or maps is kept)]
    pairs = [kept] + [p for p in [sides] + near if p is not kept]
    frames = _common_frames(*pairs) if blend and len(pairs) > 1 else None
    if frames is None:
        return kept
    combined = {s: replace(r, hands_frame=blend_maps(pairs, s, frames)) for s, r in kept.items()}
    log.note(f"the {len(pairs)} alignments' time maps are combined frame by frame over body frames {frames[0]}-"
             f"{frames[-1]}, each weighed by how alike the hand moves relative to the forearm along it over the "
             f"{D.SECOND_OPINION_BLEND_S:g} s around the frame")
    return combined


def _judged(cost: float, first: float) -> str:
    """The judge's figures for a note (:func:`coverage_mismatch`)."""
    return (f"mismatch {cost:.3f} against {first:.3f}, frame by frame over the body frames any of the alignments "
            f"covers, a frame left uncovered counting {D.JUDGE_UNCOVERED:g}")


def blend_maps(pairs: list, side: str, frames: np.ndarray, *, window_s: float | None = None,
               tau: float | None = None) -> np.ndarray:
    """One side's time map combined frame by frame from several alignments' maps.

    Over ``frames`` (a run every alignment covers), each map's
    :func:`splicer.align.wrist.local_rate_mismatch` over ``window_s`` around each frame is read.
    First, which map to follow (:func:`_follow`, since 0.35.0): the one path through the maps,
    never stepping back to a map behind the one followed, whose summed mismatch is least, each
    frame's at most :data:`~splicer.defaults.JUDGE_UNCOVERED` (where every map reads worse than
    that, all are as bad as leaving the frame out, and which one is followed there does not decide
    the rest).  Then the maps within :data:`~splicer.defaults.SECOND_OPINION_RELOCATED_S` of the
    followed one are weighed by ``exp(-(mismatch - least) / tau)`` (a map further away is another
    reading of the take, not a correction to blend in).  Where the body's hand moves in its forearm
    under :data:`~splicer.defaults.SECOND_OPINION_MIN_MOTION` of the median window's motion (a
    rest, a hold: the mismatch is a ratio to that motion and cannot be read there), the first
    pair's map alone, or the followed one's where the first lies further away; outside
    ``frames``, the first pair's map.  A weighted mean of non-decreasing maps is non-decreasing,
    and stays within the pins' tolerance every map holds; it is made non-decreasing over the whole
    covered span again where the followed map changes and at the run's edges.

    Parameters
    ----------
    pairs : list of dict of str -> SideResult
        The alignments, the one whose other fields are kept first (its map outside ``frames``).
    side : str
    frames : np.ndarray
        Contiguous body frames every map covers (:func:`_common_frames`).
    window_s, tau : float, optional
        Default :data:`~splicer.defaults.SECOND_OPINION_BLEND_S`, :data:`~splicer.defaults.SECOND_OPINION_TAU`.

    Returns
    -------
    np.ndarray [shape=(n_body,)]
        Hands-file frames; NaN where the first pair's map is.
    """
    window_s = D.SECOND_OPINION_BLEND_S if window_s is None else window_s
    tau = D.SECOND_OPINION_TAU if tau is None else tau
    if not tau > 0:
        raise ValueError(f"tau must be positive, got {tau!r}")
    base = pairs[0][side]
    sp = base.markers.spaces
    maps = np.stack([np.asarray(p[side].hands_frame, dtype=np.float64)[frames] for p in pairs])
    mis = np.stack([_mismatch_along(base.markers, frames, h, window_s) for h in maps])
    common = sp.hands_to_common(maps)
    followed = _follow(common, mis, cap=D.JUDGE_UNCOVERED)
    cols = np.arange(len(frames))
    near = np.abs(common - common[followed, cols]) <= D.SECOND_OPINION_RELOCATED_S * sp.body_fps
    unread = ~np.isfinite(mis).all(axis=0)  # the body's hand hardly moves in the window
    mis[~near] = np.inf
    alone = np.where(near[0], 0, followed)[unread]  # there the first map alone, or the followed one when far
    mis[:, unread] = np.inf
    mis[alone, np.flatnonzero(unread)] = 0.0
    w = np.exp(-(mis - mis.min(axis=0)) / tau)
    out = np.array(base.hands_frame, dtype=np.float64)
    out[frames] = (w * maps).sum(axis=0) / w.sum(axis=0)
    ok = np.isfinite(out)
    out[ok] = np.maximum.accumulate(out[ok])
    return out


def _follow(maps: np.ndarray, cost: np.ndarray, *, cap: float) -> np.ndarray:
    """Which of several time maps to follow at each frame: the path of least summed cost, each
    frame's ``cost`` at most ``cap`` (NaN: 0 for all), that never steps to a map lying behind the
    one followed the frame before (a step back would hold the non-decreasing combination still
    until that map caught up); a tie keeps the lower index.

    Parameters
    ----------
    maps : np.ndarray [shape=(k, n)]
        The maps, non-decreasing along each row (any unit).
    cost : np.ndarray [shape=(k, n)]

    Returns
    -------
    np.ndarray [shape=(n,), dtype=int]

    Examples
    --------
    Map 1 runs ahead of map 0 and matches better from frame 2: it is followed from there (summed
    cost 0).  Had it run behind, stepping to it would be a step back: map 0 throughout (6) is
    cheaper than map 1 throughout (10).

    >>> ahead = np.array([[0., 1, 2, 3, 4], [10, 11, 12, 13, 14]])
    >>> cost = np.array([[0., 0, 2, 2, 2], [5, 5, 0, 0, 0]])
    >>> _follow(ahead, cost, cap=5.0).tolist()
    [0, 0, 1, 1, 1]
    >>> _follow(ahead - [[0.], [20.]], cost, cap=5.0).tolist()
    [0, 0, 0, 0, 0]
    """
    k, n = cost.shape
    c = np.where(np.isfinite(cost), np.minimum(cost, cap), 0.0)
    c[1:] += 1e-9 * np.arange(1, k)[:, None]  # a tie keeps the lower index
    acc = c[:, 0].copy()
    back = np.zeros((k, n), dtype=np.int64)
    stay = np.eye(k, dtype=bool)
    cols = np.arange(k)
    for t in range(1, n):
        allowed = (maps[None, :, t] >= maps[:, None, t - 1]) | stay  # [from, to]
        tot = np.where(allowed, acc[:, None], np.inf)
        back[:, t] = np.argmin(tot, axis=0)
        acc = tot[back[:, t], cols] + c[:, t]
    state = np.empty(n, dtype=np.int64)
    state[-1] = int(np.argmin(acc))
    for t in range(n - 1, 0, -1):
        state[t - 1] = back[state[t], t]
    return state
