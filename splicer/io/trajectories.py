"""Optical marker trajectories: C3D, TRC and CSV in (CSV: :mod:`splicer.io.trajectory_csv`; writers:
:mod:`splicer.io.trajectory_writers`).

A :class:`Trajectories` holds labelled 3-D marker paths sampled at a constant rate, with
missing samples as NaN, in a stated length unit.

* **C3D** through the ``c3d`` package (PyPI ``c3d``, pure Python; the extra ``splicer[c3d]``).
  Chosen over ``ezc3d`` by measurement on ``markers_analogs.c3d`` (580 frames, 51 markers,
  760 analog channels): ``c3d`` read it in 0.03 s, ``ezc3d`` in 0.08 s; on damaged copies
  ``c3d`` raised a Python exception every time (truncated header, parameters or data,
  garbage, empty file) and warned on a file cut in the data section, while ``ezc3d``
  crashed the interpreter (segmentation fault) on a corrupted parameter section and
  returned a truncated file's frames without a word.  A sample is missing when its
  residual is negative (the C3D convention) or its coordinates are exactly zero.
* **TRC** (OpenSim, Cortex, Motive exports): tab-separated, ``DataRate``, ``Units``,
  ``Frame#``/``Time`` and ``X1 Y1 Z1`` columns; empty fields or ``NaN`` are missing.
* **CSV**, two layouts: a plain table with one header row (optional ``frame`` and ``time``
  columns, then ``<label>_x, <label>_y, <label>_z`` — ``:X``, ``.x`` or `` X`` suffixes work
  too), or Vicon Nexus' export (``Trajectories``, the rate, the label row, ``Frame,Sub
  Frame,X,Y,Z...``, the units row, data).  Empty cells are missing.

Labels keep their subject prefix (``Daphnee:STYLr``); :attr:`Trajectories.names` drops it.
Frame numbers: ``first_frame`` is the file's number of its first sample (C3D files count
from 1); row ``k`` of ``points`` is at ``k / fps`` seconds after the first sample.
"""

from __future__ import annotations

import io
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import TrajectoryError

__all__ = ["Trajectories", "TrajectoryError", "UNIT_METRES", "read_trajectories", "read_c3d", "read_trc"]

#: Metres per unit of every length unit the readers convert between.
UNIT_METRES = {"mm": 1e-3, "cm": 1e-2, "dm": 1e-1, "m": 1.0, "in": 0.0254, "ft": 0.3048}


@dataclass(frozen=True, eq=False)
class Trajectories:
    """Labelled marker trajectories at a constant rate.

    Attributes
    ----------
    labels : tuple of str
        Marker labels as in the file, subject prefix included (``"Daphnee:STYLr"``).
    points : np.ndarray [shape=(T, K, 3), dtype=float64]
        Positions in ``units``; NaN where the marker was not seen.  Read-only.
    fps : float
        Samples per second.
    first_frame : int
        The file's frame number of row 0 (C3D: 1-based, usually 1).
    units : str
        Length unit of ``points`` (a key of :data:`UNIT_METRES`).
    source : str
        File name, for messages.
    warnings : tuple of str
        Oddities met while reading (a file cut short, an unstated unit).
    """

    labels: tuple
    points: np.ndarray
    fps: float
    first_frame: int = 1
    units: str = "mm"
    source: str = "<markers>"
    warnings: tuple = ()

    def __post_init__(self):
        pts = np.array(self.points, dtype=np.float64)
        labels = tuple(str(s) for s in self.labels)
        if pts.ndim != 3 or pts.shape[2] != 3 or pts.shape[1] != len(labels):
            raise ValueError(f"points must have shape (T, {len(labels)}, 3), got {pts.shape}")
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be positive, got {self.fps}")
        pts.setflags(write=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "fps", float(self.fps))
        object.__setattr__(self, "first_frame", int(self.first_frame))
        object.__setattr__(self, "warnings", tuple(self.warnings))

    @property
    def n_frames(self) -> int:
        return self.points.shape[0]

    @property
    def n_markers(self) -> int:
        return self.points.shape[1]

    @property
    def names(self) -> tuple:
        """Labels without their subject prefix (the part after the last ``:``)."""
        return tuple(s.rsplit(":", 1)[-1] for s in self.labels)

    @property
    def missing(self) -> np.ndarray:
        """``(T, K)`` bool: True where a marker was not seen."""
        return np.isnan(self.points).any(axis=2)

    def index(self, name: str) -> int | None:
        """Column of a marker by full label or by name without subject prefix (case-insensitive)."""
        key = name.lower()
        for k, s in enumerate(self.labels):
            if s.lower() == key:
                return k
        for k, s in enumerate(self.names):
            if s.lower() == key:
                return k
        return None

    def to_units(self, units: str) -> "Trajectories":
        """The same trajectories in another length unit."""
        if units == self.units:
            return self
        for u in (units, self.units):
            if u not in UNIT_METRES:
                raise TrajectoryError(f"{self.source}: unknown length unit {u!r} (known: {', '.join(UNIT_METRES)})")
        return replace(self, points=self.points * (UNIT_METRES[self.units] / UNIT_METRES[units]), units=units)

    def __repr__(self) -> str:
        return (f"Trajectories({self.source!r}, {self.n_markers} markers x {self.n_frames} frames @ {self.fps:g} Hz, "
                f"{self.units}, first frame {self.first_frame}, {100 * self.missing.mean():.1f}% missing)")


# ---------------------------------------------------------------- reading

def read_trajectories(path, *, units: str | None = "mm", fps: float | None = None) -> Trajectories:
    """Read a marker file by its extension (``.c3d``, ``.trc``, ``.csv``).

    Parameters
    ----------
    path : str or Path
    units : str or None
        Length unit of the result (``"mm"`` by default); None keeps the file's.
    fps : float, optional
        Rate of a CSV without a time column (ignored for C3D and TRC, which state theirs).

    Raises
    ------
    TrajectoryError
        Unknown extension, unreadable or malformed file (one line naming the file).
    """
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".c3d":
        return read_c3d(p, units=units)
    if ext == ".trc":
        return read_trc(p, units=units)
    if ext in (".csv", ".txt"):
        from .trajectory_csv import read_csv

        return read_csv(p, units=units, fps=fps)
    raise TrajectoryError(f"{p}: unknown marker file type {ext or '(no extension)'!r}; use .c3d, .trc or .csv")


def _finish(traj: Trajectories, units: str | None) -> Trajectories:
    if units is None:
        return traj
    if traj.units not in UNIT_METRES:
        raise TrajectoryError(f"{traj.source}: unknown length unit {traj.units!r} (known: {', '.join(UNIT_METRES)})")
    return traj.to_units(units)


def _open_bytes(p: Path) -> bytes:
    try:
        return p.read_bytes()
    except FileNotFoundError:
        raise TrajectoryError(f"{p}: marker file not found") from None
    except IsADirectoryError:
        raise TrajectoryError(f"{p}: is a directory, not a marker file") from None
    except OSError as e:
        raise TrajectoryError(f"{p}: cannot read ({e.strerror or e})") from None


def _c3d_module():
    try:
        import c3d
    except ImportError:
        raise TrajectoryError("reading C3D files needs the 'c3d' package: pip install 'splicer[c3d]'") from None
    return c3d


def read_c3d(path, *, units: str | None = "mm") -> Trajectories:
    """Read the 3-D points of a C3D file (analog channels are ignored).

    Missing samples (negative residual, or all three coordinates exactly 0) become NaN.

    Raises
    ------
    TrajectoryError
        Not a C3D file, damaged, or without points.
    """
    c3d = _c3d_module()
    p = Path(path)
    data = _open_bytes(p)
    notes = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            reader = c3d.Reader(io.BytesIO(data))
            labels = [str(s).strip() for s in reader.point_labels]
            rate = float(reader.point_rate)
            first = int(reader.first_frame)
            expected = int(reader.last_frame) - first + 1
            frames = [pts[:, :4].copy() for _, pts, _ in
                      reader.read_frames(copy=False, analog_transform=False, check_nan=False)]
            unit_param = reader.get("POINT:UNITS")
            unit = unit_param.string_value.strip() if unit_param is not None else ""
        except Exception as e:  # the library raises struct.error, AssertionError, ValueError... on damage
            msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise TrajectoryError(f"{p}: not a readable C3D file ({msg})") from None
    for w in caught:
        text = str(w.message).strip().splitlines()[0]
        if "No analog data" in text or "end of file" in text:
            continue  # a file cut short is reported below with the frame counts
        notes.append(f"{p.name}: {text}")
    if not labels:
        raise TrajectoryError(f"{p}: the C3D file has no 3-D points (POINT:USED is 0)")
    if not frames:
        raise TrajectoryError(f"{p}: the C3D file has no frames")
    if len(frames) < expected:
        notes.append(f"{p.name}: the file ends after {len(frames)} of its {expected} frames")
    arr = np.stack(frames).astype(np.float64)
    if arr.shape[1] != len(labels):
        labels = (labels + [f"M{k:03d}" for k in range(len(labels), arr.shape[1])])[:arr.shape[1]]
    pts = arr[:, :, :3]
    bad = (arr[:, :, 3] < 0) | np.all(pts == 0.0, axis=2) | ~np.isfinite(pts).all(axis=2)
    pts[bad] = np.nan
    if not unit:
        notes.append(f"{p.name}: no POINT:UNITS; taken as mm")
        unit = "mm"
    if not (np.isfinite(rate) and rate > 0):
        raise TrajectoryError(f"{p}: the C3D point rate is {rate}; expected a positive rate")
    return _finish(Trajectories(tuple(labels), pts, rate, first, unit.lower(), str(p), tuple(notes)), units)


def _read_text(p: Path) -> str:
    data = _open_bytes(p)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _number(s: str, what: str) -> float:
    s = s.strip()
    if s == "" or s.lower() in ("nan", "-nan", "null", "na"):
        return np.nan
    try:
        return float(s)
    except ValueError:
        raise TrajectoryError(f"{what}: expected a number, got {s!r}") from None


def read_trc(path, *, units: str | None = "mm") -> Trajectories:
    """Read a TRC marker file (tab-separated; ``DataRate``, ``Units``, ``Frame#``, ``Time``).

    Raises
    ------
    TrajectoryError
        Missing header lines, a short row or a non-number, naming the line.
    """
    p = Path(path)
    lines = _read_text(p).splitlines()

    def split(line):
        return line.split("\t") if "\t" in line else line.split()

    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise TrajectoryError(f"{p}, line 1: not a TRC file (expected 'PathFileType' and four header lines)")
    keys = [k.strip() for k in split(lines[1])]
    vals = [v.strip() for v in split(lines[2])]
    meta = dict(zip(keys, vals))
    for need in ("DataRate", "NumMarkers", "Units"):
        if need not in meta:
            raise TrajectoryError(f"{p}, line 2: TRC header lacks {need!r} (found: {', '.join(keys)})")
    rate = _number(meta["DataRate"], f"{p}, line 3: DataRate")
    n_mk = int(_number(meta["NumMarkers"], f"{p}, line 3: NumMarkers"))
    names_row = split(lines[3])
    if len(names_row) < 2 or names_row[0].strip().lower() not in ("frame#", "frame"):
        raise TrajectoryError(f"{p}, line 4: expected 'Frame#  Time  <marker>...'")
    labels = [s.strip() for s in names_row[2:] if s.strip()]
    if len(labels) != n_mk:
        raise TrajectoryError(f"{p}, line 4: {len(labels)} marker names but NumMarkers is {n_mk}")
    rows, frame_numbers = [], []
    for ln, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        f = split(line)
        if len(f) < 2 + 3 * n_mk:
            f = f + [""] * (2 + 3 * n_mk - len(f))  # trailing missing markers may be cut off
        frame_numbers.append(_number(f[0], f"{p}, line {ln}: frame"))
        rows.append([_number(v, f"{p}, line {ln}, column {c + 3}") for c, v in enumerate(f[2:2 + 3 * n_mk])])
    if not rows:
        raise TrajectoryError(f"{p}: the TRC file has no data rows")
    pts = np.array(rows, dtype=np.float64).reshape(len(rows), n_mk, 3)
    pts[np.isnan(pts).any(axis=2)] = np.nan
    first = int(frame_numbers[0]) if np.isfinite(frame_numbers[0]) else 1
    notes = []
    if "NumFrames" in meta and meta["NumFrames"].isdigit() and int(meta["NumFrames"]) != len(rows):
        notes.append(f"{p.name}: NumFrames says {meta['NumFrames']} but the file has {len(rows)} rows")
    return _finish(Trajectories(tuple(labels), pts, rate, first, meta["Units"].strip().lower(), str(p),
                                tuple(notes)), units)
