"""The two alignment passes and their composition (ALGORITHM.md sections 4-5).

Sequences: the body markers (``n`` frames at the body rate) and the hands markers brought
to the body rate (``m`` frames).  Paths are (K, 2) arrays of (body frame, hands frame)
at that common rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .band import full_band
from .. import defaults as D
from ..defaults import DEAD_ZONE, SIGN_RAMP, SMOOTH_S
from .dtw import Band, Constraint, DTWResult, dtw, make_band
from ..errors import BandError
from ..rig.markers import Markers
from .costcache import CACHE_BYTES, CachedBandCost
from .holds import hold_band
from .costs import PalmFeatures, d1_cost, d2_cost, palm_features, phase_features
from .openend import (LOCATE_BAND_S, MAX_COARSE_CELLS, OPEN_COARSE_FPS, OPEN_HORIZONTAL_WEIGHT, UNCOVERED_QUANTILE,
                      coarse_rate, d1_sample, locate_rates, offset_band, uncovered_penalty)
from .paths import (_coarse_constraints, coarse_constraints, compose, guided_band, hold_ends, path_median,  # noqa: F401
                    remap_constraints, resample_markers, warp_markers)

__all__ = ["PassResult", "Arm", "weight_without_signs", "arm_paths", "arm_alone", "resample_markers", "pass1", "pass2", "path_median", "compose",
           "guided_band", "remap_constraints", "warp_markers", "coarse_constraints", "hold_ends"]


@dataclass(frozen=True, eq=False)
class PassResult:
    """One DTW pass.

    Attributes
    ----------
    path : np.ndarray [shape=(K, 2), dtype=int64]
        (body frame, second-sequence frame) pairs, monotone.
    cost : float
        Total local cost along the path (D1: squared sign differences; D2: radians).
    band : Band
        The admissible region, for plotting.
    name : str
    local_cost : callable or None
        ``(band, i0, i1) -> band rows of local costs``, for plots and :mod:`splicer.confidence`.
    covered : tuple of int or None
        ``(first, last)`` body frame the path covers (inclusive); the whole body with fixed
        ends.  Frames outside have no hands material (open ends).
    uncovered_cost : float
        Penalty per uncovered body frame the pass used (0 with fixed ends), local-cost units.
    ends : {"fixed", "open"}
        ``"fixed"``: the path runs from the first to the last covered row with fixed ends
        there (the whole body, or pass 2's ``covered`` span); ``"open"``: open-ended.
    step_penalty : float
        Penalty per non-diagonal step the pass used (0: the paper).
    horizontal_weight : float
        Weight of cells entered by a ``(i, j-1)`` step the pass used (1: the paper).
    located : PassResult or None
        Open ends: the coarse locating pass (its band is the whole coarse matrix, or the band
        around ``offset_s``), at ``located.fps``: ``pass_confidence(located, located.fps)``
        measures how unique the located overlap is.
    fps : float or None
        Frame rate of the pass's sequences, when recorded.
    notes : tuple of str
        Fallbacks the pass took (for the report's warnings).
    kept_cost : CachedBandCost or None
        Pass 1: ``local_cost`` with the rows the DTW computed kept as float32
        (:mod:`splicer.align.costcache`), for the readers that store float32 anyway (the
        expected path, the confidence); ``local_cost`` itself always computes afresh.
    position_weight : float
        Pass 1: the weight of the position term in its local cost (0: D1 alone, the paper).
    arms : int
        Pass 1: how many arms' local costs it averaged (1: this side's alone, the paper; 2:
        both hands of one hands take, :class:`Arm`).
    arm_costs : tuple of callable
        Pass 1 over several arms: each arm's own local cost, in their order (for
        :func:`arm_paths`); empty with one arm.
    arm_uncovered : tuple of float
        Open ends over several arms: each arm's own uncovered penalty (its own costs' quantile),
        for :func:`arm_paths`; empty otherwise.
    tempo_matched : bool
        Pass 1: its markers carried a ``blur`` (:mod:`splicer.align.tempo`), applied in its pass
        at the splice's rate.
    """

    path: np.ndarray
    cost: float
    band: Band
    name: str
    local_cost: object = None  # callable (band, i0, i1) -> band rows of local costs, for plots
    covered: tuple | None = None
    uncovered_cost: float = 0.0
    ends: str = "fixed"
    step_penalty: float = 0.0
    horizontal_weight: float = 1.0
    located: object = None
    fps: float | None = None
    notes: tuple = ()
    kept_cost: object = None
    position_weight: float = 0.0
    arms: int = 1
    arm_costs: tuple = ()
    arm_uncovered: tuple = ()
    held_rows: object = None  # np.ndarray (n,) bool or None: the full-rate DTW's held rows (body holds)
    tempo_matched: bool = False  # pass 1 read markers smoothed to the other take's tempo (Markers.blur)
    wrist_signs: bool = False  # pass 1's position term read the hand-in-forearm signs (align.costs.wrist_sign_features)
    both_skip_weight: float | None = None  # open ends: hands frames skipped beside uncovered body rows cost this times uncovered_cost (None: starts on row 0 / column 0 only)

    def skipped_both(self) -> bool:
        """Open ends: whether the path starts (or ends) past both takes' first (last) frames at once
        (the takes overlap partly; :func:`splicer.align.dtw.dtw`'s ``both_skip_cost``)."""
        if self.ends != "open" or len(self.path) == 0:
            return False
        (i0, j0), (i1, j1) = self.path[0], self.path[-1]
        return bool((i0 > 0 and j0 > 0) or (i1 < self.band.n - 1 and j1 < self.band.m - 1))

    def __repr__(self) -> str:
        return f"PassResult(name={self.name!r}, path={len(self.path)} cells, cost={self.cost:.6g}, band={self.band!r})"


@dataclass(frozen=True, eq=False)
class Arm:
    """Another arm for pass 1 to weigh: its markers in both takes and its phase-metric settings.

    Both hands of one hands take were captured on one clock, and so were both arms of the
    body take: one time map serves both sides.  Given an :class:`Arm` in ``others``,
    :func:`pass1` averages this arm's local cost with the first arm's, so a stretch where one
    arm's motion says little (a hold, a gesture performed differently) is carried by the other.

    Attributes
    ----------
    body, hands : Markers
        This arm's markers, with the first arm's frame counts and rate.
    smooth_s : float
        Its phase metric's marker smoothing (noise matching decides it per side).
    position_weight : float
        Its position term's weight (0 where positions do not compare: a hand-only file, optical markers).
    wrist_signs : bool
        Its position term reads the hand-in-forearm signs too
        (:func:`splicer.align.costs.wrist_sign_features`), at the body's rate only: an arm
        resampled for a coarser level drops them.
    coordinates : bool
        Its position term reads the positions' coordinates (False: the signs alone, for markers
        without a root heading: optical ones).  An arm without coordinates whose signs are
        dropped (at a coarser rate) has no position term there.
    """

    body: Markers
    hands: Markers
    smooth_s: float = SMOOTH_S
    position_weight: float = 0.0
    wrist_signs: bool = False
    coordinates: bool = True

    def coarser(self, fps: float) -> "Arm":
        """This arm at a coarser rate ``fps``, without the hand-in-forearm signs (the turns of a hand
        in its forearm blur into each other at 1-10 fps; at the locating rates the signs moved one
        tuning run's overlap by 3 s: benchmarks/HISTORY.md, 0.29.0), so without a position term
        when it read the signs alone."""
        return Arm(resample_markers(self.body, fps), resample_markers(self.hands, fps), self.smooth_s,
                   weight_without_signs(self.position_weight, self.coordinates))


def weight_without_signs(position_weight: float, coordinates: bool) -> float:
    """A position term's weight where the hand-in-forearm signs are dropped (the coarser rates, the
    check against the hands played backwards): the coordinates' weight, none for a term that held
    the signs alone (``coordinates=False``: optical markers).

    Examples
    --------
    >>> weight_without_signs(10.0, True), weight_without_signs(1.25, False)
    (10.0, 0.0)
    """
    return float(position_weight) if coordinates else 0.0


def _arms(body, hands, smooth_s, position_weight, others, wrist_signs=False, coordinates=True) -> list:
    """Every arm of a pass 1, the first one given as ``pass1``'s own arguments; checked to share frames."""
    arms = [Arm(body, hands, smooth_s, position_weight, wrist_signs, coordinates)] + list(others)
    for a in arms[1:]:
        if not isinstance(a, Arm):
            raise TypeError(f"others must hold Arm objects, got {type(a).__name__}")
        if (a.body.n_frames, a.hands.n_frames) != (body.n_frames, hands.n_frames) or a.body.fps != body.fps \
                or a.hands.fps != hands.fps:
            raise ValueError(f"an arm of pass 1 has {a.body.n_frames} x {a.hands.n_frames} frames at "
                             f"{a.body.fps:g} / {a.hands.fps:g} fps; the first has {body.n_frames} x {hands.n_frames} "
                             f"at {body.fps:g} / {hands.fps:g}: arms sharing a time map share their takes' frames")
    return arms


def _wrist_signs(arms: list) -> bool:
    """Whether any arm's position term read the hand-in-forearm signs."""
    return any(a.wrist_signs and a.position_weight > 0 and D.WRIST_SIGN_SCALE > 0 for a in arms)


def _blurred(arms: list) -> bool:
    """Whether any arm's markers carry the tempo-matched smoothing (:attr:`Markers.blur`)."""
    return any(x.blur is not None for a in arms for x in (a.body, a.hands))


def _resampled(arms: list, fps: float) -> list:
    """The arms at a coarser rate (:meth:`Arm.coarser`)."""
    return [a.coarser(fps) for a in arms]


def _arm_features(arms: list, dead_zone: float, sign_ramp: float) -> list:
    """Each arm's (body, hands) phase features."""
    return [tuple(phase_features(x, smooth_s=a.smooth_s, dead_zone=dead_zone, sign_ramp=sign_ramp,
                                 position=a.position_weight > 0, wrist_signs=a.wrist_signs,
                                 coordinates=a.coordinates)
                  for x in (a.body, a.hands)) for a in arms]


def _arms_cost(arms: list, features: list, theta: str):
    """Pass 1's local cost: one arm's D1 (+ position term), or the mean over the arms; and each arm's
    own (an empty tuple with one arm)."""
    costs = [d1_cost(fb, fh, theta=theta, position_weight=a.position_weight) for a, (fb, fh) in zip(arms, features)]
    if len(costs) == 1:
        return costs[0], ()

    def mean(band, i0, i1):
        out = costs[0](band, i0, i1)
        for c in costs[1:]:
            out = out + c(band, i0, i1)
        return out / len(costs)

    return mean, tuple(costs)


def arm_alone(p: PassResult, k: int) -> np.ndarray:
    """Arm ``k``'s own open-ended alignment, as if pass 1 had been run for it alone: its own
    path over the locating pass's coarse matrix with its own uncovered penalty, then its own
    full-rate path in a band of ``p``'s width around that (:func:`guided_band`).

    Parameters
    ----------
    p : PassResult
        An open-ended pass 1 over several arms, with its locating pass (``p.located``).
    k : int
        The arm, in ``p``'s order.

    Returns
    -------
    np.ndarray [shape=(K, 2), dtype=int64]
        The full-rate path.
    """
    loc = p.located
    if p.ends != "open" or loc is None or not loc.arm_costs or not 0 <= k < len(p.arm_costs):
        raise ValueError("arm_alone needs an open-ended pass 1 over several arms with its locating pass")
    u = p.arm_uncovered[k] if k < len(p.arm_uncovered) else p.uncovered_cost
    coarse = _arm_path(loc, k, own_penalty=True)
    factor = p.fps / loc.fps
    band = p.band
    if factor > 1.0 + 1e-9:
        try:
            band = guided_band(coarse, factor, band.n, band.m, band.width, band.constraints, open_begin=True,
                               open_end=True)
        except BandError:
            band = p.band
    band, held = hold_band(band, p.held_rows)
    return _run(p.arm_costs[k], band, None, open_begin=True, open_end=True, uncovered_cost=u,
                step_penalty=p.step_penalty, horizontal_weight=p.horizontal_weight, held_rows=held,
                both_skip_cost=_both_skip_cost(p.both_skip_weight, u)).path


def arm_paths(p: PassResult, progress=None, *, own_penalty: bool = False) -> list:
    """Each arm's own best path inside a pass 1 over several arms: the pass's band, end
    conditions and penalties, with that arm's local cost alone (a cross-check: where the arms'
    own paths part, the motion of at least one says little; :mod:`splicer.stages.crosscheck`).

    Open-ended, the pass's uncovered penalty applies, or with ``own_penalty`` each arm's own
    (``p.arm_uncovered``: as if the arm were aligned alone).  Works on the locating pass too
    (``p.located``: the whole coarse matrix).

    Returns
    -------
    list of np.ndarray [shape=(K, 2), dtype=int64]
        Per arm (in ``p``'s order), its path of (body frame, hands frame) cells, like
        ``p.path``.  Empty for one arm.
    """
    n = len(p.arm_costs)
    return [_arm_path(p, k, own_penalty=own_penalty,
                      progress=(lambda f, k=k: progress((k + f) / n)) if progress is not None else None)
            for k in range(n)]


def _arm_path(p: PassResult, k: int, *, own_penalty: bool, progress=None) -> np.ndarray:
    """Arm ``k``'s own best path in ``p``'s band (:func:`arm_paths`, one arm)."""
    ends = {}
    if p.ends == "open":  # the pass's uncovered penalty, or the arm's own, as if it were aligned alone
        u = p.arm_uncovered[k] if own_penalty and k < len(p.arm_uncovered) else p.uncovered_cost
        ends = dict(open_begin=True, open_end=True, uncovered_cost=u,
                    both_skip_cost=_both_skip_cost(p.both_skip_weight, u))
    return _run(p.arm_costs[k], p.band, progress, step_penalty=p.step_penalty, horizontal_weight=p.horizontal_weight,
                held_rows=p.held_rows, **ends).path


def _arm_samples(arms: list, features: list, theta: str) -> list:
    """Each arm's local cost on :func:`d1_sample`'s pairs (the same pairs for every arm: same frames, same seed)."""
    return [d1_sample(fb, fh, theta=theta, position_weight=a.position_weight) for a, (fb, fh) in zip(arms, features)]


def _uncovered_penalties(arms: list, features: list, theta: str, quantile: float, *, each: bool) -> tuple:
    """The open ends' uncovered penalty from these arms' local costs (:func:`uncovered_penalty` of
    the mean of :func:`_arm_samples`, summed and divided as :func:`_arms_cost` does), and with
    ``each`` and several arms each arm's own (``()`` otherwise), from the same samples."""
    samples = _arm_samples(arms, features, theta)
    u = uncovered_penalty(sum(samples) / len(samples), quantile)
    if not each or len(arms) < 2:
        return u, ()
    return u, tuple(uncovered_penalty(s, quantile) for s in samples)


def _both_skip_cost(weight: float | None, u: float) -> float | None:
    """:func:`splicer.align.dtw.dtw`'s ``both_skip_cost`` of an open-ended pass: ``weight`` times the
    uncovered penalty ``u`` (None: starts on row 0 or column 0 only)."""
    return None if weight is None else float(weight) * float(u)


def _run(cost, band: Band, progress=None, **ends) -> DTWResult:
    """The DTW over ``band`` with a band-chunk cost; ``progress(fraction)`` after each chunk of rows.
    ``ends``: :func:`splicer.dtw.dtw`'s ``open_begin``, ``open_end``, ``uncovered_cost``, penalties
    and ``both_skip_cost``."""
    if progress is None:
        return dtw(lambda i0, i1: cost(band, i0, i1), band, **ends)

    def chunk(i0, i1):
        out = cost(band, i0, i1)
        progress(i1 / band.n)
        return out

    return dtw(chunk, band, **ends)


def pass1(body: Markers, hands: Markers, *, width: float, constraints=(), smooth_s: float = SMOOTH_S,
          dead_zone: float = DEAD_ZONE, sign_ramp: float = SIGN_RAMP, theta: str = "window", coarse_fps: float | None = None,
          coarse_width: float | None = None, progress=None, ends: str = "fixed", offset_s: float | None = None,
          uncovered_quantile: float = UNCOVERED_QUANTILE, uncovered_cost: float | None = None,
          max_coarse_cells: int = MAX_COARSE_CELLS, step_penalty: float = 0.0,
          horizontal_weight: float | None = None, guide: np.ndarray | None = None,
          cache_bytes: int = CACHE_BYTES, position_weight: float = 0.0, others=(),
          held_rows=None, wrist_signs: bool = False, coordinates: bool = True,
          both_skip_weight: float | None = D.BOTH_SKIP_WEIGHT) -> PassResult:
    """Pass 1: banded DTW with the phase metric D1.

    Parameters
    ----------
    body, hands : Markers
        One side's markers, at the same frame rate (see :func:`resample_markers`).
    width : float
        Band width W in body frames.
    constraints : sequence of Constraint
        In the frames of these two sequences.
    smooth_s, dead_zone, sign_ramp, theta
        See :func:`splicer.metrics.phase_features` and :func:`splicer.metrics.d1_cost`.
    progress : callable, optional
        ``progress(fraction)`` as the rows are done (open-ended: the locating pass the first
        half, the full-rate pass the second).
    coarse_fps : float, optional
        Beyond the paper, for long takes: first align both sequences brought down to this
        rate, in a band of ``coarse_width`` body frames (at the full rate) around the
        diagonal, then run the full-rate pass in a band of ``width`` around that coarse path
        (:func:`guided_band`).  A performance that drifts far from uniform timing over many
        minutes stays inside the band.  None: the band follows the diagonal (the paper).
        With ``ends="open"``: the rate of the locating pass (default
        :data:`splicer.openend.OPEN_COARSE_FPS`, 10 fps, lowered for long takes to fit
        ``max_coarse_cells``).
    ends : {"fixed", "open"}
        ``"fixed"`` (the paper): the path runs from ``(0, 0)`` to ``(n - 1, m - 1)``.
        ``"open"`` (ALGORITHM.md section 9): the body's span may lie anywhere in the hands
        take and either may cover only part of the other.  A coarse pass at ``coarse_fps``
        (lowered so that the coarse matrix has at most ``max_coarse_cells`` cells), open at
        both ends over the whole hands take (or, with ``offset_s``, over a band of
        ``coarse_width`` body frames around that offset), locates the overlap; the full-rate
        pass runs open-ended in a band of ``width`` around the located coarse path.  Body
        frames outside ``result.covered`` have no hands material.
    offset_s : float, optional
        Open ends only: a starting guess (e.g. from timecode): body frame 0 shows the same
        instant as hands time ``offset_s`` seconds (may be negative: the hands take starts
        later).  The coarse pass then searches a band of ``coarse_width`` body frames
        (default 30 s) around ``j = i + offset`` instead of the whole take.
    uncovered_quantile : float
        Open ends: the per-frame penalty for uncovered body frames is this quantile of D1
        over a sample of all frame pairs (:func:`splicer.openend.uncovered_penalty`).
    uncovered_cost : float, optional
        Open ends: the penalty itself (D1 units per body frame), overriding the quantile.
    max_coarse_cells : int
        Open ends: cap on the coarse matrix (1 byte of DTW steps per cell).
    step_penalty : float
        Beyond the paper: D1 units added to every non-diagonal step, in every DTW of the pass
        (:func:`splicer.dtw.dtw`); 0 is the paper's recurrence.
    guide : np.ndarray [shape=(K, 2)], optional
        Fixed ends: a path at the full rate from an earlier pass (e.g. an open-ended pass 1
        that found both corners, or the other hand's pass 1): the band of ``width`` follows
        it instead of the diagonal (:func:`guided_band`), and no coarse pass is run.  A
        time map far from uniform timing (local speed 0.33x-3x) leaves a diagonal band.
    horizontal_weight : float, optional
        Weight of the local cost of a cell entered by a ``(i, j-1)`` step (one more hands
        frame on the same body frame), in ``(0, 1]``.  Default: 1 (the paper) with fixed
        ends, :data:`OPEN_HORIZONTAL_WEIGHT` with open ends, where a full weight makes a path
        that skips hands material cheaper than one that covers it.
    both_skip_weight : float or None
        Open ends: the path may also start (end) past both takes' first (last) frames at once,
        each hands frame skipped beside an uncovered body row costing this times the uncovered
        penalty (:func:`splicer.align.dtw.dtw`'s ``both_skip_cost``; default
        :data:`splicer.defaults.BOTH_SKIP_WEIGHT`); None: on row 0 or column 0 only (0.32.0).
    cache_bytes : int
        The full-rate pass keeps up to this many bytes of its local costs (float32, 4 bytes a
        band cell; :class:`splicer.align.costcache.CachedBandCost`) so that the expected path
        and the confidence read them instead of computing them again; 0 keeps none.
    position_weight : float
        Beyond the paper: D1 units per unit of the position term added to D1 in every DTW of
        the pass (:func:`splicer.align.costs.d1_cost`); 0 is D1 alone (the paper).
    others : sequence of Arm
        Beyond the paper: more arms sharing this time map (the other hand of the same hands
        take).  The local cost is then the mean of every arm's (``body``/``hands`` with
        ``smooth_s`` and ``position_weight`` being the first), in every DTW of the pass and in
        the uncovered penalty.  Empty (the default): this arm alone.
    held_rows : np.ndarray [shape=(n,), dtype=bool], optional
        Beyond the paper: body frames where the body holds still
        (:func:`splicer.align.holds.held_rows`); the full-rate DTW crosses them on one hands
        frame at no cost (:func:`splicer.align.dtw.dtw`).  None: none, the paper.
    wrist_signs : bool
        Beyond the paper: with ``position_weight > 0``, the position term reads the hand's
        turning in the forearm's frame too (:func:`splicer.align.costs.wrist_sign_features`),
        in the DTW at the body's rate (not at a coarser rate).  ``others`` say it per arm.
    coordinates : bool
        Beyond the paper: False leaves the positions' coordinates out of the position term, the
        hand-in-forearm signs alone (``wrist_signs`` needed; optical markers have no root heading
        to turn coordinates by); then no position term at the coarser rates.  ``others`` say it
        per arm.

    Returns
    -------
    PassResult
        With ``covered``, the first and last body frame the path covers (the whole body with
        fixed ends), ``uncovered_cost`` and ``arms``.

    Raises
    ------
    ValueError
        ``ends`` unknown, or an arm in ``others`` whose takes have other frame counts or rates.
    """
    if ends not in ("fixed", "open"):
        raise ValueError(f"ends must be 'fixed' or 'open', got {ends!r}")
    if not coordinates and not (wrist_signs and D.WRIST_SIGN_SCALE > 0) and position_weight > 0:
        raise ValueError("a position term without coordinates needs the hand-in-forearm signs (wrist_signs)")
    arms = _arms(body, hands, smooth_s, position_weight, others, wrist_signs, coordinates)
    if ends == "open":
        return _pass1_open(arms, width=width, constraints=constraints,
                           dead_zone=dead_zone, sign_ramp=sign_ramp, theta=theta,
                           coarse_fps=OPEN_COARSE_FPS if coarse_fps is None else coarse_fps,
                           coarse_width=coarse_width, progress=progress, offset_s=offset_s,
                           uncovered_quantile=uncovered_quantile, uncovered_cost=uncovered_cost,
                           max_coarse_cells=max_coarse_cells, step_penalty=step_penalty, cache_bytes=cache_bytes,
                           horizontal_weight=OPEN_HORIZONTAL_WEIGHT if horizontal_weight is None else horizontal_weight,
                           held_rows=held_rows, both_skip_weight=both_skip_weight)
    hw = 1.0 if horizontal_weight is None else float(horizontal_weight)
    n, m = body.n_frames, hands.n_frames
    notes: tuple = ()
    if guide is not None:
        try:
            band = guided_band(np.asarray(guide, dtype=np.int64), 1.0, n, m, width, constraints)
        except BandError:
            band = make_band(n, m, width, constraints)  # the guide missed a pin's window: the paper's band
    elif coarse_fps is not None and coarse_fps < body.fps:
        factor = body.fps / coarse_fps
        carms = _resampled(arms, coarse_fps)
        cb, ch = carms[0].body, carms[0].hands
        ccons = _coarse_constraints(constraints, factor, cb.n_frames, ch.n_frames)
        cw = (coarse_width if coarse_width is not None else width) / factor
        coarse = pass1(cb, ch, width=cw, constraints=ccons, smooth_s=smooth_s, dead_zone=dead_zone,
                       sign_ramp=sign_ramp, theta=theta, step_penalty=step_penalty, horizontal_weight=hw,
                       cache_bytes=0, position_weight=position_weight, others=carms[1:])
        try:
            band = guided_band(coarse.path, factor, n, m, width, constraints)
        except BandError:
            band = make_band(n, m, width, constraints)  # the coarse path missed a window: the paper's band
            notes = (f"the coarse guide pass ({coarse_fps:g} fps) missed a pin's window; pass 1 used the plain "
                     f"band of {width:g} frames instead (a long take may drift out of it: check the pins)",)
    else:
        band = make_band(n, m, width, constraints)
    band, held_rows = hold_band(band, held_rows)
    d1, each = _arms_cost(arms, _arm_features(arms, dead_zone, sign_ramp), theta)
    kept = CachedBandCost(d1, band, budget_bytes=cache_bytes)
    res = _run(kept, band, progress, step_penalty=step_penalty, horizontal_weight=hw, held_rows=held_rows)
    return PassResult(res.path, res.cost, band, "pass1", d1, res.covered, 0.0, "fixed", step_penalty, hw,
                      notes=notes, kept_cost=kept, position_weight=float(position_weight), arms=len(arms),
                      arm_costs=each, held_rows=held_rows, tempo_matched=_blurred(arms),
                      wrist_signs=_wrist_signs(arms))


def _pass1_open(arms, *, width, constraints, dead_zone, sign_ramp, theta, coarse_fps, coarse_width, progress,
                offset_s, uncovered_quantile, uncovered_cost, max_coarse_cells, step_penalty, horizontal_weight,
                cache_bytes, held_rows=None, both_skip_weight=None):
    body, hands, position_weight = arms[0].body, arms[0].hands, arms[0].position_weight
    n, m = body.n_frames, hands.n_frames
    # long takes: the whole matrix at a low rate, then each finer rate around the coarser path
    single = [coarse_rate(n, m, body.fps, coarse_fps, max_coarse_cells)]
    rates = single if offset_s is not None else locate_rates(n, m, body.fps, coarse_fps, max_coarse_cells)
    notes: tuple = ()
    coarser, level = None, 0  # the pass of the level before
    while level < len(rates):
        cfps = rates[level]
        factor = body.fps / cfps
        if factor > 1.0 + 1e-9:
            carms = _resampled(arms, cfps)
        else:
            factor, carms = 1.0, arms
        nc, mc = carms[0].body.n_frames, carms[0].hands.n_frames
        ccons = _coarse_constraints(constraints, factor, nc, mc) if factor > 1.0 else list(constraints)
        cfeat = _arm_features(carms, dead_zone, sign_ramp)
        d1c, ceach = _arms_cost(carms, cfeat, theta)
        u = uncovered_cost
        arm_u: tuple = ()
        if u is None:  # the last level's also each arm's own, for its own path (arm_paths)
            u, arm_u = _uncovered_penalties(carms, cfeat, theta, uncovered_quantile, each=level == len(rates) - 1)
        if offset_s is not None:
            cw = (coarse_width if coarse_width is not None else 30.0 * body.fps) / factor
            cband = offset_band(nc, mc, offset_s * cfps, cw, ccons)
        elif coarser is None:
            cband = full_band(nc, mc, ccons)
        else:
            try:
                cband = guided_band(coarser.path, cfps / rates[level - 1], nc, mc, LOCATE_BAND_S * cfps, ccons,
                                    open_begin=True, open_end=True)
            except BandError:  # the coarser path missed a pin's window: one level, the whole matrix, as before
                rates, coarser, level = single, None, 0
                continue
        # the bar: the locating pass its first half (its levels in equal shares), the full-rate pass the
        # second (the hour-long pair's locating pass took 11 s, all of it at 0 % before)
        first = None if progress is None else (lambda f, k=level: progress(0.5 * (k + f) / len(rates)))
        coarser = coarse = _run(d1c, cband, first, open_begin=True, open_end=True, uncovered_cost=u,
                                step_penalty=step_penalty, horizontal_weight=horizontal_weight,
                                both_skip_cost=_both_skip_cost(both_skip_weight, u))
        level += 1
    located = PassResult(coarse.path, coarse.cost, cband, "pass1 (locating)", d1c, coarse.covered, float(u), "open",
                         step_penalty, float(horizontal_weight), None, cfps, position_weight=float(position_weight),
                         arms=len(arms), arm_costs=ceach, arm_uncovered=arm_u, both_skip_weight=both_skip_weight)
    if factor > 1.0:
        try:
            band = guided_band(coarse.path, factor, n, m, width, constraints, open_begin=True, open_end=True)
        except BandError:  # the coarse path missed a constraint window: search the whole take at full rate
            if n * m > 4 * max_coarse_cells:
                raise BandError(f"the located overlap misses a constraint window and the full {n} x {m} frame "
                                f"matrix is too large to search; widen the band (now {width:g} frames) or check "
                                f"the constraints") from None
            band = full_band(n, m, constraints)
            notes = (f"the located overlap missed a pin's window; pass 1 searched the whole {n} x {m} frame "
                     "matrix at full rate instead",)
    else:
        band = cband
    band, held_rows = hold_band(band, held_rows)
    if carms is arms:
        d1, each = d1c, ceach
    else:
        feats = _arm_features(arms, dead_zone, sign_ramp)
        d1, each = _arms_cost(arms, feats, theta)
        if uncovered_cost is None and _wrist_signs(arms):
            # the hand-in-forearm signs enter the costs at this rate only: the penalty from these costs
            # (from the locating level's, the start of tuning seed 4's ZEGGS speed + imitation pair was
            # 0.13 s off; 0.03 s so; benchmarks/HISTORY.md, 0.29.0)
            u, arm_u = _uncovered_penalties(arms, feats, theta, uncovered_quantile, each=bool(arm_u))
    kept = CachedBandCost(d1, band, budget_bytes=cache_bytes)
    second = None if progress is None else (lambda f: progress(0.5 + 0.5 * f))
    res = _run(kept, band, second, open_begin=True, open_end=True, uncovered_cost=u, step_penalty=step_penalty,
               horizontal_weight=horizontal_weight, held_rows=held_rows,
               both_skip_cost=_both_skip_cost(both_skip_weight, u))
    return PassResult(res.path, res.cost, band, "pass1", d1, res.covered, float(u), "open", step_penalty,
                      float(horizontal_weight), located, body.fps, notes, kept, float(position_weight), len(arms),
                      each, arm_u, held_rows, tempo_matched=_blurred(arms), wrist_signs=_wrist_signs(arms),
                      both_skip_weight=both_skip_weight)


def _pass2_cost(d2, d1, n_band_scale: float, weight: float, d1_weight: float):
    """D2 + ``d1_weight`` * D1 / 24 + ``weight`` radians per band width of departure from the diagonal.

    D1 / 24 is 1 when half of the 24 sign components disagree (D1 ranges 0..96)."""

    def cost(band, i0, i1):
        out = d2(band, i0, i1)
        if d1 is not None and d1_weight > 0:
            out = out + (d1_weight / 24.0) * d1(band, i0, i1)
        if weight > 0:
            rows = np.arange(i0, i1)
            cols = band.lo[i0:i1, None] + np.arange(out.shape[1])[None, :]
            centre = rows * ((band.m - 1) / max(band.n - 1, 1))
            out = out + weight * np.abs(cols - centre[:, None]) / n_band_scale
        return out

    return cost


def pass2(body: Markers, hands_warped: Markers, *, width: float, constraints=(),
          diagonal_weight: float = 0.0, d1_weight: float = 0.0, smooth_s: float = SMOOTH_S,
          dead_zone: float = DEAD_ZONE, sign_ramp: float = SIGN_RAMP, theta: str = "window", progress=None,
          covered=None) -> PassResult:
    """Pass 2: banded DTW with the palm metric D2 between the body and the pass-1-warped hands.

    Parameters
    ----------
    body : Markers
    hands_warped : Markers
        Hands markers sampled at the pass-1 time map, one per body frame (or, for pass 2
        alone, the hands at the body rate).
    width : float
        Band width W in body frames (the paper: 10% of the body length).
    constraints : sequence of Constraint
        In (body frame, warped frame) coordinates.
    diagonal_weight : float
        0 is the paper's literal pass 2.  A positive weight adds that many radians per
        band width of departure from the diagonal (the pass-1 warp): D2 alone is small next
        to capture noise between neighbouring frames and the path wanders.
    d1_weight : float
        Weight of the phase metric D1 (normalised by 24) added to D2, so D2 refines within
        phases instead of overriding them; 0 is the paper's pass 2.
    smooth_s, dead_zone, sign_ramp, theta
        D1's settings, as in :func:`pass1`.
    progress : callable, optional
        ``progress(fraction)`` as the rows are done.
    covered : (int, int), optional
        After an open-ended pass 1: the first and last body frame it covers.  Pass 2 then
        aligns only those frames (fixed ends on that span; ``hands_warped`` must still have
        one frame per body frame, any values outside the span, e.g. :func:`hold_ends`); the
        result's band spans every body row (rows outside the span get the span's first or
        last interval, ``open_begin``/``open_end`` set, for plots) and its path runs from
        ``(first, first)`` to ``(last, last)``-ish.  Constraints outside the span are dropped.
    """
    fb: PalmFeatures = palm_features(body.points)
    fh: PalmFeatures = palm_features(hands_warped.points)
    d1 = None
    if d1_weight > 0:
        d1 = d1_cost(phase_features(body, smooth_s=smooth_s, dead_zone=dead_zone, sign_ramp=sign_ramp),
                     phase_features(hands_warped, smooth_s=smooth_s, dead_zone=dead_zone, sign_ramp=sign_ramp), theta=theta)
    n = body.n_frames
    cost = _pass2_cost(d2_cost(fb, fh), d1, max(width, 1.0), diagonal_weight, d1_weight)
    if covered is not None and tuple(covered) != (0, n - 1):
        return _pass2_span(cost, n, hands_warped.n_frames, width, constraints, covered, progress)
    band = make_band(body.n_frames, hands_warped.n_frames, width, constraints)
    res = _run(cost, band, progress)
    return PassResult(res.path, res.cost, band, "pass2", cost, res.covered, 0.0)


def _pass2_span(cost, n, m, width, constraints, covered, progress) -> PassResult:
    """Pass 2 over body frames ``a..b`` only (fixed ends there), reported on the full body rows."""
    a, b = int(covered[0]), int(covered[1])
    if m != n:
        raise ValueError(f"pass 2 over a covered span needs the warped hands at the body frames ({n}), got {m}")
    if not 0 <= a <= b <= n - 1:
        raise ValueError(f"covered span {covered} is outside the body frames 0..{n - 1}")
    k = b - a + 1
    sub_cons = [Constraint(c.x - a, c.y - a, c.tolerance) for c in constraints
                if 0 < c.x - a < k - 1 and 0 < c.y - a < k - 1]
    sub = make_band(k, k, width, sub_cons)
    lo = np.concatenate([np.full(a, sub.lo[0] + a), sub.lo + a, np.full(n - 1 - b, sub.lo[-1] + a)])
    hi = np.concatenate([np.full(a, sub.hi[0] + a), sub.hi + a, np.full(n - 1 - b, sub.hi[-1] + a)])
    full = Band(n=n, m=m, width=width, lo=lo, hi=hi,
                constraints=tuple(Constraint(c.x + a, c.y + a, c.tolerance) for c in sub_cons),
                open_begin=True, open_end=True)

    def chunk(i0, i1):
        out = cost(full, i0 + a, i1 + a)       # rows a.. of the full band = the span's band, shifted
        if progress is not None:
            progress(i1 / k)
        return out

    res = dtw(chunk, sub)
    return PassResult(res.path + a, res.cost, full, "pass2", cost, (a, b), 0.0, "fixed")


