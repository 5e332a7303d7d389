"""Noise matching for the phase metric: how often each take's arm changes direction, and the
marker smoothing that makes a noisier take comparable (``noise_ratio``, README *Real sessions*).
"""

from __future__ import annotations

import numpy as np

from ..defaults import DEAD_ZONE, NOISE_RATIO, NOISE_TRIGGER, SMOOTH_S, SMOOTH_STEPS
from ..rig.markers import Markers
from .costs import _smooth_derivatives

__all__ = ["sign_change_rate", "swing_rate", "matched_smoothing"]


def sign_change_rate(markers: Markers, *, smooth_s: float = SMOOTH_S, dead_zone: float = DEAD_ZONE) -> float:
    """How often D1's velocity signs change: changes per second, averaged over every marker
    coordinate (shoulder-relative, smoothed and dead-zoned as :func:`phase_features` does; a
    step into or out of the dead zone counts as a change).  The horizontal coordinates are
    taken along the principal axes of the take's horizontal velocity, so the rate does not
    depend on the way the performer faces (per world axis, a clean 12-s pair turned by 47
    degrees went from 1.49x to 1.71x).

    A gesturing arm reverses a coordinate's direction two or three times a second; capture
    noise that the smoothing leaves in adds changes that carry no phase.

    >>> import numpy as np
    >>> from splicer.rig.markers import Markers
    >>> t = np.arange(300) / 30.0                       # 10 s at 30 fps
    >>> pts = np.zeros((300, 4, 3))
    >>> pts[:, 1:, 0] = np.sin(np.pi * t + 0.3)[:, None]  # a 0.5 Hz swing: 1 reversal/s
    >>> mk = Markers(pts, np.zeros((300, 3)), np.zeros(300), 1, 30.0, "left")
    >>> round(sign_change_rate(mk), 2)  # only 3 of the 12 coordinates move
    0.25
    """
    return _sign_change_rate(markers.relative(), markers.fps, smooth_s, dead_zone, markers.up)


def _principal(x: np.ndarray, up: int | None) -> np.ndarray:
    """``x [T, K, 3]`` as (vertical, horizontal along the principal axes of x's horizontal
    part, mean removed): the same whichever way the performer faces.  ``up=None``: ``x``."""
    if up is None:
        return x
    a, b = (up + 1) % 3, (up + 2) % 3
    hor = x[..., [a, b]]
    flat = hor.reshape(-1, 2) - hor.reshape(-1, 2).mean(axis=0)
    _, axes = np.linalg.eigh(flat.T @ flat)
    return np.concatenate([x[..., up, None], hor @ axes], axis=-1)


def _sign_change_rate(rel: np.ndarray, fps: float, smooth_s: float, dead_zone: float, up: int | None = None) -> float:
    if rel.shape[0] < 2 or rel.size == 0:
        return 0.0
    vel, _ = _smooth_derivatives(rel, fps, smooth_s)
    eps = dead_zone * float(np.sqrt(np.mean(vel**2)))
    vel = _principal(vel, up)
    sg = np.where(vel > eps, 1, np.where(vel < -eps, -1, 0))
    changes = np.count_nonzero(sg[1:] != sg[:-1]) / (sg.shape[1] * sg.shape[2])
    return float(changes / (rel.shape[0] / fps))


def swing_rate(markers: Markers, *, hysteresis: float = 0.25) -> float:
    """How often the markers swing across their mean position: crossings per second, averaged
    over every shoulder-relative marker coordinate (horizontal ones along the take's principal
    axes, as in :func:`sign_change_rate`).  A crossing counts when a coordinate goes
    from above ``mean + hysteresis * std`` to below ``mean - hysteresis * std`` or back, so
    capture noise near the mean adds none; a take ``k`` times slower swings ``k`` times less
    often.

    >>> import numpy as np
    >>> from splicer.rig.markers import Markers
    >>> t = np.arange(600) / 30.0
    >>> pts = np.zeros((600, 4, 3))
    >>> pts[:, :, 0] = np.sin(np.pi * t + 0.3)[:, None]  # 0.5 Hz: one crossing a second
    >>> round(swing_rate(Markers(pts, np.zeros((600, 3)), np.zeros(600), 1, 30.0, "left")), 2)  # x of 4 markers: 4 of 12
    0.33
    """
    return _swing_rate(markers.relative(), markers.fps, hysteresis, markers.up)


def _swing_rate(rel: np.ndarray, fps: float, hysteresis: float = 0.25, up: int | None = None) -> float:
    if rel.shape[0] < 2 or rel.size == 0:
        return 0.0
    x = _principal(rel, up).reshape(rel.shape[0], -1)
    x = x - x.mean(axis=0)
    h = hysteresis * x.std(axis=0)
    crossings = 0
    for c in range(x.shape[1]):
        if h[c] <= 0:
            continue
        side = np.where(x[:, c] > h[c], 1, np.where(x[:, c] < -h[c], -1, 0))
        side = side[side != 0]
        crossings += int(np.count_nonzero(side[1:] != side[:-1]))
    return float(crossings / x.shape[1] / (rel.shape[0] / fps))


def matched_smoothing(body: Markers, hands: Markers, *, smooth_s: float = SMOOTH_S, dead_zone: float = DEAD_ZONE,
                      ratio: float | None = NOISE_RATIO, trigger: float | None = NOISE_TRIGGER,
                      steps=SMOOTH_STEPS) -> tuple[float, float]:
    """The marker smoothing D1 uses for a pair, and how much noisier one take looks.

    A take ``k`` times slower than the other shows the same reversals ``k`` times less often,
    and smoothing it over ``k * w`` seconds shows what the other shows over ``w``.  ``k`` is
    estimated from both takes' :func:`swing_rate`, which noise hardly changes (clipped to
    1/4..4).  For each width ``w = smooth_s * step`` the body's :func:`sign_change_rate` at
    ``w`` is compared with ``k`` times the hands' at ``k * w``: noise in one take (1-2 degrees
    of arm noise in a second performance, a jittery solve) adds changes at the fine widths.
    When the two differ by more than ``trigger`` (by more than ``ratio`` with
    ``trigger=None``), the first width where they agree within ``ratio`` is used for both
    takes; otherwise, and always with ``ratio=None``, ``smooth_s`` is kept.

    Returns
    -------
    (smooth_s, excess) : tuple of float
        The width chosen (seconds), and the tempo-compensated ratio of the two rates at
        ``smooth_s`` (>= 1; 1.0 when a take is still).
    """
    rel_b, rel_h = body.relative(), hands.relative()  # shoulder-relative, once per take
    rb = _sign_change_rate(rel_b, body.fps, smooth_s, dead_zone, body.up)
    sb, sh = _swing_rate(rel_b, body.fps, up=body.up), _swing_rate(rel_h, hands.fps, up=hands.up)
    if smooth_s <= 0 or min(rb, sb, sh) <= 0:
        return smooth_s, 1.0  # a still take: nothing to compare
    k = float(np.clip(sb / sh, 0.25, 4.0))  # the hands take is about k times slower

    def excess(w: float, b: float) -> float:
        h = k * _sign_change_rate(rel_h, hands.fps, k * w, dead_zone, hands.up)
        if h <= 0 or b <= 0:  # a short take smoothed flat: no changes on either side agree, on one side only do not
            return 1.0 if h <= 0 and b <= 0 else np.inf
        return float(max(b / h, h / b))

    first = excess(smooth_s, rb)
    if ratio is None or first <= max(ratio, trigger if trigger is not None else ratio):
        return smooth_s, first
    for step in steps[1:]:
        w = smooth_s * step
        if excess(w, _sign_change_rate(rel_b, body.fps, w, dead_zone, body.up)) <= ratio:
            return float(w), first
    return float(smooth_s * steps[-1]), first
