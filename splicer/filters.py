"""Gaussian smoothing along one axis (numpy only: scipy.ndimage costs half a second to import).

:func:`gaussian_filter1d` equals ``scipy.ndimage.gaussian_filter1d(x, sigma, axis, mode=mode,
truncate=4.0)`` (order 0), which the tests check; :func:`varying_gaussian_filter1d` lets the
width change from sample to sample (tempo-matched smoothing, :mod:`splicer.align.tempo`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["gaussian_filter1d", "varying_gaussian_filter1d"]


def _padded(a: np.ndarray, r: int, mode: str) -> np.ndarray:
    """``a`` (samples first) with ``r`` samples added at each end, as ``mode`` says."""
    n = a.shape[0]
    idx = np.arange(-r, n + r)
    if mode == "nearest":
        idx = np.clip(idx, 0, n - 1)
    else:  # reflect about the edges of the first and last samples: d c b a | a b c d | d c b a
        idx = np.mod(idx, 2 * n)
        idx = np.where(idx >= n, 2 * n - 1 - idx, idx)
    return a[idx]


def gaussian_filter1d(x: np.ndarray, sigma: float, axis: int = -1, mode: str = "nearest",
                      truncate: float = 4.0) -> np.ndarray:
    """Smooth ``x`` along ``axis`` with a Gaussian of standard deviation ``sigma`` samples.

    Parameters
    ----------
    x : np.ndarray
    sigma : float
        Standard deviation, in samples (> 0; 0 returns a float copy).
    axis : int
    mode : {"nearest", "reflect"}
        Edges repeat the first/last sample, or mirror the signal (scipy's modes of those names).
    truncate : float
        The kernel reaches ``int(truncate * sigma + 0.5)`` samples each side.

    Returns
    -------
    np.ndarray, float64, the shape of ``x``

    Examples
    --------
    >>> gaussian_filter1d(np.array([0.0, 0.0, 1.0, 0.0, 0.0]), 1.0).round(4).tolist()
    [0.054, 0.242, 0.3989, 0.242, 0.054]
    """
    if mode not in ("nearest", "reflect"):
        raise ValueError(f"mode must be 'nearest' or 'reflect', not {mode!r}")
    a = np.moveaxis(np.asarray(x, dtype=np.float64), axis, 0)
    if sigma <= 0 or a.shape[0] == 0:
        return np.moveaxis(a.copy(), 0, axis)
    r = int(truncate * float(sigma) + 0.5)
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / float(sigma)) ** 2)
    k /= k.sum()
    n = a.shape[0]
    padded = _padded(a, r, mode)
    out = np.zeros_like(a)
    for t, w in enumerate(k):  # 2r + 1 shifted, weighted copies: vectorised over the other axes
        out += w * padded[t:t + n]
    return np.moveaxis(out, 0, axis)


def varying_gaussian_filter1d(x: np.ndarray, sigma: np.ndarray, axis: int = -1, mode: str = "nearest",
                              truncate: float = 4.0) -> np.ndarray:
    """Smooth ``x`` along ``axis`` with a Gaussian whose width may change from sample to sample.

    Output sample ``i`` is the mean of the samples ``j`` within ``int(truncate * sigma[i] + 0.5)``
    of it, weighed by ``exp(-(j - i)^2 / (2 sigma[i]^2))`` and normalised (the edges padded as
    ``mode`` says): with one width everywhere it is :func:`gaussian_filter1d`; where
    ``sigma[i]`` is 0 the sample is kept as it is.

    Parameters
    ----------
    x : np.ndarray
    sigma : np.ndarray [shape=(x.shape[axis],)]
        Each output sample's standard deviation, in samples (finite, >= 0).
    axis, mode, truncate
        As :func:`gaussian_filter1d`.

    Returns
    -------
    np.ndarray, float64, the shape of ``x``

    Examples
    --------
    >>> x = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0])
    >>> varying_gaussian_filter1d(x, np.array([0, 0, 0, 0, 1.0, 1.0, 1.0])).round(3).tolist()
    [0.0, 0.0, 1.0, 0.0, 0.296, 0.403, 0.242]
    """
    if mode not in ("nearest", "reflect"):
        raise ValueError(f"mode must be 'nearest' or 'reflect', not {mode!r}")
    a = np.moveaxis(np.asarray(x, dtype=np.float64), axis, 0)
    n = a.shape[0]
    s = np.asarray(sigma, dtype=np.float64)
    if s.shape != (n,):
        raise ValueError(f"sigma must have one width per sample along the axis ({n}), got shape {s.shape}")
    if n and not (np.all(np.isfinite(s)) and s.min() >= 0):
        raise ValueError("sigma must be finite and >= 0")
    if n == 0 or not s.max() > 0:
        return np.moveaxis(a.copy(), 0, axis)
    reach = (truncate * s + 0.5).astype(np.int64)
    r = int(reach.max())
    padded = _padded(a, r, mode)
    out = np.zeros_like(a)
    norm = np.zeros(n)
    inv = np.where(s > 0, 1.0 / np.maximum(s, 1e-300), 0.0)
    extra = (1,) * (a.ndim - 1)
    for k in range(-r, r + 1):  # one shifted copy per offset, each sample weighed by its own width
        w = np.where(np.abs(k) <= reach, np.exp(-0.5 * (k * inv) ** 2), 0.0) if k else np.ones(n)
        out += w.reshape((n,) + extra) * padded[k + r:k + r + n]
        norm += w
    return np.moveaxis(out / norm.reshape((n,) + extra), 0, axis)
