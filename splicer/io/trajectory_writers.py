"""Optical marker trajectories out: C3D and TRC, written atomically.

The readers and :class:`~splicer.io.trajectories.Trajectories` are in :mod:`splicer.io.trajectories`.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np

from ..errors import TrajectoryError
from .atomic import write_atomic
from .trajectories import UNIT_METRES, Trajectories, _c3d_module

__all__ = ["write_c3d", "write_trc"]


def _atomic_write(path: Path, write) -> None:
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise TrajectoryError(f"{path}: cannot write: folder {parent} does not exist")
    write_atomic(path, write, what="marker file", error=lambda message: TrajectoryError(f"{path}: {message}"))


def write_c3d(traj: Trajectories, path) -> None:
    """Write the trajectories as a C3D file (float points, no analogs), atomically.

    Missing samples are written with residual -1 (and coordinates 0), the C3D convention.
    """
    c3d = _c3d_module()
    p = Path(path)
    if traj.units not in UNIT_METRES:
        raise TrajectoryError(f"{p}: cannot write unit {traj.units!r}")
    w = c3d.Writer(point_rate=float(traj.fps), analog_rate=0.0, point_scale=-1.0, point_units=f"{traj.units:<4}")
    labels = [s[:30] for s in traj.labels]
    w.set_point_labels(labels)
    w.set_start_frame(max(1, traj.first_frame))
    miss = traj.missing
    empty = np.zeros((0, 0), np.float32)
    frames = []
    for t in range(traj.n_frames):
        pts = np.zeros((traj.n_markers, 5), np.float32)
        ok = ~miss[t]
        pts[ok, :3] = traj.points[t, ok]
        pts[~ok, 3] = -1.0
        frames.append((pts, empty))
    w.add_frames(frames)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="No analog data")
        _atomic_write(p, w.write)


def write_trc(traj: Trajectories, path) -> None:
    """Write the trajectories as a TRC file (tab-separated; missing samples as empty fields)."""
    p = Path(path)
    n, k = traj.n_frames, traj.n_markers
    out = io.StringIO()
    out.write(f"PathFileType\t4\t(X/Y/Z)\t{p.name}\n")
    out.write("DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n")
    out.write(f"{traj.fps:g}\t{traj.fps:g}\t{n}\t{k}\t{traj.units}\t{traj.fps:g}\t{traj.first_frame}\t{n}\n")
    out.write("Frame#\tTime\t" + "\t".join(f"{s}\t\t" for s in traj.labels).rstrip("\t") + "\n")
    out.write("\t\t" + "\t".join(f"X{i + 1}\tY{i + 1}\tZ{i + 1}" for i in range(k)) + "\n\n")
    for t in range(n):
        vals = ["" if np.isnan(v) else f"{v:.6f}" for v in traj.points[t].ravel()]
        out.write(f"{traj.first_frame + t}\t{t / traj.fps:.6f}\t" + "\t".join(vals) + "\n")
    _atomic_write(p, lambda f: f.write(out.getvalue().encode("utf-8")))
