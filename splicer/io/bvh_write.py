"""Writing BVH files (:func:`write_bvh`).

The text is produced here, not by bvhio's writer, which adds an End Site to every leaf
(even where the input had none), drops the End Site of a joint with children, recomputes
every channel from quaternions (0..360 angles come back in -180..180, channel sets are
re-chosen) and formats value by value in Python.  The motion block is formatted as
``%.12g`` by :func:`splicer.io.fastformat.format_motion_block_g` (the same bytes as
``np.savetxt(fmt="%.12g")``, about 5x faster, written chunk by chunk so the text of the
whole file is never in memory; blocks under :data:`FAST_MIN_VALUES` values by
``np.savetxt`` itself, so a small file does not import numba): typical files are reproduced digit for digit, computed
values to about 1e-12 relative.  The text goes to a temporary file in the destination
directory, moved into place with ``os.replace`` (:mod:`splicer.io.atomic`): a failed write
leaves no partial file and never clobbers an existing one.  Inside an open
:class:`splicer.io.atomic.Transaction` (the ``splice`` command) the file only appears when
every output of the transaction is complete.
"""

from __future__ import annotations

import io
import os
import sys
from pathlib import Path

import numpy as np

from .atomic import write_atomic
from ..errors import BVHError
from ..model.motion import Motion

__all__ = ["write_bvh"]

_FLOAT_FMT = "{:.12g}"
# From this many values on the motion block goes to the compiled formatter; below, to
# np.savetxt (the same bytes), which is faster than importing numba and loading its kernel.
FAST_MIN_VALUES = 1_000_000
#: Once the compiled formatter is loaded in this process, it formats small blocks too (about 4x
#: faster than ``np.savetxt``, the same bytes).
PREFER_LOADED = True


def write_bvh(motion: Motion, path: str | os.PathLike, *, progress=None) -> None:
    """Write ``motion`` as a standard BVH file, atomically.

    Parameters
    ----------
    motion : Motion
        ``channels`` [shape=(T, C)] are written as they are (degrees, file units),
        ``frame_time`` in seconds.
    path : str or os.PathLike
        Destination.  Its directory must exist.  An existing file is replaced only once the
        new one is complete.
    progress : callable, optional
        ``progress(fraction)``: the share of frames written, after each piece of the motion
        block (4,096 frames for large blocks).

    Raises
    ------
    BVHError
        The motion cannot be written as BVH (non-finite values, a joint name with line
        breaks) or the file cannot be written; the message names ``path``.  No temporary
        file is left behind and an existing destination is untouched.

    Notes
    -----
    Joints are written in skeleton order with tab indentation; a joint gets an End Site
    block exactly when ``skeleton.end_sites`` is not NaN for it.  Offsets and channel
    values use ``%.12g`` (the motion block by the compiled formatter of
    :mod:`splicer.io.fastformat`, streamed in chunks of 4,096 frames), Frame Time the
    shortest text that reads back exactly.
    """
    spath = str(path)
    if not isinstance(motion, Motion):
        raise TypeError(f"write_bvh expects a Motion, got {type(motion).__name__}")
    text_header = _format_header(motion, spath)
    dest = Path(path)
    directory = dest.parent
    if dest.is_dir():
        raise BVHError("is a directory, cannot write a BVH file there", path=spath)
    if not directory.is_dir():
        raise BVHError(f"cannot write: directory {str(directory)!r} does not exist", path=spath)

    def write(f) -> None:
        f.write(text_header.encode("utf-8"))
        rows, total = 0, max(motion.n_frames, 1)
        for piece in _motion_text(motion.channels):
            f.write(piece)
            if progress is not None:
                rows += piece.count(b"\n")
                progress(min(rows / total, 1.0))

    write_atomic(dest, write, what="file", error=lambda message: BVHError(message, path=spath))


def _motion_text(values: np.ndarray):
    """The motion block as '%.12g' text, in pieces (compiled for large blocks, numpy for small)."""
    T, C = values.shape
    if C == 0:
        if T:
            yield b"\n" * T
    elif T * C >= FAST_MIN_VALUES or (PREFER_LOADED and "splicer.io.fastformat" in sys.modules):
        from .fastformat import format_motion_block_g  # numba: compiled on first use

        yield from format_motion_block_g(values)  # streamed, 4,096 frames at a time
    elif T:
        buf = io.BytesIO()
        np.savetxt(buf, values, fmt="%.12g", delimiter=" ")
        yield buf.getvalue()


def _format_header(motion: Motion, path: str) -> str:
    """HIERARCHY and the MOTION header as text (validates what BVH cannot represent)."""
    sk = motion.skeleton
    for name in sk.names:
        if not name or " ".join(name.split()) != name:
            raise BVHError(f"joint name {name!r} cannot be written to BVH (empty, or with line breaks, "
                           "tabs or leading/trailing/double spaces)", path=path)
    if not np.isfinite(motion.channels).all():
        t, c = np.argwhere(~np.isfinite(motion.channels))[0]
        j = int(np.searchsorted(sk.channel_offsets, c, side="right") - 1)
        raise BVHError(f"channel value is not finite at frame {t} (joint {sk.names[j]!r}, "
                       f"column {c}); BVH cannot store it", path=path)
    if not (np.isfinite(sk.offsets).all() and not np.isinf(sk.end_sites).any()):
        raise BVHError("skeleton offsets must be finite", path=path)

    out = ["HIERARCHY"]

    def vec(v) -> str:
        return " ".join(_FLOAT_FMT.format(float(x) + 0.0) for x in v)

    def emit(j: int, depth: int) -> None:
        ind = "\t" * depth
        out.append(f"{ind}{'ROOT' if sk.parents[j] < 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET {vec(sk.offsets[j])}")
        out.append(f"{ind}\tCHANNELS {len(sk.channels[j])}" + "".join(" " + c for c in sk.channels[j]))
        for k in sk.children[j]:
            emit(k, depth + 1)
        if not np.isnan(sk.end_sites[j]).any():
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET {vec(sk.end_sites[j])}")
            out.append(f"{ind}\t}}")
        out.append(f"{ind}}}")

    roots = [j for j in range(sk.n_joints) if sk.parents[j] < 0]
    if len(roots) != 1:
        raise BVHError(f"a BVH file has exactly one ROOT joint, the skeleton has {len(roots)}", path=path)
    # BVH lists joints depth first; the channel columns must follow the same order.
    order: list[int] = []
    stack = [roots[0]]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(sk.children[j]))
    if order != list(range(sk.n_joints)):
        raise BVHError("skeleton joints are not in depth-first (BVH) order; cannot write them", path=path)
    emit(roots[0], 0)
    out.append("MOTION")
    out.append(f"Frames: {motion.n_frames}")
    out.append(f"Frame Time: {motion.frame_time!r}")
    return "\n".join(out) + "\n"
