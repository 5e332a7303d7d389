"""Runs of True in a 1-D mask: the one run finder every stage uses (numpy only).

:func:`splicer.transfer.timemap.frame_ranges` (report ranges, inclusive), the dropout scan and
the marker gap filler (``splicer.rig``) and the plot's line painter all call
:func:`true_runs`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["true_runs"]


def true_runs(mask) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) of each run of True in ``mask``, as two int arrays.

    Parameters
    ----------
    mask : array_like [shape=(n,)]
        Anything ``np.asarray(mask, bool)`` reads as a 1-D boolean array.

    Returns
    -------
    starts, stops : np.ndarray [shape=(k,), dtype=int]
        ``mask[starts[i]:stops[i]]`` is all True, and no run is longer.

    Examples
    --------
    >>> s, e = true_runs([0, 1, 1, 0, 1, 0, 0, 1])
    >>> s.tolist(), e.tolist()
    ([1, 4, 7], [3, 5, 8])
    >>> [a.tolist() for a in true_runs(np.zeros(3, bool))]
    [[], []]
    """
    m = np.asarray(mask, dtype=bool)
    if m.ndim != 1:
        raise ValueError(f"mask must be 1-D, got shape {m.shape}")
    d = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)
