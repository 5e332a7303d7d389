"""Sampling motions at fractional frames, and smooth random time warps.

Frame numbers here are 0-based and fractional: frame ``2.5`` lies halfway between frames
2 and 3.  Rotations are interpolated by slerp (shortest arc) between the two neighbouring
frames, everything else linearly.  Frames outside ``[0, T - 1]`` are clipped to the range
(the first or last frame is held).
"""

from __future__ import annotations

import numpy as np
from ..filters import gaussian_filter1d

from ..model.motion import Motion
from ..model.rotations import euler_channels_deg, quat_normalize, quat_slerp

__all__ = ["sample_rotations", "sample_linear", "resample_motion"]


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
