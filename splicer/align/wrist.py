"""The last refinement of a time map: the hand's motion relative to the forearm (0.17.0).

Pass 1 aligns the arm's phases (D1) and pass 2 the palm's angle to the forearm (D2); the time
map that comes out of them, smoothed and weighed by its uncertainty, still wanders by a frame or
two for a second at a time where the arm's signs say little (a second performance, a noisy
solve).  The hand's direction *in the forearm's own frame* is a signal of its own: it does not
move when the shoulder or elbow of the other performance swing a little wider or jitter, and
its rate of change, taken as a function of time, is the same in both takes once the hands'
tempo is allowed for.  This module finds, within :data:`splicer.defaults.WRIST_RADIUS_S` of the
map, the smooth offset that best matches that rate of change, and moves the map by it.

For each body frame ``t`` and each offset ``d`` (a grid of :data:`STEP_FRAMES` common frames
within the radius)::

    E[t, d] = || v_body(t) - s(t) * v_hands(c(t) + d) ||^2 / median(E)

where ``v`` is the frame-to-frame change of the hand's unit direction in the forearm frame
(smoothed over :data:`splicer.defaults.WRIST_SMOOTH_S` first), ``c`` the map in common frames and
``s`` its local slope (the hands' tempo: a hand moving twice as fast in the hands take changes
twice as much per hands frame).  Offset paths cost ``sum E[t, d_t] + lam * sum (d_t - d_{t-1})^2``
(starting from offset 0, steps of at most :data:`MAX_STEP` grid points per frame) and are weighed
``exp(-cost)``; the expected offset per frame (forward-backward, :func:`expected_offsets`: a
smooth function of the input, where the best path alone jumped between near-equal paths when
the input changed in its last digits) is smoothed over
:data:`splicer.defaults.WRIST_OFFSET_SMOOTH_S` and added.

Measured on the ground-truth protocol (benchmarks/HISTORY.md, 0.17.0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..model.rotations import cross3
from ..transfer.sampling import sample_linear
from .risk import running_sum

__all__ = ["STEP_FRAMES", "MAX_STEP", "LAMBDA", "ANATOMICAL", "STYLOID", "STILL_WRIST", "comparable_placements", "markers_compare", "wrist_moves", "hand_in_forearm", "turn_onto", "offset_costs", "offset_posterior", "expected_offsets",
           "WristFit", "WristEvidence", "refine_map", "rate_mismatch", "local_rate_mismatch", "noise_share"]

#: Offsets are searched on a grid of this many common (body) frames.
STEP_FRAMES = 0.25
#: The offset moves at most this many grid points from one body frame to the next (a tempo
#: departure of up to ``MAX_STEP * STEP_FRAMES`` = 0.5 hands frames per body frame).
MAX_STEP = 2
#: Cost of a change of offset, per squared common frame, against the normalised match cost.
LAMBDA = 10.0
#: Above this many cells the costs' median is taken over evenly spaced rows (memory).
_MEDIAN_CELLS = 1 << 21


def hand_in_forearm(points: np.ndarray) -> np.ndarray:
    """The hand's unit direction in the forearm's frame, per frame.

    The frame: ``x`` from the wrist's centre ``c = (p1 + p2) / 2`` to the forearm marker ``p3``;
    ``y`` the wrist's width ``p1 - p2`` made orthogonal to ``x``; ``z = x × y``.  The hand's
    direction is ``p4 - c``, normalised.

    Parameters
    ----------
    points : np.ndarray [shape=(T, 4, 3)]
        Markers ``p1, p2, p3, p4`` (any world frame and unit).

    Returns
    -------
    np.ndarray [shape=(T, 3), dtype=float64]
        Components of the hand's direction along ``x, y, z``: each in [-1, 1], unitless; zeros
        where a direction is undefined (coincident markers).
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 3 or p.shape[1:] != (4, 3):
        raise ValueError(f"points must have shape (T, 4, 3), got {p.shape}")

    def unit(v):
        n = np.linalg.norm(v, axis=-1, keepdims=True)
        return np.where(n > 1e-12, v / np.maximum(n, 1e-12), 0.0)

    c = 0.5 * (p[:, 0] + p[:, 1])
    x = unit(p[:, 2] - c)
    y = p[:, 0] - p[:, 1]
    y = unit(y - (y * x).sum(-1, keepdims=True) * x)
    z = cross3(x, y)
    h = unit(p[:, 3] - c)
    return np.stack([(h * x).sum(-1), (h * y).sum(-1), (h * z).sum(-1)], axis=-1)


#: The anatomical placement of :func:`splicer.rig.markers.marker_placement`: wrist markers across
#: the index and pinky bases, the forearm's from the elbow, the hand's at the middle finger's base;
#: the roles optical markers have (styloids, forearm, hand: :mod:`splicer.rig.marker_roles`).
ANATOMICAL = "p1-p2 index-pinky, p3 elbow, p4 middle"
#: The same with the wrist markers on the styloids (``arm_markers(..., wrist="styloid")``), as the
#: virtual markers of a take aligned against optical ones are made.
STYLOID = "p1-p2 index-pinky styloid, p3 elbow, p4 middle"
_P3_ELBOW, _P3_FOREARM_JOINT, _P3_HAND = ", p3 elbow,", ", p3 forearm joint,", ", p3 hand,"


def comparable_placements(body: str, hands: str) -> bool:
    """Whether the hand's direction in the forearm's frame compares between two takes' markers.

    Placed the same way (:func:`splicer.rig.markers.marker_placement`), or optical markers on one
    take and the anatomical placement (:data:`ANATOMICAL`, :data:`STYLOID`) on the other, or a body's real
    forearm (``p3 elbow``) against a hand file's virtual one turned with its forearm joint
    (``p3 forearm joint``, Leap: it points along the real forearm,
    :func:`splicer.rig.handonly.hand_only_view`), the rest alike: a fixed difference of where
    the markers sit is taken out by :func:`turn_onto`.  Never where ``p3`` turns with the hand
    (a wrist-rooted hand file and the body's view made like it): the direction then holds no
    wrist motion.  Measured: a body without finger joints against a hands take with them (the
    markers across the palm made from the wrist's axes) and a wrist-rooted hand file mislead the
    refinement by 1.7-5 frames even so (tests/test_splice.py, tests/test_handonly.py); they keep
    their maps.
    """
    if not body or not hands or _P3_HAND in body or _P3_HAND in hands:
        return False
    return (body == hands or body.replace(_P3_ELBOW, _P3_FOREARM_JOINT) == hands
            or {body, hands} in ({"optical", ANATOMICAL}, {"optical", STYLOID}))


#: A take whose hand direction in the forearm's frame (:func:`hand_in_forearm`, each unit-vector
#: component's standard deviation) varies less than this holds no wrist motion: a hand-only file
#: whose forearm joint turns with the hand (the shared Leap clips: exactly 0).
STILL_WRIST = 1e-6


def wrist_moves(points: np.ndarray) -> bool:
    """Whether the hand turns in the forearm's frame at all over these markers (:data:`STILL_WRIST`)."""
    d = hand_in_forearm(points)
    return bool(len(d) > 1 and float(np.max(np.std(d, axis=0))) > STILL_WRIST)


def markers_compare(placed: tuple, body_points: np.ndarray, hands_points: np.ndarray) -> bool:
    """Whether the wrist's signal can be read from these markers: placements that compare
    (:func:`comparable_placements`, ``placed`` as ``(body, hands)``), every marker a number, and
    a hand that turns in its forearm in both takes (:func:`wrist_moves`).  The one rule for the
    wrist's refinement (:func:`splicer.stages.transfer.refine_time_maps`) and the second opinion
    that reads the same signal (:mod:`splicer.stages.recheck`)."""
    return bool(comparable_placements(*placed) and np.isfinite(body_points).all() and np.isfinite(hands_points).all()
                and wrist_moves(body_points) and wrist_moves(hands_points))


def turn_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation ``R`` (3 x 3, proper) minimising ``sum ||R a_t - b_t||^2`` (Kabsch).

    Two rigs may place the wrist and hand markers a little differently (other finger bases, skin
    markers against joints): the hand's direction in the forearm's frame then differs by about a
    fixed rotation, which this takes out before the rates of change are compared.
    """
    h = np.asarray(a, dtype=np.float64).T @ np.asarray(b, dtype=np.float64)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


@njit(cache=True)
def _offset_costs(vb, vh, c, slope, offsets, out):
    # out[t, s] = || vb[t] - slope[t] * vh(c[t] + offsets[s]) ||^2, vh linear between rows, clipped to its ends
    n, S = out.shape
    m, k = vh.shape
    for t in range(n):
        for s in range(S):
            w = min(max(c[t] + offsets[s], 0.0), m - 1.0)
            j = min(int(np.floor(w)), max(m - 2, 0))
            f = w - j
            j1 = min(j + 1, m - 1)
            acc = 0.0
            for q in range(k):
                d = vb[t, q] - slope[t] * ((1.0 - f) * vh[j, q] + f * vh[j1, q])
                acc += d * d
            out[t, s] = acc


def offset_costs(v_body: np.ndarray, v_hands: np.ndarray, c: np.ndarray, slope: np.ndarray,
                 offsets: np.ndarray) -> np.ndarray:
    """``E[t, d]``: the squared mismatch of the rates of change, divided by its median.

    Parameters
    ----------
    v_body : np.ndarray [shape=(n, k)]
        Body rates of change at the map's body frames.
    v_hands : np.ndarray [shape=(m, k)]
        Hands rates of change per common frame (the hands take at the body's rate).
    c : np.ndarray [shape=(n,)]
        The map, common frames (finite).
    slope : np.ndarray [shape=(n,)]
        The map's local slope, common frames per body frame (>= 0).
    offsets : np.ndarray [shape=(S,)]
        Offsets tried, common frames.

    Returns
    -------
    np.ndarray [shape=(n, S), dtype=float64]
        Unitless (1 is the median cell, or the mean where over half the cells are 0; over
        :data:`_MEDIAN_CELLS` cells, of evenly spaced rows); all zeros when every cell is 0 (no
        motion at all).
    """
    e = np.empty((len(c), len(offsets)))
    _offset_costs(np.ascontiguousarray(v_body, dtype=np.float64), np.ascontiguousarray(v_hands, dtype=np.float64),
                  np.ascontiguousarray(c, dtype=np.float64), np.ascontiguousarray(slope, dtype=np.float64),
                  np.ascontiguousarray(offsets, dtype=np.float64), e)
    if not e.size:
        return e
    sample = e[::max(1, e.size // _MEDIAN_CELLS)] if e.size > _MEDIAN_CELLS else e  # whole rows, evenly spread
    scale = float(np.median(sample))
    if not scale > 0.0:
        scale = float(np.mean(sample))
    if not scale > 0.0:
        e[:] = 0.0
        return e
    e /= scale  # in place: an hour-long take's costs are 200 MB
    return e


@njit(cache=True)
def _expected_offsets(e, offsets, lam, max_step, temp):
    # forward-backward over offset paths weighed exp(-(sum e + lam * steps^2) / temp), the path
    # starting from the middle column; the posterior mean of each row's offset.  Scaled in the
    # linear domain (each row's weights divided by their sum; each row's emissions taken
    # relative to its smallest cost, so one of them is exp(0)).  Memory: the forward table
    # (n x S) and a few rows.  Returns (n, 2): each row's posterior mean and standard deviation.
    n, S = e.shape
    zero = S // 2
    kern = np.empty(2 * max_step + 1)
    for k in range(2 * max_step + 1):
        d = k - max_step
        kern[k] = np.exp(-lam * d * d / temp)
    fw = np.empty((n, S))
    em = np.empty(S)
    for t in range(n):
        lo = e[t].min()
        for s in range(S):
            em[s] = np.exp(-(e[t, s] - lo) / temp)
        z = 0.0
        for s in range(S):
            if t == 0:
                v = np.exp(-lam * (s - zero) * (s - zero) / temp)
            else:
                v = 0.0
                for k in range(2 * max_step + 1):
                    p = s - (k - max_step)
                    if 0 <= p < S:
                        v += fw[t - 1, p] * kern[k]
            fw[t, s] = v * em[s]
            z += fw[t, s]
        if z > 0.0:
            for s in range(S):
                fw[t, s] /= z
        else:  # every weight underflowed: the emissions alone
            z = em.sum()
            for s in range(S):
                fw[t, s] = em[s] / z
    out = np.empty((n, 2))
    bw = np.ones(S)
    nb = np.empty(S)
    for t in range(n - 1, -1, -1):
        if t < n - 1:
            lo = e[t + 1].min()
            for s in range(S):
                em[s] = np.exp(-(e[t + 1, s] - lo) / temp) * bw[s]
            z = 0.0
            for s in range(S):
                v = 0.0
                for k in range(2 * max_step + 1):
                    q = s + (k - max_step)
                    if 0 <= q < S:
                        v += kern[k] * em[q]
                nb[s] = v
                z += v
            for s in range(S):
                bw[s] = nb[s] / z if z > 0.0 else 1.0
        z = 0.0
        mean = 0.0
        for s in range(S):
            w = fw[t, s] * bw[s]
            z += w
            mean += w * offsets[s]
        if z > 0.0:
            mean /= z
            var = 0.0
            for s in range(S):
                var += fw[t, s] * bw[s] * (offsets[s] - mean) ** 2
            out[t, 0] = mean
            out[t, 1] = np.sqrt(var / z)
        else:
            out[t, 0] = 0.0
            out[t, 1] = 0.0
    return out


def offset_posterior(e: np.ndarray, offsets: np.ndarray, *, step: float = STEP_FRAMES, lam: float = LAMBDA,
                     max_step: int = MAX_STEP, temperature: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Each row's expected offset, and its standard deviation, over paths weighed ``exp(-cost / temperature)``.

    ``cost = sum e[t, s_t] + lam * sum ((s_t - s_{t-1}) * step)^2`` with ``s_{-1}`` the middle
    column (offset 0): the first row may lie anywhere, at that price; from then on each step
    moves at most ``max_step`` columns.  The expected offset (the posterior's mean,
    forward-backward) is a smooth function of ``e``, where the best path alone would jump
    between near-equal paths when the input changes in its last digits.  The standard deviation
    says how sharply the costs pick it (the risk model reads it, :mod:`splicer.align.risk`).

    Parameters
    ----------
    e : np.ndarray [shape=(n, S)]
        Costs, finite.
    offsets : np.ndarray [shape=(S,)]
        Each column's offset (any unit), symmetric about the middle column.

    Returns
    -------
    mean, sd : np.ndarray [shape=(n,), dtype=float64]
        In the unit of ``offsets``.
    """
    e = np.ascontiguousarray(e, dtype=np.float64)
    offsets = np.ascontiguousarray(offsets, dtype=np.float64)
    if e.ndim != 2 or e.shape[1] < 1 or offsets.shape != (e.shape[1],):
        raise ValueError(f"e must be (n, S) with S >= 1 and offsets (S,), got {e.shape} and {offsets.shape}")
    if not (np.isfinite(e).all() and np.isfinite(offsets).all()):
        raise ValueError("e and offsets must be finite")
    if not (lam >= 0 and step > 0 and temperature > 0 and int(max_step) == max_step and max_step >= 0):
        raise ValueError(f"need lam >= 0, step > 0, temperature > 0 and a whole max_step >= 0, "
                         f"got {lam}, {step}, {temperature}, {max_step}")
    if len(e) == 0:
        return np.zeros(0), np.zeros(0)
    out = _expected_offsets(e, offsets, float(lam) * step * step, int(max_step), float(temperature))
    return out[:, 0].copy(), out[:, 1].copy()


def expected_offsets(e: np.ndarray, offsets: np.ndarray, **kw) -> np.ndarray:
    """The mean of :func:`offset_posterior` (same arguments)."""
    return offset_posterior(e, offsets, **kw)[0]


@dataclass(frozen=True, eq=False)
class WristFit:
    """What :func:`refine_map` did to a map.

    Attributes
    ----------
    refined : np.ndarray [shape=(n,)]
        The map, non-decreasing, within ``[0, m - 1]``, common frames.
    offset : np.ndarray [shape=(n,)]
        What was added, common frames (before the clip and the monotone pass).
    sd : np.ndarray [shape=(n,)]
        The offset posterior's standard deviation, common frames (zero where nothing was searched).
    """

    refined: np.ndarray
    offset: np.ndarray
    sd: np.ndarray


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    from ..filters import gaussian_filter1d  # scipy's, bit for bit, without importing scipy

    return gaussian_filter1d(x, sigma, axis=0, mode="nearest") if sigma > 0 and len(x) > 1 else x.copy()


def _direction(points: np.ndarray, smooth_s: float, fps: float) -> np.ndarray:
    """The hand's direction in the forearm's frame (:func:`hand_in_forearm`), smoothed over ``smooth_s``."""
    return _smooth(hand_in_forearm(points), smooth_s * fps)


def _tempo(c: np.ndarray, slope_s: float, fps: float) -> np.ndarray:
    """The map's local slope (the hands' tempo), smoothed over ``slope_s``: the slope, not the map, so true to the ends."""
    return np.clip(_smooth(np.gradient(c), slope_s * fps), 0.0, None)


@dataclass(frozen=True, eq=False)
class WristEvidence:
    """A side's wrist refinement per body frame, seconds (NaN where it did not run): what the
    risk model reads (:func:`splicer.stages.risk.side_risk_signals`).

    Attributes
    ----------
    shift_s : np.ndarray [shape=(n_body,)]
        How far the refinement moved the map (its smoothed offset, absolute).
    sd_s : np.ndarray [shape=(n_body,)]
        The offset posterior's standard deviation.
    """

    shift_s: np.ndarray
    sd_s: np.ndarray


def refine_map(body_points: np.ndarray, hands_points: np.ndarray, c: np.ndarray, *, fps: float, radius_s: float,
               smooth_s: float, offset_smooth_s: float, slope_s: float,
               still: np.ndarray | None = None) -> WristFit:
    """The map ``c`` (common frames, one per body frame) moved by the wrist's best smooth offset.

    Parameters
    ----------
    body_points : np.ndarray [shape=(n, 4, 3)]
        The body's markers over the map's frames.
    hands_points : np.ndarray [shape=(m, 4, 3)]
        The hands' markers at the body's rate (common frames).
    c : np.ndarray [shape=(n,)]
        The map, common frames, finite and non-decreasing.
    fps : float
        The common rate, frames per second.
    radius_s, smooth_s, offset_smooth_s, slope_s : float
        The offsets searched (each side), the markers' smoothing, the offset path's smoothing,
        and the window of the map's slope, seconds.
    still : np.ndarray [shape=(n,), dtype=bool], optional
        Frames where the body holds still (its hand does not move in the forearm: nothing to
        read): their costs are 0, so the offset is carried across them by the offset path's
        smoothness (:data:`splicer.defaults.WRIST_HOLD_MARGIN_S`).  None: every frame read.

    Returns
    -------
    WristFit
    """
    c = np.asarray(c, dtype=np.float64)
    n, m = len(c), len(hands_points)
    if n < 2 or m < 2 or not radius_s > 0:
        return WristFit(c.copy(), np.zeros(n), np.zeros(n))
    if not np.isfinite(c).all():
        raise ValueError("the map must be finite over the frames refined")
    xb, xh = _direction(body_points, smooth_s, fps), _direction(hands_points, smooth_s, fps)
    xh = xh @ turn_onto(sample_linear(xh, c), xb).T  # markers placed a little differently on the two rigs
    vb, vh = np.gradient(xb, axis=0), np.gradient(xh, axis=0)
    slope = _tempo(c, slope_s, fps)
    radius = radius_s * fps
    offsets = np.arange(-np.floor(radius / STEP_FRAMES), np.floor(radius / STEP_FRAMES) + 1) * STEP_FRAMES
    e = offset_costs(vb, vh, c, slope, offsets)
    if still is not None:
        still = np.asarray(still, dtype=bool)
        if still.shape != (n,):
            raise ValueError(f"still must have one flag per frame of the map ({n}), got shape {still.shape}")
        e[still] = 0.0
    mean, sd = offset_posterior(e, offsets)
    d = _smooth(mean, offset_smooth_s * fps)
    return WristFit(np.maximum.accumulate(np.clip(c + d, 0.0, m - 1.0)), d, sd)


def rate_mismatch(body_points: np.ndarray, hands_points: np.ndarray, c: np.ndarray, *, fps: float,
                  smooth_s: float) -> float:
    """How unlike the body's the hands' hand-in-forearm motion is along the map ``c``.

    The hands' direction (:func:`hand_in_forearm`, smoothed over ``smooth_s``) is sampled along
    the map and turned onto the body's (:func:`turn_onto`); the mean squared difference of the
    two per-body-frame rates of change, over the body's mean squared rate.  0: the hand moves
    alike in both takes along the map; about 2 for unrelated motion.  Two alignments of one pair
    compare by it (:mod:`splicer.stages.recheck`): it reads what pass 1 does not, the hand
    relative to the forearm, which a second performance's arm noise leaves clean.

    Parameters
    ----------
    body_points, hands_points, c, fps
        As :func:`refine_map` (``c`` finite, any order).
    smooth_s : float
        The markers' smoothing, seconds.

    Returns
    -------
    float
        NaN with fewer than 3 frames or a body hand that does not move.
    """
    c = np.asarray(c, dtype=np.float64)
    if len(c) < 3 or len(hands_points) < 2:
        return float("nan")
    if not np.isfinite(c).all():
        raise ValueError("the map must be finite")
    xb = _direction(body_points, smooth_s, fps)
    xh = sample_linear(_direction(hands_points, smooth_s, fps), c)
    xh = xh @ turn_onto(xh, xb).T
    vb, vh = np.gradient(xb, axis=0), np.gradient(xh, axis=0)
    energy = float(np.mean(np.sum(vb ** 2, axis=1)))
    if not energy > 0:
        return float("nan")
    return float(np.mean(np.sum((vb - vh) ** 2, axis=1)) / energy)


def local_rate_mismatch(body_points: np.ndarray, hands_points: np.ndarray, c: np.ndarray, *, fps: float,
                        smooth_s: float, window_s: float, min_motion: float = 0.0) -> np.ndarray:
    """:func:`rate_mismatch` over the window of ``window_s`` seconds centred on each frame of the map.

    The directions and their rates of change are made once along the whole map (as
    :func:`rate_mismatch` makes them along its frames); each window then fits its own rotation
    of the hands' directions onto the body's (:func:`turn_onto`) and compares the rates turned
    by it.  Running sums make every window at once: O(n) for a map of n frames.

    Parameters
    ----------
    body_points, hands_points, c, fps, smooth_s
        As :func:`rate_mismatch` (``c`` finite).
    window_s : float
        The window, seconds (> 0); clipped at the map's ends.
    min_motion : float
        A window whose body hand moves in its forearm less than this share of the median
        window's motion (summed squared rates) gets NaN: the ratio's denominator is then too
        small to read (0: only a hand that does not move at all).

    Returns
    -------
    np.ndarray [shape=(n,)]
        0 where the hand moves alike in both takes along the map; about 2 for unrelated motion;
        NaN where the body's hand moves too little in the window.
    """
    c = np.asarray(c, dtype=np.float64)
    if not window_s > 0:
        raise ValueError(f"window_s must be positive, got {window_s!r}")
    if not min_motion >= 0:
        raise ValueError(f"min_motion must be >= 0, got {min_motion!r}")
    if c.ndim != 1 or len(c) != len(body_points):
        raise ValueError(f"need one map frame per body frame, got {c.shape} for {len(body_points)} body frames")
    if not np.isfinite(c).all():
        raise ValueError("the map must be finite")
    n = len(c)
    if n < 3 or len(hands_points) < 2:
        return np.full(n, np.nan)
    xb = _direction(body_points, smooth_s, fps)
    xh = sample_linear(_direction(hands_points, smooth_s, fps), c)
    vb, vh = np.gradient(xb, axis=0), np.gradient(xh, axis=0)
    half = max(1, int(round(window_s * fps / 2.0)))
    u, _, vt = np.linalg.svd(running_sum(xh[:, :, None] * xb[:, None, :], half))  # Kabsch per window
    v, ut = np.swapaxes(vt, 1, 2), np.swapaxes(u, 1, 2)
    d = np.sign(np.linalg.det(v @ ut))
    d[d == 0] = 1.0
    rot = (v * np.stack([np.ones(n), np.ones(n), d], axis=1)[:, None, :]) @ ut  # V diag(1, 1, d) U^T
    cross = np.einsum("tij,tji->t", rot, running_sum(vh[:, :, None] * vb[:, None, :], half))  # sum vb . R vh
    energy = running_sum(np.sum(vb ** 2, axis=1), half)
    other = running_sum(np.sum(vh ** 2, axis=1), half)
    out = np.full(n, np.nan)
    ok = energy > max(0.0, min_motion * float(np.median(energy)))
    out[ok] = (energy[ok] + other[ok] - 2.0 * cross[ok]) / energy[ok]
    return out


def noise_share(body_points: np.ndarray, hands_points: np.ndarray, c: np.ndarray, *, fps: float, smooth_s: float,
                slope_s: float, body_noise: np.ndarray | None = None, hands_noise: np.ndarray | None = None) -> float:
    """How much of the hand's motion relative to the forearm, as :func:`refine_map` reads it, is marker noise.

    The refinement matches the rates of change of the hand's direction in the forearm's frame;
    optical markers' noise reaches them (the frame spans markers a few centimetres apart).  With a
    draw of each take's noise carried to these frames (:meth:`splicer.rig.marker_arm.MarkerArm.noise_sample`),
    the noise's part of the rates is the change the draw makes to them::

        share = (sum_q mean(dv_body_q^2) + sum_q mean((slope * dv_hands_q(c))^2)) / sum_q mean(v_body_q^2)

    Parameters
    ----------
    body_points, hands_points, c, fps, smooth_s, slope_s
        As :func:`refine_map` (``c`` finite).
    body_noise, hands_noise : np.ndarray [shape like the points], optional
        The noise draws; None: that take's markers carry none (a solved skeleton's).

    Returns
    -------
    float
        Unitless, >= 0 (0 without noise draws); ``inf`` when the body's hand does not move in its
        forearm at all but noise is drawn, NaN with fewer than 3 frames.
    """
    c = np.asarray(c, dtype=np.float64)
    if len(c) < 3 or len(hands_points) < 2:
        return float("nan")
    if body_noise is None and hands_noise is None:
        return 0.0
    if not np.isfinite(c).all():
        raise ValueError("the map must be finite")

    def rate(points):
        return np.gradient(_direction(points, smooth_s, fps), axis=0)

    vb = rate(body_points)
    noise = 0.0
    if body_noise is not None:
        noise += float(np.sum(np.mean((rate(body_points + body_noise) - vb) ** 2, axis=0)))
    if hands_noise is not None:
        dv = rate(hands_points + hands_noise) - rate(hands_points)
        slope = _tempo(c, slope_s, fps)
        noise += float(np.sum(np.mean((slope[:, None] * sample_linear(dv, c)) ** 2, axis=0)))
    signal = float(np.sum(np.mean(vb ** 2, axis=0)))
    if not signal > 0:
        return float("inf") if noise > 0 else 0.0
    return noise / signal
