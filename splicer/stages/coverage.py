"""Stage 6e, coverage edges: where the hands' material starts or stops inside the body.

With open ends the alignment decides which body frames the hands take covers.  Where an
uncovered range begins or ends inside the body, the exact frame is located only to within a
few frames (the covered frames there may show material from before the hands performance or
after it), and nothing in the expected path's spread or the arms' check says so: the path is
as sure of itself there as anywhere.  So the covered frames within
:data:`splicer.defaults.COVERAGE_EDGE_S` of an uncovered range get at least that estimated
error, which makes them low confidence; the output motion is not changed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..align.risk import distance_to_uncovered
from ..defaults import COVERAGE_EDGE_S

__all__ = ["coverage_edges", "mark_coverage_edges"]


def coverage_edges(hands_frame, fps: float, edge_s: float = COVERAGE_EDGE_S) -> np.ndarray:
    """Covered body frames within ``edge_s`` seconds of an uncovered one.

    Parameters
    ----------
    hands_frame : np.ndarray [shape=(n,)]
        Hands-file frame of each body frame; NaN where uncovered.
    fps : float
        Body frames per second.
    edge_s : float
        Seconds each side of an uncovered range (rounded to whole frames).

    Returns
    -------
    np.ndarray [shape=(n,), dtype=bool]

    Examples
    --------
    >>> hf = np.array([np.nan, np.nan, 5, 6, 7, 8, 9, 10, np.nan, np.nan])
    >>> coverage_edges(hf, 10.0, 0.2).astype(int).tolist()  # 2 frames each side
    [0, 0, 1, 1, 0, 0, 1, 1, 0, 0]
    >>> bool(coverage_edges(np.arange(5.0), 10.0, 0.2).any())  # nothing uncovered: no edges
    False
    """
    h = np.asarray(hands_frame, dtype=np.float64)
    if h.ndim != 1:
        raise ValueError(f"hands_frame must have shape (n,), got {h.shape}")
    if not (fps > 0 and np.isfinite(fps)) or not (edge_s >= 0 and np.isfinite(edge_s)):
        raise ValueError(f"fps must be positive and edge_s >= 0 (both finite), got {fps!r}, {edge_s!r}")
    unc = ~np.isfinite(h)
    # an uncovered frame within w frames (the risk model's edge feature counts the same way)
    return (distance_to_uncovered(unc) <= int(round(edge_s * fps))) & ~unc


def mark_coverage_edges(sides: dict, edge_s: float = COVERAGE_EDGE_S) -> dict:
    """Each side's confidence with its coverage edges' estimated error at least ``edge_s``.

    Parameters
    ----------
    sides : dict of str -> SideResult
        The finished sides of a splice (:func:`splicer.pipeline.splice`).

    Returns
    -------
    dict of str -> SideResult
        The same sides; a side with a confidence and an uncovered range inside its body gets
        :meth:`~splicer.align.confidence.Confidence.with_floor` ``(edge_s, where=edges)``.
    """
    out = {}
    for s, r in sides.items():
        conf = r.alignment.confidence
        edges = coverage_edges(r.hands_frame, r.markers.spaces.body_fps, edge_s) if conf is not None else None
        if edges is None or not edges.any():
            out[s] = r
            continue
        out[s] = replace(r, alignment=replace(r.alignment, confidence=conf.with_floor(edge_s, where=edges)))
    return out
