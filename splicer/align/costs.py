"""Local costs of the two passes: the phase metric D1 and the palm metric D2.

Both are computed on the fly, one chunk of band rows at a time, by private numba
kernels; the public functions prepare per-frame features and return a callable that
:func:`splicer.dtw.dtw` asks for rows ``i0 .. i1-1`` of the band.

D1 (ALGORITHM.md section 4, paper eq. 6-7)::

    D1(i, j) = sum_r || sgn(v_r,i) - sgn(R(theta_ij) v'_r,j) ||^2 + || sgn(a_r,i) - sgn(R(theta_ij) a'_r,j) ||^2

with a dead zone (``|x| < eps -> 0``) whose ``eps`` is a fraction of each motion's own
RMS speed / acceleration; beyond the paper, past the dead zone the sign rises linearly to
+-1 over a ramp (another fraction of the RMS), so D1 is continuous in the input, and ``theta_ij`` the rotation about the up axis that best
superimposes the 5-frame marker windows around ``i`` and ``j`` (Kovar, Gleicher & Pighin
2002), or the difference of root headings.

Beyond the paper, pass 1 may add a position term ``w P(i, j)``: the mean squared difference
of the two takes' shoulder-relative wrist and hand positions (``p1, p2, p4``), each turned by
its root's heading and normalised per take and axis by median and MAD
(:func:`position_features`), so a confined or re-scaled hands performance still compares.
Derivative signs flip with noise and say nothing where the arm holds; where the arm *is*
says which stretch of the performance this is (README, *How it works*).

D2 (section 5, eq. 8-9): the angle (radians) between the body's hand vector ``h`` and the
hands capture's ``h'`` after turning the forearm ``f'`` onto ``f``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from ..filters import gaussian_filter1d, varying_gaussian_filter1d

from .. import defaults as D
from ..defaults import DEAD_ZONE, SIGN_RAMP, SMOOTH_S
from ..rig.markers import Markers

__all__ = [
    "PhaseFeatures",
    "phase_features",
    "d1_cost",
    "position_features",
    "wrist_sign_features",
    "PalmFeatures",
    "palm_features",
    "d2_cost",
    "window_points",
    "kgp_theta",
]

WINDOW = 5  # frames in the theta window (paper: 5 frames x 4 markers = 20 positions)


@dataclass(frozen=True, eq=False)
class PhaseFeatures:
    """Per-frame inputs of D1 for one motion.

    Attributes
    ----------
    vel, acc : np.ndarray [shape=(T, 4, 3)]
        Shoulder-relative marker velocity (units/s) and acceleration (units/s^2), smoothed.
    eps_vel, eps_acc : float
        Dead zones: components smaller than these count as zero.
    window : np.ndarray [shape=(T, 2, 20)]
        Horizontal marker coordinates (axes ``a, b`` of :func:`horizontal_axes`) of the
        5-frame window around each frame, mean removed, for theta.
    heading : np.ndarray [shape=(T,)]
        Root heading, radians.
    up : int
    ramp_vel, ramp_acc : float
        Width of the sign's ramp past the dead zone (same units as ``eps_vel``, ``eps_acc``);
        0: the paper's step.
    position : np.ndarray [shape=(T, 9) or (T, 12)] or None
        Normalised positions for the position term (:func:`position_features`), with the
        hand-in-forearm signs (:func:`wrist_sign_features`) as three more columns when asked
        for; None when not asked for.

    :func:`phase_features` lays ``vel``, ``acc`` and ``window`` out in memory with the frames
    last (they are ``(T, ...)`` views of ``(..., T)`` arrays): D1's kernel reads one coordinate
    of a row's whole band of hands frames at a time.
    """

    vel: np.ndarray
    acc: np.ndarray
    eps_vel: float
    eps_acc: float
    window: np.ndarray
    heading: np.ndarray
    up: int
    ramp_vel: float = 0.0
    ramp_acc: float = 0.0
    position: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return self.vel.shape[0]


def horizontal_axes(up: int) -> tuple[int, int]:
    """The two horizontal axes ``(a, b)`` for vertical axis ``up``; a turn by +theta takes a toward b."""
    return (up + 1) % 3, (up + 2) % 3


def window_points(points: np.ndarray, up: int, width: int = WINDOW) -> np.ndarray:
    """Horizontal coordinates of the markers in a ``width``-frame window around each frame.

    Parameters
    ----------
    points : np.ndarray [shape=(T, K, 3)]
        Marker positions.
    up : int
        Vertical axis.

    Returns
    -------
    np.ndarray [shape=(T, 2, width * K)]
        Row 0: axis ``a``, row 1: axis ``b``, with the window's mean removed.  Windows are
        clamped at the ends of the motion (repeated edge frames).
    """
    T, K, _ = points.shape
    a, b = horizontal_axes(up)
    half = width // 2
    idx = np.clip(np.arange(T)[:, None] + np.arange(-half, half + 1)[None, :], 0, T - 1)
    win = points[idx][..., [a, b]]  # (T, width, K, 2)
    win = win.reshape(T, width * K, 2)
    win = win - win.mean(axis=1, keepdims=True)
    return np.ascontiguousarray(np.transpose(win, (0, 2, 1)))


def kgp_theta(win_body: np.ndarray, win_hands: np.ndarray) -> float:
    """Rotation (radians, about the up axis) that best superimposes ``win_hands`` on ``win_body``.

    Both are (2, N) horizontal coordinates with the mean removed (see :func:`window_points`).
    Closed form of Kovar, Gleicher & Pighin 2002: ``theta = atan2(sum(b a' - a b'), sum(a a' + b b'))``.
    """
    a, b = win_body
    a2, b2 = win_hands
    return float(np.arctan2(np.sum(b * a2 - a * b2), np.sum(a * a2 + b * b2)))


def _smooth_derivatives(x: np.ndarray, fps: float, smooth_s: float) -> tuple[np.ndarray, np.ndarray]:
    sigma = smooth_s * fps
    xs = gaussian_filter1d(x, sigma, axis=0, mode="nearest") if sigma > 0 else x
    vel = np.gradient(xs, axis=0) * fps if x.shape[0] > 1 else np.zeros_like(xs)
    acc = np.gradient(vel, axis=0) * fps if x.shape[0] > 1 else np.zeros_like(xs)
    return vel, acc


#: position_features: an axis whose spread (MAD) is below this share of the widest axis's is
#: scaled as if it had that share (a nearly still coordinate would otherwise turn noise into cost)
POSITION_MIN_SPREAD = 0.1


def position_features(markers: Markers, *, wrist_signs: bool = False, coordinates: bool = True) -> np.ndarray:
    """The position term's inputs: shoulder-relative ``p1, p2, p4``, heading removed, normalised.

    Each frame's wrist and hand markers relative to the shoulder are turned about the up axis
    by minus the root's heading (so a performer facing elsewhere compares), then each of the
    nine coordinates is centred on its median and divided by its MAD (times 1.4826: the
    standard deviation for normal data), floored at :data:`POSITION_MIN_SPREAD` of the largest.
    Median and MAD, not mean and standard deviation: extra material at the ends of a hands
    take (a calibration pose held for seconds) barely moves them.

    With ``wrist_signs``, the hand-in-forearm signs of :func:`wrist_sign_features` times
    :data:`splicer.defaults.WRIST_SIGN_SCALE` follow as three more columns (none when that is 0),
    so the position term (the mean squared difference over the columns) reads them too.

    Parameters
    ----------
    markers : Markers
    wrist_signs : bool
        Append the hand-in-forearm signs (both takes of a pair alike: the term compares columns).
    coordinates : bool
        False: the signs alone (``wrist_signs`` needed), for markers without a root heading to
        turn the coordinates by (optical markers: :data:`splicer.defaults.OPTICAL_SIGN_WEIGHT`).

    Returns
    -------
    np.ndarray [shape=(T, 9), (T, 12) or (T, 3), dtype=float64]
        Unitless; zeros where the take does not move at all (the signs' columns too).

    Raises
    ------
    ValueError
        ``coordinates=False`` without the signs (nothing left to compare).
    """
    if not coordinates:
        if not (wrist_signs and D.WRIST_SIGN_SCALE > 0):
            raise ValueError("position features without coordinates need the hand-in-forearm signs")
        return np.ascontiguousarray(D.WRIST_SIGN_SCALE * wrist_sign_features(markers))
    rel = markers.relative()[:, [0, 1, 3]]
    a, b = horizontal_axes(markers.up)
    h = np.asarray(markers.heading, dtype=np.float64)[:, None]
    cs, sn = np.cos(h), np.sin(h)
    x = rel.copy()
    x[..., a] = cs * rel[..., a] + sn * rel[..., b]  # turned by -heading: a turn by +phi adds phi to the heading
    x[..., b] = -sn * rel[..., a] + cs * rel[..., b]
    x = x.reshape(len(x), -1)
    extra = wrist_signs and D.WRIST_SIGN_SCALE > 0
    cols = 12 if extra else 9
    if not len(x):
        return np.zeros((0, cols))
    med = np.median(x, axis=0)
    mad = 1.4826 * np.median(np.abs(x - med), axis=0)
    top = float(mad.max())
    if not top > 0.0:
        return np.zeros((len(x), cols))
    y = (x - med) / np.maximum(mad, POSITION_MIN_SPREAD * top)
    if extra:
        y = np.concatenate([y, D.WRIST_SIGN_SCALE * wrist_sign_features(markers)], axis=1)
    return np.ascontiguousarray(y)


def wrist_sign_features(markers: Markers, *, smooth_s: float | None = None,
                        ramp: float | None = None) -> np.ndarray:
    """The signs of the hand's turning in the forearm's frame, per frame (0.29.0).

    A second performance's shoulder and elbow noise moves every shoulder-relative marker, and
    D1's signs then match noise; the hand's direction in the forearm's own frame
    (:func:`splicer.align.wrist.hand_in_forearm`) does not move with it.  Its three components
    are smoothed over ``smooth_s`` seconds and differentiated; each velocity is divided by
    ``ramp`` times that component's RMS velocity over the take and clipped to [-1, 1]: a sign
    that rises linearly to +-1, so the turns' timing counts, not their size (a wider or narrower
    gesture turns the same way).

    Parameters
    ----------
    markers : Markers
        ``p1, p2`` on the wrist, ``p3`` up the forearm, ``p4`` on the hand.
    smooth_s : float, optional
        Gaussian smoothing of the direction, seconds (>= 0); default
        :data:`splicer.defaults.WRIST_SIGN_SMOOTH_S`.
    ramp : float, optional
        Ramp width as a share of the RMS velocity (> 0); default :data:`splicer.defaults.WRIST_SIGN_RAMP`.

    Returns
    -------
    np.ndarray [shape=(T, 3), dtype=float64]
        In [-1, 1], unitless; zeros where a component never moves.

    Examples
    --------
    >>> import numpy as np
    >>> from splicer.rig.markers import Markers
    >>> t = np.arange(60) / 30.0
    >>> ang = np.where(t < 1.0, t, 2.0 - t)                       # the hand turns one way, then back
    >>> p = np.zeros((60, 4, 3)); p[:, 0, 1], p[:, 1, 1], p[:, 2, 0] = 0.5, -0.5, 1.0
    >>> p[:, 3, 0], p[:, 3, 2] = -np.cos(ang), np.sin(ang)        # in the forearm's x-z plane
    >>> mk = Markers(p, np.zeros((60, 3)), np.zeros(60), 1, 30.0, "right")
    >>> s = wrist_sign_features(mk, smooth_s=0.0)
    >>> float(s[10, 2]), float(s[50, 2])                           # z: up, then down
    (1.0, -1.0)
    """
    from .wrist import _direction  # the hand's direction in the forearm's frame, smoothed, as the wrist's stage reads it

    smooth_s = D.WRIST_SIGN_SMOOTH_S if smooth_s is None else smooth_s
    ramp = D.WRIST_SIGN_RAMP if ramp is None else ramp
    if not smooth_s >= 0.0 or not ramp > 0.0:
        raise ValueError(f"smooth_s must be >= 0 and ramp > 0, got {smooth_s!r} and {ramp!r}")
    d = _direction(markers.points, smooth_s, markers.fps)
    if len(d) < 2:
        return np.zeros((len(d), 3))
    v = np.gradient(d, axis=0)
    rms = np.sqrt(np.mean(v ** 2, axis=0))
    out = np.zeros_like(v)
    ok = rms > 0.0
    out[:, ok] = np.clip(v[:, ok] / (ramp * rms[ok]), -1.0, 1.0)
    return out


def phase_features(markers: Markers, *, smooth_s: float = SMOOTH_S, dead_zone: float = DEAD_ZONE,
                   sign_ramp: float = SIGN_RAMP, position: bool = False, wrist_signs: bool = False,
                   coordinates: bool = True) -> PhaseFeatures:
    """Prepare D1's inputs for one motion.

    Parameters
    ----------
    markers : Markers
        Virtual markers of one side, at the rate the DTW works at.
    smooth_s : float
        Standard deviation (seconds) of the Gaussian that smooths the shoulder-relative
        markers before differentiating: capture noise flips signs otherwise.  Default: the
        splice's, :data:`splicer.defaults.SMOOTH_S`.  Markers with a ``blur``
        (:class:`~splicer.rig.markers.Markers`) are smoothed first by a further ``blur * smooth_s``
        at each frame.
    dead_zone : float
        Components below ``dead_zone`` times the motion's RMS velocity (acceleration)
        count as zero, so a hold reads as a hold and a confined hand capture is judged on
        the same relative scale as a free body capture.  Default: the splice's,
        :data:`splicer.defaults.DEAD_ZONE`.
    sign_ramp : float
        Past the dead zone, the sign rises linearly to +-1 over ``sign_ramp`` times the RMS
        velocity (acceleration); 0 is the paper's step.  Default: the splice's,
        :data:`splicer.defaults.SIGN_RAMP`.
    position : bool
        Also prepare the position term's inputs (:func:`position_features`).
    wrist_signs : bool
        With ``position``: the position term reads the hand-in-forearm signs too
        (:func:`wrist_sign_features`).
    coordinates : bool
        With ``position``: False leaves the coordinates out, the signs alone
        (:func:`position_features`).
    """
    rel = markers.relative()
    if markers.blur is not None:  # tempo-matched smoothing first (splicer.align.tempo)
        rel = varying_gaussian_filter1d(rel, markers.blur * (smooth_s * markers.fps), axis=0)
    vel, acc = _smooth_derivatives(rel, markers.fps, smooth_s)
    rms_v = float(np.sqrt(np.mean(vel**2))) if vel.size else 0.0
    rms_a = float(np.sqrt(np.mean(acc**2))) if acc.size else 0.0
    win = window_points(markers.points, markers.up)
    vel, acc, win = (np.moveaxis(_frames_last(x), -1, 0) for x in (vel, acc, win))  # (T, ...) views, frames last in memory
    return PhaseFeatures(
        vel, acc, dead_zone * rms_v, dead_zone * rms_a, win,
        np.array(markers.heading, dtype=np.float64), markers.up,  # a writable copy: one compiled D1 kernel, not two
        sign_ramp * rms_v, sign_ramp * rms_a,
        position_features(markers, wrist_signs=wrist_signs, coordinates=coordinates) if position else None,
    )


@njit(cache=True, error_model="numpy")
def _sgn(x, eps, ramp):
    # the dead-zoned sign; with ramp > 0 it rises linearly from 0 at eps to 1 at eps + ramp.
    # Written with selects, not branches: D1's signs of real derivatives flip unpredictably from
    # one band cell to the next, and mispredicted branches were half of D1's time.  The values
    # are those of the branching form bit for bit (NaN -> 0; -(|x| - eps) / ramp == (x + eps) / ramp
    # exactly), tested against it; the unused quotient (ramp 0) is harmless under numpy's error model.
    # Not inlined by numba (inline="always"): LLVM inlines it anyway, and numba's own inlining of
    # its four uses (and of _d1_terms) cost 0.9 s of compiling for no speed.
    ax = abs(x)
    v = (ax - eps) / ramp if ax < eps + ramp else 1.0
    v = v if ax > eps else 0.0
    return v if x >= 0.0 else -v


@njit(cache=True, error_model="numpy")
def _signs(x, eps, ramp, out):
    for t in range(x.shape[0]):
        for m in range(x.shape[1]):
            for k in range(x.shape[2]):
                out[t, m, k] = _sgn(x[t, m, k], eps, ramp)


@njit(cache=True, error_model="numpy")
def _d1_terms(i, l, w, cs, sn, sv, sa, svu, sau, vh, ah, evh, eah, rvh, rah, up, o):
    # D1 of row i's band cells l .. l + w - 1 into o[:w], given each cell's turn (cs, sn), and +inf
    # in the rest of o (the chunk is as wide as its widest row).
    # Frames last everywhere: sv, sa (K, 3, T): body velocity / acceleration signs; svu, sau (K, T):
    # the hands' signs along the up axis, which no turn changes; vh, ah (K, 3, T): the hands' raw
    # derivatives (turned per cell); evh, eah: the hands' dead zones; rvh, rah: their sign ramps.
    # The row is worked through one term at a time over all its cells (unit-stride loops the
    # compiler vectorises); every cell adds its terms in the same order as a cell-by-cell loop
    # would, so the costs are the same bit for bit.
    a = (up + 1) % 3
    b = (up + 2) % 3
    for c in range(w):
        o[c] = 0.0
    for m in range(sv.shape[0]):
        s1, s2, s3, s4, s5, s6 = sv[m, up, i], sa[m, up, i], sv[m, a, i], sv[m, b, i], sa[m, a, i], sa[m, b, i]
        va, vb, aa, ab, su, au = vh[m, a], vh[m, b], ah[m, a], ah[m, b], svu[m], sau[m]
        for c in range(w):
            j = l + c
            co = cs[c]
            si = sn[c]
            cost = o[c]
            d = s1 - su[j]
            cost += d * d
            d = s2 - au[j]
            cost += d * d
            d = s3 - _sgn(co * va[j] - si * vb[j], evh, rvh)
            cost += d * d
            d = s4 - _sgn(si * va[j] + co * vb[j], evh, rvh)
            cost += d * d
            d = s5 - _sgn(co * aa[j] - si * ab[j], eah, rah)
            cost += d * d
            d = s6 - _sgn(si * aa[j] + co * ab[j], eah, rah)
            cost += d * d
            o[c] = cost
    for c in range(w, o.shape[0]):
        o[c] = np.inf


@njit(cache=True, parallel=True, error_model="numpy")
def _d1_rows_window(i0, i1, lo, hi, sv, sa, wb, svu, sau, vh, ah, evh, eah, rvh, rah, wh, up, out):
    # D1 of rows i0..i1-1 with the paper's theta per cell: cos/sin straight from the KGP sums over
    # the 5-frame windows wb, wh (2, N, T), theta = atan2(num, den).  One kernel per way of turning,
    # so a run compiles only the one it uses.
    N = wb.shape[1]
    for r in prange(i1 - i0):
        i = i0 + r
        l = lo[i]
        w = hi[i] - l + 1
        num = np.zeros(w)
        den = np.zeros(w)
        for k in range(N):
            b0 = wb[0, k, i]
            b1 = wb[1, k, i]
            h0 = wh[0, k]
            h1 = wh[1, k]
            for c in range(w):
                num[c] += b1 * h0[l + c] - b0 * h1[l + c]
                den[c] += b0 * h0[l + c] + b1 * h1[l + c]
        cs = np.empty(w)
        sn = np.empty(w)
        for c in range(w):
            norm = np.sqrt(num[c] * num[c] + den[c] * den[c])
            cs[c] = den[c] / norm if norm > 0.0 else 1.0
            sn[c] = num[c] / norm if norm > 0.0 else 0.0
        _d1_terms(i, l, w, cs, sn, sv, sa, svu, sau, vh, ah, evh, eah, rvh, rah, up, out[r])


@njit(cache=True, parallel=True, error_model="numpy")
def _d1_rows_heading(i0, i1, lo, hi, sv, sa, hb, svu, sau, vh, ah, evh, eah, rvh, rah, hh, up, out):
    # D1 of rows i0..i1-1 with theta the difference of the root headings hb[i] - hh[j]
    for r in prange(i1 - i0):
        i = i0 + r
        l = lo[i]
        w = hi[i] - l + 1
        cs = np.empty(w)
        sn = np.empty(w)
        for c in range(w):
            th = hb[i] - hh[l + c]
            cs[c] = np.cos(th)
            sn[c] = np.sin(th)
        _d1_terms(i, l, w, cs, sn, sv, sa, svu, sau, vh, ah, evh, eah, rvh, rah, up, out[r])


def _sign_array(x: np.ndarray, eps: float, ramp: float) -> np.ndarray:
    """The dead-zoned signs of a C-contiguous 3-D array, a new array of its shape."""
    out = np.empty_like(x)
    _signs(x, eps, ramp, out)
    return out


def _frames_last(x: np.ndarray) -> np.ndarray:
    """``x`` (frames first) with its frames axis moved last, C-contiguous: a view when its memory
    is laid out so already (as :func:`phase_features` leaves it), else a copy."""
    return np.ascontiguousarray(np.moveaxis(x, 0, -1))


def d1_cost(body: PhaseFeatures, hands: PhaseFeatures, *, theta: str = "window", position_weight: float = 0.0):
    """A band-chunk cost callable for D1 (see :func:`splicer.dtw.dtw`).

    Parameters
    ----------
    body, hands : PhaseFeatures
        From :func:`phase_features`, both at the same frame rate.
    theta : {"window", "heading"}
        Vertical-axis alignment: per frame pair from 5-frame marker windows (the paper),
        or the difference of root headings.
    position_weight : float
        Beyond the paper: add this many D1 units times the position term (the mean squared
        difference of the two frames' :func:`position_features`); 0 is D1 alone.  Both
        features need ``position`` then.

    Returns
    -------
    callable ``(band, i0, i1) -> np.ndarray [shape=(i1 - i0, band width)]``
    """
    if body.up != hands.up:
        raise ValueError("body and hands features must use the same up axis")
    if theta not in ("window", "heading"):
        raise ValueError(f"theta must be 'window' or 'heading', not {theta!r}")
    mode = 0 if theta == "window" else 1
    w = float(position_weight)
    if not (w >= 0.0 and np.isfinite(w)):
        raise ValueError(f"position_weight must be >= 0 and finite, got {position_weight!r}")
    if w > 0.0 and (body.position is None or hands.position is None):
        raise ValueError("a position weight needs phase_features(..., position=True) on both takes")
    if w > 0.0 and body.position.shape[1] != hands.position.shape[1]:
        raise ValueError(f"the takes' position features have {body.position.shape[1]} and "
                         f"{hands.position.shape[1]} columns: both need the same wrist_signs")
    # frames last (see _d1_terms), writable C arrays throughout: one compiled kernel each
    sv = _sign_array(_frames_last(body.vel), body.eps_vel, body.ramp_vel)
    sa = _sign_array(_frames_last(body.acc), body.eps_acc, body.ramp_acc)
    vh, ah, wb, wh = (_frames_last(x) for x in (hands.vel, hands.acc, body.window, hands.window))
    # the hands' signs along the up axis, once per frame
    up = body.up
    svu = _sign_array(np.ascontiguousarray(vh[:, up:up + 1]), hands.eps_vel, hands.ramp_vel)[:, 0]
    sau = _sign_array(np.ascontiguousarray(ah[:, up:up + 1]), hands.eps_acc, hands.ramp_acc)[:, 0]

    def cost(band, i0: int, i1: int) -> np.ndarray:
        width = band.max_row_width  # the engine wants every chunk padded to the widest row
        out = np.empty((i1 - i0, width))
        if mode == 0:
            _d1_rows_window(i0, i1, band.lo, band.hi, sv, sa, wb, svu, sau, vh, ah, hands.eps_vel,
                            hands.eps_acc, hands.ramp_vel, hands.ramp_acc, wh, body.up, out)
        else:
            _d1_rows_heading(i0, i1, band.lo, band.hi, sv, sa, body.heading, svu, sau, vh, ah, hands.eps_vel,
                             hands.eps_acc, hands.ramp_vel, hands.ramp_acc, hands.heading, body.up, out)
        if w > 0.0:
            _position_rows(i0, i1, band.lo, band.hi, body.position, hands.position, w, out)
        return out

    return cost


@njit(cache=True, parallel=True)
def _position_rows(i0, i1, lo, hi, xb, xh, weight, out):
    # adds weight * mean_k (xb[i, k] - xh[j, k])^2 to every band cell of rows i0..i1-1
    ncol = xb.shape[1]
    for r in prange(i1 - i0):
        i = i0 + r
        for c in range(hi[i] - lo[i] + 1):
            j = lo[i] + c
            s = 0.0
            for k in range(ncol):
                d = xb[i, k] - xh[j, k]
                s += d * d
            out[r, c] += weight * s / ncol


@dataclass(frozen=True, eq=False)
class PalmFeatures:
    """Per-frame inputs of D2: unit forearm vector ``f`` and unit hand vector ``h``, shape (T, 3)."""

    forearm: np.ndarray
    hand: np.ndarray

    @property
    def n_frames(self) -> int:
        return self.forearm.shape[0]


def palm_features(points: np.ndarray) -> PalmFeatures:
    """D2's inputs from markers ``points`` (T, 4, 3): ``c = (p1 + p2) / 2``, ``f = p3 - c``, ``h = p4 - c``, normalised."""
    c = 0.5 * (points[:, 0] + points[:, 1])
    f = points[:, 2] - c
    h = points[:, 3] - c
    f = f / np.maximum(np.linalg.norm(f, axis=-1, keepdims=True), 1e-12)
    h = h / np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-12)
    return PalmFeatures(np.ascontiguousarray(f), np.ascontiguousarray(h))


@njit(cache=True, inline="always")
def _palm_angle(f0, f1, f2, h0, h1, h2, g0, g1, g2, k0, k1, k2):
    # turn (g, k) (hands forearm, hand) so that g lands on f, then the angle between h and k
    c = g0 * f0 + g1 * f1 + g2 * f2
    v0 = g1 * f2 - g2 * f1
    v1 = g2 * f0 - g0 * f2
    v2 = g0 * f1 - g1 * f0
    if c < -1.0 + 1e-9:
        c = -1.0 + 1e-9
    s = 1.0 / (1.0 + c)
    # Rodrigues for the smallest rotation: R k = k c + v x k + v (v . k) / (1 + c)
    vk = v0 * k0 + v1 * k1 + v2 * k2
    r0 = k0 * c + (v1 * k2 - v2 * k1) + v0 * vk * s
    r1 = k1 * c + (v2 * k0 - v0 * k2) + v1 * vk * s
    r2 = k2 * c + (v0 * k1 - v1 * k0) + v2 * vk * s
    n = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if n < 1e-12:
        return 0.0
    cosang = (h0 * r0 + h1 * r1 + h2 * r2) / n
    if cosang > 1.0:
        cosang = 1.0
    if cosang < -1.0:
        cosang = -1.0
    return np.arccos(cosang)


@njit(cache=True, parallel=True)
def _d2_rows(i0, i1, lo, hi, width, fb, hb, fh, hh, out):
    for r in prange(i1 - i0):
        i = i0 + r
        for c in range(hi[i] - lo[i] + 1):
            j = lo[i] + c
            out[r, c] = _palm_angle(fb[i, 0], fb[i, 1], fb[i, 2], hb[i, 0], hb[i, 1], hb[i, 2],
                                    fh[j, 0], fh[j, 1], fh[j, 2], hh[j, 0], hh[j, 1], hh[j, 2])
        for c in range(hi[i] - lo[i] + 1, width):
            out[r, c] = np.inf


def d2_cost(body: PalmFeatures, hands: PalmFeatures):
    """A band-chunk cost callable for D2 (radians); see :func:`d1_cost`."""

    def cost(band, i0: int, i1: int) -> np.ndarray:
        width = band.max_row_width  # the engine wants every chunk padded to the widest row
        out = np.empty((i1 - i0, width))
        _d2_rows(i0, i1, band.lo, band.hi, width, body.forearm, body.hand, hands.forearm, hands.hand, out)
        return out

    return cost
