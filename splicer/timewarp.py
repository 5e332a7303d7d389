"""Sampling motions at fractional frames, and smooth random time warps.

Frame numbers here are 0-based and fractional: frame ``2.5`` lies halfway between frames
2 and 3.  Rotations are interpolated by slerp (shortest arc) between the two neighbouring
frames, everything else linearly.  Frames outside ``[0, T - 1]`` are clipped to the range
(the first or last frame is held).
"""

from __future__ import annotations

import numpy as np
from .filters import gaussian_filter1d

from .model import Motion
from .rotations import euler_channels_deg, quat_normalize, quat_slerp

__all__ = ["sample_rotations", "sample_linear", "resample_motion", "smooth_noise", "smooth_monotone_warp"]


def _neighbours(n: int, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Floor frame, ceil frame and weight of the ceil frame for each fractional frame."""
    f = np.asarray(frames, dtype=np.float64)
    if f.ndim != 1:
        raise ValueError(f"frames must be a 1-D array of fractional frame numbers, got shape {f.shape}")
    if n < 1:
        raise ValueError("cannot sample a sequence without frames")
    if not np.all(np.isfinite(f)):
        raise ValueError("frames must be finite")
    f = np.clip(f, 0.0, n - 1)
    i0 = np.floor(f).astype(np.int64)
    i0 = np.minimum(i0, n - 1)
    i1 = np.minimum(i0 + 1, n - 1)
    return i0, i1, f - i0


def sample_rotations(q: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Quaternions at fractional frames, by slerp between the floor and ceil frames.

    Parameters
    ----------
    q : np.ndarray [shape=(T, K, 4)]
        Unit quaternions ``(w, x, y, z)`` of K joints over T frames.
    frames : np.ndarray [shape=(F,)]
        Fractional frame numbers, clipped to ``[0, T - 1]``.

    Returns
    -------
    np.ndarray [shape=(F, K, 4), dtype=float64]
        At an integer frame, that frame's quaternion; at ``i + 0.5``, the rotation halfway
        (geodesically) between frames ``i`` and ``i + 1``.

    Examples
    --------
    >>> q = np.array([[[1.0, 0, 0, 0]], [[0.0, 0, 0, 1]]])   # identity, then 180 deg about z
    >>> np.round(sample_rotations(q, np.array([0.5])), 4)
    array([[[0.7071, 0.    , 0.    , 0.7071]]])
    """
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 3 or q.shape[-1] != 4:
        raise ValueError(f"q must have shape (T, K, 4), got {q.shape}")
    i0, i1, t = _neighbours(q.shape[0], frames)
    out = quat_slerp(q[i0], q[i1], np.broadcast_to(t[:, None], (t.shape[0], q.shape[1])))
    exact = t == 0.0
    out[exact] = quat_normalize(q[i0[exact]])
    return out


def sample_linear(x: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Values at fractional frames, by linear interpolation along the first axis.

    Parameters
    ----------
    x : np.ndarray [shape=(T, ...)]
    frames : np.ndarray [shape=(F,)]
        Fractional frame numbers, clipped to ``[0, T - 1]``.

    Returns
    -------
    np.ndarray [shape=(F, ...), dtype=float64]
    """
    x = np.asarray(x, dtype=np.float64)
    i0, i1, t = _neighbours(x.shape[0], frames)
    t = t.reshape((-1,) + (1,) * (x.ndim - 1))
    return x[i0] * (1.0 - t) + x[i1] * t


def resample_motion(motion: Motion, frames: np.ndarray, frame_time: float) -> Motion:
    """A new motion whose frame ``k`` is ``motion`` at fractional frame ``frames[k]``.

    Parameters
    ----------
    motion : Motion
    frames : np.ndarray [shape=(F,)]
        Fractional frame numbers of ``motion`` (clipped to its range); need not be increasing.
    frame_time : float
        Seconds per frame of the result.

    Returns
    -------
    Motion
        F frames.  Joints with three rotation channels are slerped and written back as
        Euler angles in their own channel order, each angle brought within 180 degrees of
        the linearly interpolated original channel (so an identity frame map reproduces
        the channels, and angles stay continuous where the input's are); other rotation
        channels and all position channels are interpolated linearly.
    """
    sk = motion.skeleton
    frames = np.asarray(frames, dtype=np.float64)
    ch = sample_linear(motion.channels, frames)
    rot3 = [j for j in range(sk.n_joints) if len(sk.rotation_columns(j)) == 3]
    if rot3 and len(frames):
        q = sample_rotations(motion.rotations[:, rot3], frames)
        for k, j in enumerate(rot3):
            cols = sk.rotation_columns(j)
            ch[:, cols] = euler_channels_deg(q[:, k], sk.rotation_order(j), near_deg=ch[:, cols])
    return Motion(sk, ch.reshape(len(frames), sk.n_channels), frame_time, motion.source)


# Random warps for synthetic data (evaluation code, not the alignment or the transfer): outside
# the mutation-testing scope.
# pragma: no mutate start
def smooth_noise(n: int, rng: np.random.Generator, *, sigma: float, dims: tuple[int, ...] = ()) -> np.ndarray:
    """Gaussian-smoothed white noise with unit standard deviation (in expectation).

    Parameters
    ----------
    n : int
        Number of samples.
    rng : np.random.Generator
    sigma : float
        Width of the Gaussian smoothing kernel, in samples (> 0).
    dims : tuple of int
        Extra trailing dimensions (independent channels).

    Returns
    -------
    np.ndarray [shape=(n, *dims), dtype=float64]
        Smooth (infinitely differentiable in the limit) curves, zero mean, unit variance.
    """
    if sigma <= 0:
        raise ValueError(f"sigma must be positive, got {sigma}")
    pad = int(np.ceil(4 * sigma))
    w = rng.standard_normal((n + 2 * pad,) + tuple(dims))
    s = gaussian_filter1d(w, sigma, axis=0, mode="reflect")[pad:pad + n]
    # standard deviation of white noise after a unit-sum Gaussian of width sigma
    return s * np.sqrt(2.0 * np.sqrt(np.pi) * sigma)


def smooth_monotone_warp(n: int, rng: np.random.Generator, *, min_speed: float, max_speed: float,
                         sigma: float) -> np.ndarray:
    """A random, smooth, strictly increasing time warp.

    The local speed ``s`` (warped frames per input frame) is ``exp`` of smoothed noise squashed
    by ``tanh`` into ``[log min_speed, log max_speed]``, so it is smooth, bounded and spends
    comparable time above and below the geometric mean speed.

    Parameters
    ----------
    n : int
        Number of input frames.
    rng : np.random.Generator
    min_speed, max_speed : float
        Bounds of the local speed, ``0 < min_speed <= max_speed``.
    sigma : float
        Smoothing width of the log-speed, in input frames.

    Returns
    -------
    np.ndarray [shape=(n,), dtype=float64]
        Warped position of each input frame: ``w[0] = 0`` and
        ``min_speed <= w[i + 1] - w[i] <= max_speed``.
    """
    if not (0 < min_speed <= max_speed):
        raise ValueError(f"need 0 < min_speed <= max_speed, got {min_speed}, {max_speed}")
    lo, hi = np.log(min_speed), np.log(max_speed)
    z = smooth_noise(n, rng, sigma=sigma)
    speed = np.exp(0.5 * (lo + hi) + 0.5 * (hi - lo) * np.tanh(1.5 * z))
    return np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]))])
# pragma: no mutate end
