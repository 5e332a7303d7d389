"""Gap filling of marker trajectories (occlusions), never silent.

Each run of missing samples of a marker is filled by the first method that applies:

* ``rigid``: the marker's segment (forearm, hand, shoulder girdle...) has at least
  ``min_donors`` other markers seen throughout the gap and at its edge frames.  The marker is
  carried rigidly with them: a least-squares rigid fit (Kabsch) of the donors from the last
  frame before the gap to each gap frame places the marker as it sat before; the same from
  the first frame after; the two are blended linearly across the gap.  Exact for a rigid
  cluster.  At the ends of the take, only the seen side is used.
* ``pattern``: fewer donors than a rigid fit needs, but one or two of the segment's other
  markers seen throughout the gap and at its edges: the marker follows each donor's path, its
  offset from the donor moving linearly from the offset before the gap to the one after (held
  at an end of the take); two donors' results are averaged.  The error is the change in the
  two markers' offset during the gap (the segment turning), not the marker's own motion: on
  the protocol's markers, the cubic fills it replaced were off by 12 mm (median RMS) and up to
  690 mm on 0.5-1 s gaps; see README *Optical markers* and benchmarks/HISTORY.md.
* ``cubic``: interior gaps without a donor: a cubic spline through up to four seen
  samples on each side (linear when only one on a side).
* ``constant velocity``: gaps at the start or end without a donor: the marker moves
  on at the mean velocity of its last (first) three seen frames.

Every filled range is returned as a :class:`Fill`; a gap longer than ``max_gap_s`` seconds is
filled too but also listed in the warnings, since no method is reliable over it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import CubicSpline

from ..io.trajectories import Trajectories
from ..runs import true_runs

__all__ = ["Fill", "GapFill", "fill_gaps", "missing_runs", "rigid_transform"]


@dataclass(frozen=True)
class Fill:
    """One filled run of missing samples.

    Attributes
    ----------
    label : str
    start, stop : int
        Rows ``start`` (inclusive) to ``stop`` (exclusive) of the trajectories.
    first_frame : int
        The file's frame number of row 0 (to name frames as the file does).
    fps : float
    method : str
        ``"rigid"``, ``"pattern"``, ``"cubic"`` or ``"constant velocity"``.
    donors : tuple of str
        Markers the rigid fit used, or the pattern followed.
    too_long : bool
        Longer than the stated limit.
    """

    label: str
    start: int
    stop: int
    first_frame: int
    fps: float
    method: str
    donors: tuple = ()
    too_long: bool = False

    @property
    def seconds(self) -> float:
        return (self.stop - self.start) / self.fps

    def describe(self) -> str:
        a, b = self.first_frame + self.start, self.first_frame + self.stop - 1
        return f"{self.label}: frames {a}-{b} ({self.seconds:.2f} s) by {self.method}"

    def to_dict(self) -> dict:
        return {"marker": self.label, "frames": [self.first_frame + self.start, self.first_frame + self.stop - 1],
                "seconds": round(self.seconds, 4), "method": self.method, "donors": list(self.donors),
                "too_long": self.too_long}


@dataclass(frozen=True, eq=False)
class GapFill:
    """Filled trajectories and what was done.

    Attributes
    ----------
    trajectories : Trajectories
        The input with the filled columns complete (other columns untouched).
    fills : tuple of Fill
    warnings : tuple of str
        Gaps longer than the limit, markers never seen.
    """

    trajectories: Trajectories
    fills: tuple
    warnings: tuple


def missing_runs(miss: np.ndarray) -> list[tuple[int, int]]:
    """Runs of True in a 1-D bool array as ``(start, stop)`` pairs (stop exclusive)."""
    starts, stops = true_runs(miss)
    return list(zip(starts.tolist(), stops.tolist()))


def rigid_transform(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares rigid motions (Kabsch) taking ``src`` onto each ``dst``.

    Parameters
    ----------
    src : np.ndarray [shape=(k, 3)]
    dst : np.ndarray [shape=(G, k, 3)]
        ``k >= 3`` points, not collinear.

    Returns
    -------
    R : np.ndarray [shape=(G, 3, 3)]
        Proper rotations (det +1).
    t : np.ndarray [shape=(G, 3)]
        Translations: ``dst ~ src @ R^T + t``.
    """
    cs = src.mean(axis=0)
    cd = dst.mean(axis=1)
    h = np.einsum("ki,gkj->gij", src - cs, dst - cd[:, None, :])
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.swapaxes(vt, 1, 2) @ np.swapaxes(u, 1, 2)))
    d[d == 0] = 1.0
    dm = np.zeros((len(d), 3, 3))
    dm[:, 0, 0] = 1.0
    dm[:, 1, 1] = 1.0
    dm[:, 2, 2] = d
    r = np.swapaxes(vt, 1, 2) @ dm @ np.swapaxes(u, 1, 2)
    return r, cd - np.einsum("gij,j->gi", r, cs)


def _carry(pts: np.ndarray, c: int, donors: list[int], ref: int, frames: np.ndarray) -> np.ndarray:
    """Marker ``c`` at ``frames``, carried rigidly with ``donors`` from frame ``ref``."""
    r, t = rigid_transform(pts[ref, donors], pts[frames][:, donors])
    return np.einsum("gij,j->gi", r, pts[ref, c]) + t


def _across(at_edges: list, gap: np.ndarray, refs: list[int]):
    """What ``at_edges`` holds for each edge row in ``refs``, carried across ``gap``: blended
    linearly from the row before the gap to the row after it, or the one edge's alone."""
    if len(refs) == 1:
        return at_edges[0]
    w = ((gap - refs[0]) / (refs[1] - refs[0]))[:, None]
    return (1 - w) * at_edges[0] + w * at_edges[1]


def _pattern(pts: np.ndarray, c: int, donors: list[int], refs: list[int], gap: np.ndarray) -> np.ndarray:
    """Marker ``c`` at ``gap``: each donor's path plus the offset from it, interpolated linearly
    between the edge rows ``refs`` (held when only one); averaged over the donors."""
    out = np.zeros((len(gap), 3))
    for d in donors:
        out += pts[gap, d] + _across([pts[r, c] - pts[r, d] for r in refs], gap, refs)
    return out / len(donors)


def _velocity(x: np.ndarray, seen: np.ndarray, edge: int, step: int) -> np.ndarray:
    """Mean velocity (units per row) over up to three seen rows inward from ``edge``."""
    k = edge
    for _ in range(3):
        nxt = k + step
        if not (0 <= nxt < len(x)) or not seen[nxt]:
            break
        k = nxt
    if k == edge:
        return np.zeros(3)
    return (x[edge] - x[k]) / (edge - k)


def _cubic(x: np.ndarray, seen: np.ndarray, a: int, b: int) -> np.ndarray:
    before = np.flatnonzero(seen[:a])[-4:]
    after = b + np.flatnonzero(seen[b:])[:4]
    knots = np.concatenate([before, after])
    rows = np.arange(a, b)
    if len(before) < 2 or len(after) < 2:
        return np.stack([np.interp(rows, knots, x[knots, k]) for k in range(3)], axis=1)
    return CubicSpline(knots, x[knots], axis=0)(rows)


def fill_gaps(traj: Trajectories, segments: dict | None = None, *, columns=None, max_gap_s: float = 0.5,
              min_donors: int = 3) -> GapFill:
    """Fill the missing samples of some markers; see the module docstring for the methods.

    Parameters
    ----------
    traj : Trajectories
    segments : dict of str to sequence of int, optional
        Rigid segments: name -> marker columns moving together.  A marker's donors are the
        other markers of its segments.  None: no rigid fill.
    columns : sequence of int, optional
        Markers to fill; every marker of ``segments`` (all markers without segments) by default.
    max_gap_s : float
        Gaps longer than this (seconds) are filled but reported in the warnings.
    min_donors : int
        Donors a rigid fill needs (at least 3).

    Returns
    -------
    GapFill
        Markers never seen are left as they are and named in the warnings.
    """
    if min_donors < 3:
        raise ValueError("a rigid fit needs at least 3 donor markers")
    segments = {k: [int(c) for c in v] for k, v in (segments or {}).items()}
    if columns is None:
        columns = sorted({c for v in segments.values() for c in v}) if segments else range(traj.n_markers)
    pts = np.array(traj.points)
    seen_all = ~traj.missing
    n = traj.n_frames
    fills, notes = [], []
    for c in columns:
        seen = seen_all[:, c]
        if seen.all():
            continue
        label = traj.labels[c]
        if not seen.any():
            notes.append(f"{traj.source}: marker {label} is never seen; it cannot be filled")
            continue
        mates = sorted({d for v in segments.values() if c in v for d in v if d != c})
        x = traj.points[:, c]
        for a, b in missing_runs(~seen):
            refs = [r for r in (a - 1, b) if 0 <= r < n]
            gap = np.arange(a, b)
            span = np.concatenate([gap, refs])
            donors = [d for d in mates if seen_all[span, d].all()]
            if len(donors) >= min_donors:
                val = _across([_carry(traj.points, c, donors, r, gap) for r in refs], gap, refs)
                method, used = "rigid", tuple(traj.labels[d] for d in donors)
            elif donors:  # the two nearest at the gap's edges
                near = sorted(donors, key=lambda d: float(np.linalg.norm(traj.points[refs, d] - x[refs],
                                                                         axis=1).mean()))
                val = _pattern(traj.points, c, near[:2], refs, gap)
                method, used = "pattern", tuple(traj.labels[d] for d in near[:2])
            elif a > 0 and b < n:
                val, method, used = _cubic(x, seen, a, b), "cubic", ()
            else:
                edge, step = (b, 1) if a == 0 else (a - 1, -1)
                v = _velocity(x, seen, edge, step)
                val, method, used = x[edge] + np.outer(gap - edge, v), "constant velocity", ()
            pts[a:b, c] = val
            f = Fill(label, a, b, traj.first_frame, traj.fps, method, used, (b - a) / traj.fps > max_gap_s)
            fills.append(f)
            if f.too_long:
                notes.append(f"{traj.source}: gap longer than the {max_gap_s:g} s limit, {f.describe()}; "
                             "treat that stretch with care")
    return GapFill(replace(traj, points=pts), tuple(fills), tuple(notes))
