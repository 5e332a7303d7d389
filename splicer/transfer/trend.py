"""The time map weighed by the alignment's own uncertainty: a local-trend smoother.

The expected path (pass 1) gives a hands time for every body frame and, with it, how widely
the near-best paths spread there (:class:`splicer.align.posterior.Posterior`: a standard
deviation).  Where the spread is small the time map is already right to a few milliseconds;
where it is large (a noisy second performance, a still arm) the path wanders around the
truth, and what is known of the truth there is that the performers' tempo changes smoothly.
:func:`trend_time_map` combines the two as a state-space model: the state is the hands time
``x`` (seconds) and the local tempo ``v`` (hands seconds per body second), the tempo drifts as
a random walk whose variance grows by ``tempo_var_per_s`` per second of body time, and each
body frame observes ``x`` with the standard deviation the spread says.
The Rauch-Tung-Striebel smoother gives the mean of ``x`` given every observation: it follows
the time map where the estimate is small and bridges the uncertain stretches with the tempo
the confident frames around them imply.  It also gives the standard deviation of ``x`` given
every observation, and how far the mean moved from the map: both are signals of the risk
model (:mod:`splicer.align.risk`).

Units are in the names: ``_s`` seconds, ``_per_s`` per second of body time; ``hands`` /
``body`` frames are 0-based, fractional where the map is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..runs import true_runs

__all__ = ["TrendFit", "trend_fit", "trend_time_map", "ERROR_FLOOR_S"]

#: No frame is trusted to better than this (seconds of hands time): the expected path's own
#: resolution, a fraction of a frame.
ERROR_FLOOR_S = 0.005
#: Prior standard deviation of the tempo at the first observed frame (hands s per body s):
#: loose next to any real tempo change, so the data decide.
_TEMPO_PRIOR = 1.0
#: Prior variance of the hands time at the first frame of a run (seconds squared): none to speak of.
_X_PRIOR = 1e4


@njit(cache=True)
def _rts(y, r, dts, q, v0, p_v0):  # pragma: no cover - compiled; tested against a dense Gaussian solution (tests/test_trend.py)
    """Rauch-Tung-Striebel smoother of a local-linear-trend model (plain loops).

    ``y[i]`` observed with variance ``r[i]`` (``r[i] < 0``: not observed); state (x, v),
    ``x[i+1] = x[i] + dt v[i]`` with ``dt = dts[i+1]`` (0 across a body hold: the hands time
    stands still), ``v`` a random walk of variance density ``q``.  Returns the
    smoothed ``x`` and its variance.  The prior at index 0 is ``x = y[0]`` (loosely:
    ``_X_PRIOR``), ``v = v0``."""
    n = y.shape[0]
    xf = np.empty(n)
    vf = np.empty(n)
    pf = np.empty((n, 3))  # filtered covariance: p00, p01, p11
    pp = np.empty((n, 3))  # predicted covariance
    xp = np.empty(n)
    vp = np.empty(n)
    x, v = y[0], v0
    a, b, c = _X_PRIOR, 0.0, p_v0
    for i in range(n):
        if i > 0:
            dt = dts[i]
            q00, q01, q11 = q * dt * dt * dt / 3.0, q * dt * dt / 2.0, q * dt
            x = x + dt * v
            a, b, c = a + 2.0 * dt * b + dt * dt * c + q00, b + dt * c + q01, c + q11
        xp[i], vp[i] = x, v
        pp[i, 0], pp[i, 1], pp[i, 2] = a, b, c
        if r[i] >= 0.0:
            s = a + r[i]
            k0, k1 = a / s, b / s
            e = y[i] - x
            x, v = x + k0 * e, v + k1 * e
            a, b, c = a * (r[i] / s), b * (r[i] / s), c - k1 * b  # (1 - k0) a, (1 - k0) b without cancelling
        xf[i], vf[i] = x, v
        pf[i, 0], pf[i, 1], pf[i, 2] = a, b, c
    xs = xf.copy()
    vs = vf.copy()
    ps = pf.copy()  # smoothed covariance
    for i in range(n - 2, -1, -1):
        # C = Pf[i] F^T inv(Pp[i+1]), F = [[1, dt], [0, 1]]
        dt = dts[i + 1]
        f00 = pf[i, 0] + dt * pf[i, 1]
        f01 = pf[i, 1]
        f10 = pf[i, 1] + dt * pf[i, 2]
        f11 = pf[i, 2]
        a1, b1, c1 = pp[i + 1, 0], pp[i + 1, 1], pp[i + 1, 2]
        det = a1 * c1 - b1 * b1
        i00, i01, i11 = c1 / det, -b1 / det, a1 / det
        c00 = f00 * i00 + f01 * i01
        c01 = f00 * i01 + f01 * i11
        c10 = f10 * i00 + f11 * i01
        c11 = f10 * i01 + f11 * i11
        dx, dv = xs[i + 1] - xp[i + 1], vs[i + 1] - vp[i + 1]
        xs[i] = xf[i] + c00 * dx + c01 * dv
        vs[i] = vf[i] + c10 * dx + c11 * dv
        # Ps[i] = Pf[i] + C (Ps[i+1] - Pp[i+1]) C^T
        d00, d01, d11 = ps[i + 1, 0] - a1, ps[i + 1, 1] - b1, ps[i + 1, 2] - c1
        e00, e01 = c00 * d00 + c01 * d01, c00 * d01 + c01 * d11
        e10, e11 = c10 * d00 + c11 * d01, c10 * d01 + c11 * d11
        ps[i, 0] = pf[i, 0] + e00 * c00 + e01 * c01
        ps[i, 1] = pf[i, 1] + e00 * c10 + e01 * c11
        ps[i, 2] = pf[i, 2] + e10 * c10 + e11 * c11
    return xs, ps[:, 0].copy()


@dataclass(frozen=True, eq=False)
class TrendFit:
    """The smoother's answer for one side (:func:`trend_fit`).

    Attributes
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        The smoothed hands frame of each body frame (fractional), NaN where uncovered; not yet
        monotone or pinned.
    sd_s : np.ndarray [shape=(n,)]
        Standard deviation of each body frame's hands time given every frame's observation,
        seconds; NaN where uncovered.
    shift_s : np.ndarray [shape=(n,)]
        How far the smoothed hands time lies from the map it smoothed, seconds; NaN where uncovered.
    """

    hands_frame: np.ndarray
    sd_s: np.ndarray
    shift_s: np.ndarray


def trend_fit(hands_frame, sd_s, *, body_fps: float, hands_fps: float, tempo_var_per_s: float,
              floor_s: float = ERROR_FLOOR_S, held=None) -> TrendFit:
    """The time map's most likely course given each frame's spread and a smooth tempo, with its
    standard deviation (arguments as :func:`trend_time_map`; ``held``: body frames where the
    body holds still, :func:`splicer.align.holds.held_rows`, across which the hands time stands
    still and the tempo does not drift).

    Examples
    --------
    The wild frame of :func:`trend_time_map`'s example moves by 20 hands frames (a third of a
    second at 60 fps); the sure frames around it stay known to about their own 10 ms:

    >>> hf = np.arange(10.0) * 2
    >>> hf[5] = 30.0
    >>> sd = np.full(10, 0.01); sd[5] = 1.0
    >>> fit = trend_fit(hf, sd, body_fps=30, hands_fps=60, tempo_var_per_s=0.01)
    >>> round(float(fit.shift_s[5]), 2), bool(np.all(fit.sd_s <= 0.01))
    (0.33, True)
    """
    hf = np.asarray(hands_frame, dtype=np.float64)
    sd_all = np.asarray(sd_s, dtype=np.float64)
    if hf.ndim != 1 or sd_all.shape != hf.shape:
        raise ValueError(f"hands_frame and sd_s need one shape (n,), got {hf.shape} and {sd_all.shape}")
    for name, v in (("body_fps", body_fps), ("hands_fps", hands_fps), ("tempo_var_per_s", tempo_var_per_s),
                    ("floor_s", floor_s)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive and finite, got {v!r}")
    out = np.full(hf.shape, np.nan)
    sd_out = np.full(hf.shape, np.nan)
    dt = 1.0 / float(body_fps)
    dts = np.full(hf.shape, dt)
    if held is not None:
        h = np.asarray(held, dtype=bool)
        if h.shape != hf.shape:
            raise ValueError(f"held must have shape {hf.shape}, got {h.shape}")
        dts[h] = 0.0
    for a, b in zip(*true_runs(np.isfinite(hf))):  # each run [a, b) of covered frames on its own
        y = hf[a:b] / float(hands_fps)
        e = sd_all[a:b]
        seen = np.isfinite(e)
        if b - a < 3 or not seen.any():
            out[a:b] = hf[a:b]
            sd_out[a:b] = np.where(seen, np.maximum(e, floor_s), np.nan)  # nothing to smooth: the spread itself
            continue
        sd = np.maximum(np.where(seen, e, 1.0), floor_s)
        r = np.where(seen, sd * sd, -1.0)
        v0 = (y[-1] - y[0]) / ((b - a - 1) * dt)
        xs, var = _rts(y, r, dts[a:b], float(tempo_var_per_s), v0, _TEMPO_PRIOR ** 2)
        out[a:b] = xs * float(hands_fps)
        sd_out[a:b] = np.sqrt(np.maximum(var, 0.0))
    return TrendFit(hands_frame=out, sd_s=sd_out, shift_s=np.abs(out - hf) / float(hands_fps))


def trend_time_map(hands_frame, sd_s, *, body_fps: float, hands_fps: float, tempo_var_per_s: float,
                   floor_s: float = ERROR_FLOOR_S) -> np.ndarray:
    """The time map's most likely course given each frame's spread and a smooth tempo.

    Parameters
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        Hands frame per body frame (fractional); NaN where the body frame is uncovered.
        Each run of covered frames is smoothed on its own.
    sd_s : np.ndarray [shape=(n,)]
        Standard deviation of each body frame's hands time, seconds (the expected path's
        spread); NaN or inf: the frame says nothing (it is bridged).
    body_fps, hands_fps : float
        Frame rates, frames per second.
    tempo_var_per_s : float
        How fast the tempo (hands seconds per body second) may drift: the variance its random
        walk gains per second of body time (> 0).
    floor_s : float
        The smallest standard deviation a frame is taken to have, seconds.

    Returns
    -------
    np.ndarray [shape=(n,)]
        Smoothed hands frames, NaN where ``hands_frame`` is; not yet monotone or pinned
        (:func:`splicer.stages.transfer.trend_time_maps` does both).

    Examples
    --------
    A straight map with one wild frame whose spread is a second comes back to the line:

    >>> hf = np.arange(10.0) * 2
    >>> hf[5] = 30.0
    >>> sd = np.full(10, 0.01); sd[5] = 1.0
    >>> out = trend_time_map(hf, sd, body_fps=30, hands_fps=60, tempo_var_per_s=0.01)
    >>> bool(abs(out[5] - 10.0) < 0.05)
    True
    """
    return trend_fit(hands_frame, sd_s, body_fps=body_fps, hands_fps=hands_fps, tempo_var_per_s=tempo_var_per_s,
                     floor_s=floor_s).hands_frame
