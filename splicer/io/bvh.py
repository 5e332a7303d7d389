"""Reading and writing BVH motion-capture files (the only module that imports ``bvhio``).

Reading (:func:`read_bvh`)
--------------------------
1. The bytes are read once and decoded (UTF-8, BOM allowed, else Latin-1); ``\\r\\n`` and
   lone ``\\r`` endings are normalised so line numbers match an editor's.  A NUL byte means
   a binary file.
2. A light line scanner (:func:`_scan_header`) checks HIERARCHY and the MOTION header and
   collects joint names, offsets, channels and End Sites in float64.  It runs first because
   on malformed input bvhio loops forever (its ``parseLine`` re-reads ``""`` at end of file,
   so an empty or truncated file never returns), raises ``IndexError``/``SyntaxError``
   without a usable line, or silently accepts bad input (unknown channel names, a negative
   Frame Time).  Each complaint is a :class:`~splicer.errors.BVHError` naming the file, the
   1-based line and what was expected.
3. bvhio, the parser of record, then parses the hierarchy (``loadKeyFrames=False``); its
   joints, offsets, channels, End Sites, frame count and frame time are cross-checked
   against the scan.  The scan's values are returned: bvhio keeps offsets in ``glm.vec3``
   (float32) and only the first word of a joint name.
4. The motion rows are parsed with numpy (``np.loadtxt``), not bvhio: bvhio builds one
   ``Pose`` per joint and frame (0.58 s for the 2065-frame, 75-joint ZEGGS take, against
   about 0.1 s here) and converts angles to quaternions, losing the raw values (e.g.
   rotations stored in 0..360).

Writing (:func:`write_bvh`)
---------------------------
The text is produced here, not by bvhio's writer, which adds an End Site to every leaf
(even where the input had none), drops the End Site of a joint with children, recomputes
every channel from quaternions (0..360 angles come back in -180..180, channel sets are
re-chosen) and formats value by value in Python.  The motion block is formatted with
``np.savetxt`` (``%.12g``: typical files are reproduced digit for digit, computed values to
about 1e-12 relative).  The text goes to a temporary file in the destination directory,
moved into place with ``os.replace`` (:mod:`splicer.atomic`): a failed write leaves no
partial file and never clobbers an existing one.  Inside an open
:class:`splicer.atomic.Transaction` (the ``splice`` command) the file only appears when every
output of the transaction is complete.
"""

from __future__ import annotations

import io
import math
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import limits
from .atomic import write_atomic
from ..errors import BVHError, SplicerWarning
from .limits import shorten
from ..model.motion import Motion, Skeleton

__all__ = ["read_bvh", "write_bvh"]

_CHANNEL_NAMES = {
    c.lower(): c
    for c in ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
}
_MOTION_FMT = "%.12g"
_FLOAT_FMT = "{:.12g}"


# ---------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------
def read_bvh(path: str | os.PathLike) -> Motion:
    """Read a BVH file.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.bvh`` file.  It is only read, never modified.

    Returns
    -------
    Motion
        ``channels`` [shape=(T, C), dtype=float64] holds the values exactly as in the file
        (degrees, file units), ``T`` being the header's ``Frames:``; ``frame_time`` is in
        seconds; ``source`` is ``str(path)``.  Channel names are normalised to the
        ``"Xrotation"`` spelling; joint names are kept verbatim (e.g. ``"mixamorig:Hips"``).

    Raises
    ------
    BVHError
        The file cannot be read or is not a well-formed BVH file.  The message names the
        file and, where one applies, the 1-based line.

    Warns
    -----
    SplicerWarning
        The data section has more rows than ``Frames:`` says; the first ``Frames:`` rows
        are used.

    Notes
    -----
    Accepted: any rotation order per joint, position channels on any joint, joints with or
    without End Site, CRLF / CR / LF line endings, tabs or spaces, blank lines, lower-case
    channel names.  A joint name may contain single spaces (written back the same way).
    """
    spath = str(path)
    lines = _read_lines(Path(path), spath)
    scan = _scan_header(lines, spath)
    if limits.is_regular_file(path):  # a pipe cannot be read a second time
        _cross_check_with_bvhio(spath, scan)
    values = _parse_motion(lines, scan, spath)
    skeleton = Skeleton(
        names=tuple(scan.names),
        parents=np.array(scan.parents, dtype=np.int64),
        offsets=np.array(scan.offsets, dtype=np.float64).reshape(-1, 3),
        channels=tuple(scan.channels),
        end_sites=np.array(scan.end_sites, dtype=np.float64).reshape(-1, 3),
    )
    return Motion(skeleton, values, scan.frame_time, source=spath)


def _read_lines(p: Path, spath: str) -> list[str]:
    """The file's lines, line endings removed (index i is line i + 1)."""
    data = limits.read_input(p, max_bytes=limits.MAX_BVH_BYTES, what="BVH file",
                             error=lambda message: BVHError(message, path=spath))
    n_lines = max(data.count(b"\n"), data.count(b"\r")) + 1  # CR-only files too
    if n_lines > limits.MAX_LINES:
        raise BVHError(f"the file has {n_lines:,} lines, more than the limit of {limits.MAX_LINES:,}", path=spath)
    if not data.strip():
        raise BVHError("the file is empty, expected a BVH file starting with HIERARCHY", path=spath, line=1)
    nul = data.find(b"\x00")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        raise BVHError("binary data (NUL byte): expected a text BVH file", path=spath, line=line)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        # Not UTF-8: Latin-1 decodes any byte; garbage then fails the HIERARCHY check.
        text = data.decode("latin-1")
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


@dataclass
class _Scan:
    """What the line scanner found in the header (lists grow joint by joint)."""

    names: list[str] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)
    offsets: list[list[float]] = field(default_factory=list)
    channels: list[tuple[str, ...]] = field(default_factory=list)
    end_sites: list[list[float]] = field(default_factory=list)
    name_lines: list[int] = field(default_factory=list)
    frames: int = 0
    frames_line: int = 0
    frame_time: float = 0.0
    data_start: int = 0  # 0-based index of the first line after "Frame Time:"

    @property
    def n_channels(self) -> int:
        return sum(len(c) for c in self.channels)


def _show(tokens: list[str]) -> str:
    s = " ".join(tokens)
    return repr(s if len(s) <= 40 else s[:37] + "...")


class _Lines:
    """Iterator over non-blank lines yielding (1-based line number, tokens)."""

    def __init__(self, lines: list[str], path: str):
        self.lines = lines
        self.i = 0
        self.path = path

    def next(self, expected: str) -> tuple[int, list[str]]:
        while self.i < len(self.lines):
            tokens = self.lines[self.i].split()
            self.i += 1
            if tokens:
                return self.i, tokens
        last = max((k + 1 for k, t in enumerate(self.lines) if t.strip()), default=1)
        raise BVHError(f"the file ends here (unexpected end of file), expected {expected}",
                       path=self.path, line=last)


def _number(tok: str, what: str, path: str, line: int) -> float:
    """A finite number of at most ``limits.MAX_ABS_VALUE`` in magnitude, written in ASCII."""
    v = math.nan
    if tok.isascii() and "_" not in tok and len(tok) <= 64:
        try:
            v = float(tok)
        except ValueError:
            pass
    if not math.isfinite(v):
        raise BVHError(f"{what}: expected a number, found {shorten(tok)}", path=path, line=line)
    if abs(v) > limits.MAX_ABS_VALUE:
        raise BVHError(f"{what}: {shorten(tok)} is too large (the limit is {limits.MAX_ABS_VALUE:g} in "
                       "magnitude)", path=path, line=line)
    return v


def _scan_header(lines: list[str], path: str) -> _Scan:
    """Check HIERARCHY and the MOTION header line by line; collect the skeleton."""
    src = _Lines(lines, path)
    scan = _Scan()
    ln, tok = src.next("HIERARCHY")
    if tok != ["HIERARCHY"]:
        raise BVHError(f"expected HIERARCHY, found {_show(tok)}", path=path, line=ln)
    ln, tok = src.next("ROOT <name>")
    if tok[0] != "ROOT":
        raise BVHError(f"expected ROOT <name>, found {_show(tok)}", path=path, line=ln)
    _scan_joint(src, scan, tok, ln, parent=-1, depth=1)
    ln, tok = src.next("MOTION")
    if tok == ["}"]:
        raise BVHError("unbalanced braces: '}' without a matching '{' (expected MOTION)", path=path, line=ln)
    if tok[0] in ("ROOT", "JOINT"):
        raise BVHError(f"expected MOTION after the root joint, found {_show(tok)} (only one ROOT is supported)",
                       path=path, line=ln)
    if tok != ["MOTION"]:
        raise BVHError(f"expected MOTION, found {_show(tok)}", path=path, line=ln)

    ln, tok = src.next("Frames: <count>")
    joined = " ".join(tok)
    if not joined.startswith("Frames:"):
        raise BVHError(f"expected Frames: <count>, found {_show(tok)}", path=path, line=ln)
    count = joined[len("Frames:"):].strip()
    if not (count.isascii() and count.isdigit()):
        raise BVHError(f"Frames: expected a non-negative whole number, found {shorten(count)}", path=path, line=ln)
    if len(count.lstrip("0")) > 9 or int(count) > limits.MAX_FRAMES:
        raise BVHError(f"Frames: {shorten(count)} is more than the limit of {limits.MAX_FRAMES:,} frames",
                       path=path, line=ln)
    scan.frames, scan.frames_line = int(count), ln
    if scan.frames * scan.n_channels > limits.MAX_VALUES:
        raise BVHError(f"Frames: {scan.frames:,} frames of {scan.n_channels} channels is more than the limit of "
                       f"{limits.MAX_VALUES:,} values", path=path, line=ln)

    ln, tok = src.next("Frame Time: <seconds>")
    joined = " ".join(tok)
    if not (len(tok) >= 2 and tok[0] == "Frame" and tok[1].startswith("Time:")):
        raise BVHError(f"expected Frame Time: <seconds>, found {_show(tok)}", path=path, line=ln)
    value = joined[len("Frame "):].strip()[len("Time:"):].strip()
    ft = _number(value, "Frame Time", path, ln) if value else math.nan
    if not ft > 0:
        raise BVHError(f"Frame Time: expected a positive number of seconds, found {shorten(value)}",
                       path=path, line=ln)
    lo, hi = limits.FRAME_TIME_RANGE
    if not lo <= ft <= hi:
        raise BVHError(f"Frame Time: {shorten(value)} seconds is outside the accepted range {lo:g} .. {hi:g} s "
                       f"({1 / hi:g} to {1 / lo:g} frames per second)", path=path, line=ln)
    scan.frame_time = ft
    scan.data_start = src.i
    return scan


def _scan_offset(src: _Lines, what: str) -> list[float]:
    ln, tok = src.next(f"OFFSET x y z of {what}")
    if tok[0] != "OFFSET":
        raise BVHError(f"expected OFFSET x y z of {what}, found {_show(tok)}", path=src.path, line=ln)
    if len(tok) != 4:
        raise BVHError(f"OFFSET of {what}: expected 3 numbers, found {len(tok) - 1}", path=src.path, line=ln)
    return [_number(t, f"OFFSET of {what}", src.path, ln) for t in tok[1:]]


def _scan_joint(src: _Lines, scan: _Scan, head: list[str], head_line: int, parent: int, depth: int) -> None:
    """Scan one ROOT/JOINT block whose header line ``head`` was just read (recursive)."""
    path = src.path
    if len(head) < 2:
        raise BVHError(f"{head[0]}: expected a joint name", path=path, line=head_line)
    name = " ".join(head[1:])
    if len(name) > limits.MAX_NAME:
        raise BVHError(f"joint name {shorten(name)} is {len(name):,} characters long (the limit is "
                       f"{limits.MAX_NAME})", path=path, line=head_line)
    if not name.isprintable():
        raise BVHError(f"joint name {shorten(name)} contains an invisible or control character",
                       path=path, line=head_line)
    if len(scan.names) >= limits.MAX_JOINTS:
        raise BVHError(f"more than {limits.MAX_JOINTS} joints", path=path, line=head_line)
    if depth > limits.MAX_DEPTH:
        raise BVHError(f"joints nested more than {limits.MAX_DEPTH} deep", path=path, line=head_line)
    if name in scan.names:
        first = scan.name_lines[scan.names.index(name)]
        raise BVHError(f"duplicate joint name {shorten(name)} (first defined at line {first})",
                       path=path, line=head_line)
    j = len(scan.names)
    scan.names.append(name)
    scan.name_lines.append(head_line)
    scan.parents.append(parent)
    scan.end_sites.append([math.nan] * 3)
    what = f"joint {shorten(name)}"

    ln, tok = src.next(f"'{{' opening {what}")
    if tok != ["{"]:
        raise BVHError(f"expected '{{' opening {what}, found {_show(tok)}", path=path, line=ln)
    scan.offsets.append(_scan_offset(src, what))

    ln, tok = src.next(f"CHANNELS <n> <names> of {what}")
    if tok[0] != "CHANNELS":
        raise BVHError(f"expected CHANNELS <n> <names> of {what}, found {_show(tok)}", path=path, line=ln)
    if len(tok) < 2 or not (tok[1].isascii() and tok[1].isdigit() and len(tok[1]) <= 3):
        raise BVHError(f"CHANNELS of {what}: expected a channel count (0 to 6), found {_show(tok[1:2])}",
                       path=path, line=ln)
    n = int(tok[1])
    if len(tok) - 2 != n:
        raise BVHError(f"CHANNELS of {what}: the count says {n} but {len(tok) - 2} names follow",
                       path=path, line=ln)
    chans = []
    for c in tok[2:]:
        norm = _CHANNEL_NAMES.get(c.lower())
        if norm is None:
            raise BVHError(f"CHANNELS of {what}: unknown channel {shorten(c)}, expected one of "
                           + ", ".join(_CHANNEL_NAMES.values()), path=path, line=ln)
        if norm in chans:
            raise BVHError(f"CHANNELS of {what}: channel {norm} appears twice", path=path, line=ln)
        chans.append(norm)
    scan.channels.append(tuple(chans))

    while True:
        ln, tok = src.next(f"JOINT, End Site or '}}' closing {what} (opened at line {head_line})")
        if tok[0] == "JOINT":
            _scan_joint(src, scan, tok, ln, parent=j, depth=depth + 1)
        elif tok == ["End", "Site"]:
            if not math.isnan(scan.end_sites[j][0]):
                raise BVHError(f"{what} has a second End Site", path=path, line=ln)
            ln2, tok2 = src.next(f"'{{' opening the End Site of {what}")
            if tok2 != ["{"]:
                raise BVHError(f"expected '{{' opening the End Site of {what}, found {_show(tok2)}",
                               path=path, line=ln2)
            scan.end_sites[j] = _scan_offset(src, f"the End Site of {what}")
            ln2, tok2 = src.next(f"'}}' closing the End Site of {what}")
            if tok2 != ["}"]:
                raise BVHError(f"expected '}}' closing the End Site of {what} (opened at line {ln}), "
                               f"found {_show(tok2)}", path=path, line=ln2)
        elif tok == ["}"]:
            return
        else:
            raise BVHError(f"expected JOINT, End Site or '}}' closing {what} (opened at line {head_line}), "
                           f"found {_show(tok)}", path=path, line=ln)


def _bvhio():
    """bvhio, imported on first use (about 0.1 s, mostly PyGLM).

    PyGLM >= 2.8 warns (PendingDeprecationWarning) about bvhio's ``import glm``; that is
    bvhio's business, not the user's, so the warning is silenced for that import only.
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*import glm.*", category=PendingDeprecationWarning)
        import bvhio
    return bvhio


def _cross_check_with_bvhio(path: str, scan: _Scan) -> None:
    """Parse the hierarchy with bvhio (the parser of record) and compare it with the scan.

    Only called after the scan accepted the whole header, so bvhio cannot run into the end
    of the file (where its ``parseLine`` would loop forever).
    """
    try:
        bvh = _bvhio().readAsBvh(path, loadKeyFrames=False)
    except Exception:
        # bvhio is stricter than the BVH files in the wild in two ways the scan accepts:
        # joint names containing spaces (it keeps the first word and then fails or
        # mis-names) and files not in the locale's encoding.  The scan, which has checked
        # every line, is used alone for such a file.
        return
    layout = [entry[0] for entry in bvh.Root.layout()]
    problems = []
    if [j.Name for j in layout] != [n.split()[0] for n in scan.names]:
        problems.append("joint names differ")
    else:
        for k, j in enumerate(layout):
            name = scan.names[k]
            if tuple(_CHANNEL_NAMES.get(c.lower(), c) for c in j.Channels) != scan.channels[k]:
                problems.append(f"channels of joint {name!r} differ")
            off = np.array([j.Offset.x, j.Offset.y, j.Offset.z], dtype=np.float64)
            if not np.allclose(off, scan.offsets[k], rtol=1e-6, atol=1e-6):
                problems.append(f"offset of joint {name!r} differs")
            es = np.array(scan.end_sites[k])
            if not np.isnan(es[0]):
                bes = np.array([j.EndSite.x, j.EndSite.y, j.EndSite.z], dtype=np.float64)
                if not np.allclose(bes, es, rtol=1e-6, atol=1e-6):
                    problems.append(f"End Site of joint {name!r} differs")
            parent = scan.parents[k]
            if parent >= 0 and j not in layout[parent].Children:
                problems.append(f"parent of joint {name!r} differs")
        if bvh.FrameCount != scan.frames:
            problems.append("Frames: differs")
        if not math.isclose(bvh.FrameTime, scan.frame_time, rel_tol=1e-12):
            problems.append("Frame Time differs")
    if problems:
        raise BVHError("bvhio and the line scanner disagree on the hierarchy ("
                       + "; ".join(problems[:3]) + "); please report this file", path=path)


def _parse_motion(lines: list[str], scan: _Scan, path: str) -> np.ndarray:
    """The first ``scan.frames`` data rows as a (T, C) float64 array."""
    T, C = scan.frames, scan.n_channels
    body = lines[scan.data_start:]
    rows: list[str] = []
    row_lines: list[int] = []
    extra = 0
    for k, text in enumerate(body):
        if text.strip():
            if len(rows) < T:
                rows.append(text)
                row_lines.append(scan.data_start + k + 1)
            else:
                extra += 1
    if len(rows) < T:
        last = row_lines[-1] if row_lines else scan.data_start
        raise BVHError(f"Frames: says {T} but the data section has only {len(rows)} rows "
                       f"(the file ends after line {last}): the file is truncated",
                       path=path, line=scan.frames_line)
    if extra:
        warnings.warn(f"{path}: the data section has {T + extra} rows but Frames: (line {scan.frames_line}) "
                      f"says {T}; the first {T} rows are used", SplicerWarning, stacklevel=3)
    if T == 0:
        return np.zeros((0, C))
    counts = np.fromiter((len(r.split()) for r in rows), dtype=np.int64, count=T)
    bad = np.flatnonzero(counts != C)
    if bad.size:
        k = int(bad[0])
        raise BVHError(f"expected {C} values per frame (one per channel), found {counts[k]}",
                       path=path, line=row_lines[k])
    if C == 0:
        return np.zeros((T, 0))
    values = None
    if all(r.isascii() for r in rows):
        try:
            values = np.loadtxt(rows, dtype=np.float64, comments=None, ndmin=2)
        except ValueError:
            values = None
    if values is not None and values.shape == (T, C):
        bad = ~(np.abs(values) <= limits.MAX_ABS_VALUE)  # NaN, inf and absurd values
        if not bad.any():
            return values
        k, col = (int(v) for v in np.argwhere(bad)[0])
        _number(rows[k].split()[col], f"value {col + 1} of the frame row", path, row_lines[k])
    for k, r in enumerate(rows):  # locate the offending value for the message (error path only)
        for col, t in enumerate(r.split()):
            _number(t, f"value {col + 1} of the frame row", path, row_lines[k])
    raise BVHError("the motion data could not be parsed as numbers", path=path, line=row_lines[0])


# ---------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------
def write_bvh(motion: Motion, path: str | os.PathLike) -> None:
    """Write ``motion`` as a standard BVH file, atomically.

    Parameters
    ----------
    motion : Motion
        ``channels`` [shape=(T, C)] are written as they are (degrees, file units),
        ``frame_time`` in seconds.
    path : str or os.PathLike
        Destination.  Its directory must exist.  An existing file is replaced only once the
        new one is complete.

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
    values use ``%.12g``, Frame Time the shortest text that reads back exactly.
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
        if motion.n_frames and motion.skeleton.n_channels:
            buf = io.StringIO()
            np.savetxt(buf, motion.channels, fmt=_MOTION_FMT, delimiter=" ")
            f.write(buf.getvalue().encode("ascii"))
        elif motion.n_frames:
            f.write(b"\n" * motion.n_frames)

    write_atomic(dest, write, what="file", error=lambda message: BVHError(message, path=spath))


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
