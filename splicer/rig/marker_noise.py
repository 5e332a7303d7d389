"""How noisy optical markers are, and what that noise does downstream.

An optical system's markers jitter by a millimetre or two from frame to frame, independently
of each other: white noise on top of motion that is smooth at the capture's rate (60-250 Hz).
The third difference of a trajectory, ``x[t+3] - 3 x[t+2] + 3 x[t+1] - x[t]``, removes any
motion that is locally quadratic and multiplies white noise's variance by 20 (1 + 9 + 9 + 1);
at 100 Hz an arm's jerk leaves about 0.1 mm in it against the noise's 4-9 mm.  So
:func:`marker_noise` estimates each marker's noise from its third differences (median absolute
deviation, robust to the odd swap or spike), and :func:`noise_markers` draws noise like it for
the paper's markers, which the caller carries through the same resampling as the markers
themselves: every step from the file's rate to the alignment's (linear interpolation, Gaussian
anti-aliasing, axis relabelling) is linear, so the noise drawn and carried is noise as the
alignment sees it (:func:`splicer.align.wrist.noise_share`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["marker_noise", "role_noise", "noise_markers"]

#: Sum of the squared coefficients of the third difference (1, -3, 3, -1).
_D3_GAIN = 20.0
#: The median absolute deviation of a normal variable, in standard deviations.
_MAD_NORMAL = 0.6744897501960817
#: Fewer usable third differences than this (each coordinate's counted): no estimate (NaN).
MIN_DIFFERENCES = 10


def marker_noise(points: np.ndarray) -> np.ndarray:
    """Each marker's white-noise standard deviation, from its third differences.

    Parameters
    ----------
    points : np.ndarray [shape=(T, K, 3)]
        Trajectories at the file's rate, file units; NaN where a marker is missing (a difference
        that touches a missing sample is left out).

    Returns
    -------
    np.ndarray [shape=(K,), dtype=float64]
        Standard deviation per coordinate (the three pooled), file units; NaN for a marker with
        fewer than :data:`MIN_DIFFERENCES` usable differences (coordinates counted apart).
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 3:
        raise ValueError(f"points must have shape (T, K, 3), got {p.shape}")
    out = np.full(p.shape[1], np.nan)
    if len(p) < 4:
        return out
    d3 = p[3:] - 3.0 * p[2:-1] + 3.0 * p[1:-2] - p[:-3]
    for k in range(p.shape[1]):
        d = d3[:, k].ravel()
        d = d[np.isfinite(d)]
        if len(d) < MIN_DIFFERENCES:
            continue
        mad = float(np.median(np.abs(d - np.median(d))))
        out[k] = mad / _MAD_NORMAL / np.sqrt(_D3_GAIN)
    return out


def role_noise(noise: np.ndarray, roles: dict) -> dict:
    """The noise of each role's point when its markers are averaged: ``sqrt(sum sd^2) / k``.

    Parameters
    ----------
    noise : np.ndarray [shape=(K,)]
        Each marker's standard deviation (:func:`marker_noise`).
    roles : dict of str to sequence of int
        Role -> the columns averaged into it.

    Returns
    -------
    dict of str to float
        File units; NaN where a marker's noise is unknown.
    """
    sd = np.asarray(noise, dtype=np.float64)
    return {r: float(np.sqrt(np.sum(sd[list(cols)] ** 2)) / len(cols)) if len(cols) else float("nan")
            for r, cols in roles.items()}


def noise_markers(sd: dict, n_frames: int, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """White noise like the markers': ``p1..p4`` and the shoulder, one draw per frame.

    Parameters
    ----------
    sd : dict
        ``"p1".."p4"``, ``"shoulder"`` -> standard deviation per coordinate (file units); a
        missing or NaN entry draws zeros.
    n_frames : int
    seed : int
        The draw is fixed, so a splice does not change from run to run.

    Returns
    -------
    points, shoulder : np.ndarray [shape=(n_frames, 4, 3)], [shape=(n_frames, 3)]
    """
    rng = np.random.default_rng(seed)
    scale = np.array([sd.get(r, np.nan) for r in ("p1", "p2", "p3", "p4", "shoulder")], dtype=np.float64)
    scale = np.where(np.isfinite(scale), scale, 0.0)
    draw = rng.standard_normal((int(n_frames), 5, 3)) * scale[None, :, None]
    return draw[:, :4], draw[:, 4]
