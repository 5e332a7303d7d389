"""Random smooth noise and monotone time warps for synthetic data and the evaluation protocol
(never imported by the splice itself)."""

from __future__ import annotations

import numpy as np

from ..filters import gaussian_filter1d

__all__ = ["smooth_noise", "smooth_monotone_warp"]


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
