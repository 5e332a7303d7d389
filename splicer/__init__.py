"""splicer: splice separately captured finger motion onto full-body motion capture.

The method is Majkowska, Zordan & Faloutsos, "Automatic Splicing for Hand and Body
Animations" (SCA 2006): virtual markers on wrist, forearm and hand; a banded DTW pass with a
derivative-sign phase metric; a narrower pass with a palm-angle metric; user pins; merge;
BVH out.

Public API
----------
Motions
    :func:`read_bvh`, :func:`write_bvh`, :class:`Motion`, :class:`Skeleton`.
The splice
    :func:`splice` (the whole job), :class:`SpliceOptions`, :class:`SpliceResult`,
    :class:`SideResult`, :class:`Report` (``to_dict()``, ``to_json()``), :class:`SideReport`.
Stages (each returns a typed result; :func:`splice` composes them)
    :func:`load_inputs` -> :func:`find_rig` -> :func:`condition_hands` -> :func:`side_markers`
    -> :func:`align_side` (both sides: :func:`align_pair`, with one noise decision,
    :func:`phase_smoothing`) -> :func:`time_map` -> on the sides' :class:`SideResult`:
    :func:`cross_check` -> :func:`trend_time_maps` -> :func:`refine_time_maps` -> (a noisy pair:
    :func:`position_second_opinion`) -> :func:`estimate_risk` ->
    :func:`uncover_unsure_edges` -> :func:`mark_coverage_edges` -> :func:`transfer_side` -> :func:`check_fingers` -> :func:`build_report`.
The constraints file
    :func:`read_config`, :func:`parse_config`, :class:`SpliceConfig`, :class:`Pin`.
Skeletons
    :func:`find_roles`.
Optical markers
    :func:`read_trajectories` (C3D, TRC, CSV), :func:`write_c3d`, :class:`Trajectories`;
    ``splice(..., hands_markers=..., body_markers=...)``; :func:`align_marker_files` (alignment only).
Errors
    :class:`SplicerError` (base), :class:`BVHError`, :class:`RoleError`,
    :class:`ConstraintError`, :class:`BandError`, :class:`TrajectoryError`; warnings: :class:`SplicerWarning`.

Example
-------
>>> import splicer
>>> result = splicer.splice("body.bvh", "hands.bvh", config="sync.yaml")    # doctest: +SKIP
>>> splicer.write_bvh(result.motion, "out.bvh")                               # doctest: +SKIP

Importing :mod:`splicer` is cheap: the modules behind each name (numba kernels, bvhio,
YAML) load on first use.
"""

from __future__ import annotations

import importlib

__version__ = "0.38.0"

from .errors import (BandError, BVHError, ConstraintError, RoleError, SplicerError,  # noqa: E402
                     SplicerWarning, TrajectoryError)

# numpy, numba, bvhio, YAML, matplotlib: none is imported by ``import splicer`` (``splice --help``
# and ``--version`` stay as cheap as Python itself; tests/test_cli_imports.py checks it).

#: public name -> module that defines it (loaded on first access)
_LAZY = {
    "Motion": ".model.motion", "Skeleton": ".model.motion",
    "read_bvh": ".io.bvh", "write_bvh": ".io.bvh",
    "splice": ".pipeline", "SpliceResult": ".pipeline", "SideResult": ".pipeline",
    "load_inputs": ".pipeline", "find_rig": ".pipeline", "condition_hands": ".pipeline", "check_fingers": ".pipeline", "side_markers": ".pipeline", "align_side": ".pipeline",
    "align_pair": ".pipeline", "phase_smoothing": ".pipeline",
    "time_map": ".pipeline", "transfer_side": ".pipeline", "build_report": ".pipeline",
    "cross_check": ".pipeline", "estimate_risk": ".pipeline", "mark_coverage_edges": ".pipeline",
    "trend_time_maps": ".pipeline", "refine_time_maps": ".pipeline", "uncover_unsure_edges": ".pipeline",
    "position_second_opinion": ".pipeline",
    "SpliceOptions": ".options",
    "Report": ".report", "SideReport": ".report",
    "read_config": ".io.config", "parse_config": ".io.config", "SpliceConfig": ".io.config",
    "Pin": ".align.frames",
    "find_roles": ".rig.roles",
    "Trajectories": ".io.trajectories", "read_trajectories": ".io.trajectories", "write_c3d": ".io.trajectory_writers",
    "align_marker_files": ".markers_cli",
}

__all__ = ["BVHError", "BandError", "ConstraintError", "Motion", "RoleError", "Skeleton", "SplicerError",
           "SplicerWarning", "TrajectoryError", "__version__", *sorted(_LAZY)]


def __getattr__(name):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'splicer' has no attribute {name!r}")
    value = getattr(importlib.import_module(mod, __name__), name)
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
