"""Read and write a motion by its file extension: ``.fbx`` through Blender's importer and
exporter (:mod:`splicer.fbx`, needs ``splicer[blender]``), anything else as BVH (splicer's
own reader and writer, which also read pipes)."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import SplicerError
from ..model.motion import Motion

__all__ = ["read_motion", "write_motion"]


#: Marker-trajectory files (:mod:`splicer.io.trajectories`): never a take's motion.
_MARKER_SUFFIXES = (".c3d", ".trc")


def _is_fbx(path) -> bool:
    """``.fbx`` (any case) goes to Blender; everything else is BVH, as before (also pipes such as
    ``/dev/stdin`` or ``<(...)``, which have no suffix)."""
    return Path(path).suffix.lower() == ".fbx"


def read_motion(path: str | os.PathLike, *, progress=None) -> Motion:
    """A BVH or FBX file as a :class:`~splicer.model.Motion`: ``.fbx`` (any case) is read by
    Blender (:func:`splicer.fbx.read_fbx`), any other path as BVH (:func:`splicer.bvh.read_bvh`).
    ``progress(fraction)``: a BVH's reading and parsing as they go (:func:`~splicer.bvh.read_bvh`).

    Raises
    ------
    SplicerError
        What the reader raises (for FBX without ``bpy``: one line saying how to install it); a
        marker file (``.c3d``, ``.trc``) given as a take: one line saying where it goes instead.
    """
    suffix = Path(path).suffix.lower()
    if suffix in _MARKER_SUFFIXES:
        raise SplicerError(f"{path}: optical markers ({suffix[1:].upper()}), not a motion: give the take's BVH or FBX "
                           "here, and the markers with --hands-markers or --body-markers (hands_markers= or "
                           "body_markers= in Python)")
    if _is_fbx(path):
        from .fbx import read_fbx

        return read_fbx(path)
    from .bvh import read_bvh

    return read_bvh(path, progress=progress)


def write_motion(motion: Motion, path: str | os.PathLike, *, progress=None) -> None:
    """Write ``motion`` as FBX (a ``.fbx`` path) or else BVH, atomically (inside a
    :class:`~splicer.atomic.Transaction`: staged with the other outputs).  ``progress(fraction)``
    as the frames are written (BVH; Blender writes an FBX in one call)."""
    if _is_fbx(path):
        from .fbx import write_fbx

        return write_fbx(motion, path)
    from .bvh import write_bvh

    return write_bvh(motion, path, progress=progress)
