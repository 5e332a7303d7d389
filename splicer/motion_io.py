"""Read and write a motion by its file extension: ``.bvh`` (splicer's own reader and writer)
or ``.fbx`` (Blender's importer and exporter, :mod:`splicer.fbx`, needs ``splicer[blender]``)."""

from __future__ import annotations

import os
from pathlib import Path

from .errors import SplicerError
from .model import Motion

__all__ = ["MOTION_SUFFIXES", "read_motion", "write_motion"]

MOTION_SUFFIXES = (".bvh", ".fbx")


def _kind(path, what: str) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in MOTION_SUFFIXES:
        raise SplicerError(f"{path}: cannot {what} a {suffix or 'suffix-less'} file; motions are "
                           f"{' or '.join(s[1:].upper() for s in MOTION_SUFFIXES)} ({', '.join(MOTION_SUFFIXES)})")
    return suffix


def read_motion(path: str | os.PathLike) -> Motion:
    """A BVH or FBX file as a :class:`~splicer.model.Motion`, chosen by the suffix (any case).

    Raises
    ------
    SplicerError
        An unknown suffix; otherwise what :func:`splicer.bvh.read_bvh` or
        :func:`splicer.fbx.read_fbx` raise (a missing ``bpy`` for FBX: one line saying how to install it).
    """
    if _kind(path, "read") == ".fbx":
        from .fbx import read_fbx

        return read_fbx(path)
    from .bvh import read_bvh

    return read_bvh(path)


def write_motion(motion: Motion, path: str | os.PathLike) -> None:
    """Write ``motion`` as BVH or FBX by the suffix of ``path``, atomically (inside a
    :class:`~splicer.atomic.Transaction`: staged with the other outputs)."""
    if _kind(path, "write") == ".fbx":
        from .fbx import write_fbx

        return write_fbx(motion, path)
    from .bvh import write_bvh

    return write_bvh(motion, path)
