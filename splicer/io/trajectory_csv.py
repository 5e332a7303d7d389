"""CSV marker tables in: a plain table with one header row, or Vicon Nexus' trajectory export.

See :mod:`splicer.io.trajectories` for the layouts and :class:`~splicer.io.trajectories.Trajectories`.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from ..errors import TrajectoryError
from .trajectories import Trajectories, _finish, _number, _read_text

__all__ = ["read_csv"]

_AXIS_SUFFIX = re.compile(r"^(.*?)(?:[_:. ]|)([xyzXYZ])$")


def read_csv(path, *, units: str | None = "mm", fps: float | None = None, file_units: str = "mm") -> Trajectories:
    """Read a CSV marker table: plain (one header row) or Vicon Nexus' trajectory export.

    Parameters
    ----------
    path : str or Path
    units : str or None
        Length unit of the result; None keeps the file's.
    fps : float, optional
        Samples per second when the file has no ``time`` column (plain layout).
    file_units : str
        Length unit of a plain CSV's numbers (it cannot say); Nexus exports state theirs.

    Raises
    ------
    TrajectoryError
        No rate, a column without its x/y/z siblings, a non-number (naming line and column).
    """
    p = Path(path)
    text = _read_text(p)
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise TrajectoryError(f"{p}: empty CSV file")
    if rows[0] and rows[0][0].strip().lower() == "trajectories":
        return _finish(_nexus_csv(p, rows), units)
    header = [h.strip() for h in rows[0]]
    frame_col = time_col = None
    triples: dict = {}
    for c, h in enumerate(header):
        low = h.lower()
        if low in ("frame", "frame#", "frames"):
            frame_col = c
        elif low in ("time", "time_s", "t", "seconds"):
            time_col = c
        elif h:
            m = _AXIS_SUFFIX.match(h)
            if not m or not m.group(1):
                raise TrajectoryError(f"{p}, line 1, column {c + 1}: {h!r} is not <marker>_x/_y/_z, frame or time")
            triples.setdefault(m.group(1), {})["xyz".index(m.group(2).lower())] = c
    labels = list(triples)
    for lab in labels:
        if len(triples[lab]) != 3:
            raise TrajectoryError(f"{p}, line 1: marker {lab!r} lacks some of its x, y, z columns")
    if not labels:
        raise TrajectoryError(f"{p}, line 1: no <marker>_x/_y/_z columns")
    data, frames, times = [], [], []
    for ln, r in enumerate(rows[1:], start=2):
        if not any(v.strip() for v in r):
            continue
        r = r + [""] * (len(header) - len(r))
        data.append([[_number(r[triples[lab][a]], f"{p}, line {ln}, column {triples[lab][a] + 1}")
                      for a in range(3)] for lab in labels])
        if frame_col is not None:
            frames.append(_number(r[frame_col], f"{p}, line {ln}: frame"))
        if time_col is not None:
            times.append(_number(r[time_col], f"{p}, line {ln}: time"))
    if not data:
        raise TrajectoryError(f"{p}: the CSV file has no data rows")
    if fps is None:
        if len(times) < 2:
            raise TrajectoryError(f"{p}: no time column; give the rate (fps) of this CSV")
        dt = np.diff(np.array(times))
        if not (np.all(np.isfinite(dt)) and np.all(dt > 0)):
            raise TrajectoryError(f"{p}: the time column does not increase")
        fps = 1.0 / float(np.median(dt))
    pts = np.array(data, dtype=np.float64)
    pts[np.isnan(pts).any(axis=2)] = np.nan
    first = int(frames[0]) if frames and np.isfinite(frames[0]) else 0
    return _finish(Trajectories(tuple(labels), pts, float(fps), first, file_units, str(p)), units)


def _nexus_csv(p: Path, rows: list) -> Trajectories:
    if len(rows) < 6:
        raise TrajectoryError(f"{p}: a Nexus CSV export needs 'Trajectories', rate, labels, axes, units rows")
    rate = _number(rows[1][0] if rows[1] else "", f"{p}, line 2: rate")
    if not (rate > 0):
        raise TrajectoryError(f"{p}, line 2: expected the trajectory rate, got {rows[1]!r}")
    label_row, axis_row, unit_row = rows[2], rows[3], rows[4]
    cols, labels = [], []
    for c, lab in enumerate(label_row):
        if lab.strip():
            labels.append(lab.strip())
            cols.append(c)
    if not labels:
        raise TrajectoryError(f"{p}, line 3: no marker labels")
    for c in cols:
        if [a.strip().upper() for a in axis_row[c:c + 3]] != ["X", "Y", "Z"]:
            raise TrajectoryError(f"{p}, line 4, column {c + 1}: expected X, Y, Z under {label_row[c]!r}")
    unit = unit_row[cols[0]].strip().lower() if len(unit_row) > cols[0] else "mm"
    data, frames = [], []
    for ln, r in enumerate(rows[5:], start=6):
        if not any(v.strip() for v in r):
            break  # a blank row ends the section
        r = r + [""] * (cols[-1] + 3 - len(r))
        frames.append(_number(r[0], f"{p}, line {ln}: frame"))
        data.append([[_number(r[c + a], f"{p}, line {ln}, column {c + a + 1}") for a in range(3)] for c in cols])
    if not data:
        raise TrajectoryError(f"{p}: the Nexus CSV export has no data rows")
    pts = np.array(data, dtype=np.float64)
    pts[np.isnan(pts).any(axis=2)] = np.nan
    return Trajectories(tuple(labels), pts, rate, int(frames[0]) if np.isfinite(frames[0]) else 1, unit or "mm", str(p))
