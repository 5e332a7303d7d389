"""Reading BVH files (:func:`read_bvh`).

1. The bytes are read once (:func:`splicer.io.limits.read_input`); nothing else the size of
   the file is ever made.  A NUL byte means a binary file; the line count is checked.
2. Only the header is decoded (UTF-8, BOM allowed, else Latin-1; ``\\r\\n`` and lone ``\\r``
   endings normalised so line numbers match an editor's): the first 64 KiB up to a line
   break, more when the hierarchy goes on.  :func:`splicer.io.bvh_header.scan_header`
   checks it line by line, then bvhio (the parser of record) parses the hierarchy and is
   cross-checked (:func:`splicer.io.bvh_header.cross_check_with_bvhio`).
3. The motion rows are parsed in place from the bytes by the compiled parser of
   :mod:`splicer.io.fastparse` (each value equals ``float(token)`` bit for bit; compiled on
   first use and cached); a block under :data:`FAST_MIN_BYTES` (8 MiB) by ``np.loadtxt``
   instead, which gives the same values and the same errors without importing numba (unless
   the compiled parser is already loaded, as in ``splice-server``: then it reads every block).  Not
   by bvhio, which builds one ``Pose`` per joint and frame and
   converts angles to quaternions, losing the raw values (e.g. rotations stored in 0..360).
   A malformed value, a row with the wrong number of values, a truncated block: one
   :class:`~splicer.errors.BVHError` with the file's 1-based line.
"""

from __future__ import annotations

import os
import re
import sys
import warnings
from pathlib import Path

import numpy as np

from . import limits
from .bvh_header import NeedMoreText, Scan, cross_check_with_bvhio, number, scan_header
from ..errors import BVHError, SplicerWarning
from ..model.motion import Motion, Skeleton, _Owned

__all__ = ["read_bvh"]

_HEADER_CHUNK = 1 << 16
# Motion blocks from this size on go to the compiled parser; smaller ones to numpy, which
# is faster than importing numba (0.3-0.7 s) and loading or compiling its kernel.
FAST_MIN_BYTES = 8 << 20
#: Once the compiled parser is loaded in this process (a large file read before, ``splice-server``),
#: it reads small blocks too: about 3x faster than ``np.loadtxt``, the same values and messages.
PREFER_LOADED = True
_LINE_BREAK = re.compile(rb"\r\n|\r|\n")
#: :func:`read_bvh`'s progress: the share of the bar for reading the bytes (parsing them takes about twice as long)
READ_SHARE = 0.3


def read_bvh(path: str | os.PathLike, *, progress=None) -> Motion:
    """Read a BVH file.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.bvh`` file.  It is only read, never modified.
    progress : callable, optional
        ``progress(fraction)`` as the file is read (up to :data:`READ_SHARE`) and its motion
        block parsed (the rest), by bytes: a 1 GB take takes seconds.

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
    Memory: the file's bytes plus the (T, C) float64 array.
    """
    spath = str(path)
    tick = (lambda f: None) if progress is None else progress
    data = _read_bytes(Path(path), spath, lambda f: tick(READ_SHARE * f))
    scan, data_offset = _header(data, spath)
    if limits.is_regular_file(path):  # a pipe cannot be read a second time
        cross_check_with_bvhio(spath, scan)
    values = _parse_motion(data, data_offset, scan, spath, lambda f: tick(READ_SHARE + (1 - READ_SHARE) * f))
    del data
    tick(1.0)
    skeleton = Skeleton(
        names=tuple(scan.names),
        parents=np.array(scan.parents, dtype=np.int64),
        offsets=np.array(scan.offsets, dtype=np.float64).reshape(-1, 3),
        channels=tuple(scan.channels),
        end_sites=np.array(scan.end_sites, dtype=np.float64).reshape(-1, 3),
    )
    return Motion(skeleton, _Owned(values), scan.frame_time, source=spath)  # taken over, not copied


def _read_bytes(p: Path, spath: str, progress=None):
    """The file's bytes (bytes or bytearray), checked for size, line count, emptiness and NUL."""
    data = limits.read_input(p, max_bytes=limits.MAX_BVH_BYTES, what="BVH file",
                             error=lambda message: BVHError(message, path=spath), progress=progress)
    n_cr = data.count(b"\r") if data.find(b"\r") >= 0 else 0  # a fast scan when there is none
    n_lines = max(data.count(b"\n"), n_cr) + 1  # CR-only files too
    if n_lines > limits.MAX_LINES:
        raise BVHError(f"the file has {n_lines:,} lines, more than the limit of {limits.MAX_LINES:,}", path=spath)
    if not _has_text(data):
        raise BVHError("the file is empty, expected a BVH file starting with HIERARCHY", path=spath, line=1)
    if isinstance(data, bytes):  # small inputs: one array type for the compiled parser
        data = bytearray(data)
    nul = data.find(b"\x00")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        raise BVHError("binary data (NUL byte): expected a text BVH file", path=spath, line=line)
    return data


def _has_text(data) -> bool:
    """Whether ``data`` has a byte other than ASCII whitespace (without copying it)."""
    view = memoryview(data)
    for i in range(0, len(data), 1 << 20):
        if bytes(view[i:i + (1 << 20)]).strip(b" \t\n\r\x0b\x0c"):
            return True
    return False


def _decode_lines(raw) -> list[str]:
    try:
        text = bytes(raw).decode("utf-8-sig")
    except UnicodeDecodeError:
        # Not UTF-8: Latin-1 decodes any byte; garbage then fails the HIERARCHY check.
        text = bytes(raw).decode("latin-1")
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def _header(data, path: str) -> tuple[Scan, int]:
    """Scan the header; returns the scan and the byte offset of the line after ``Frame Time:``.

    Only a prefix of the file ending at a line break is decoded, doubled until the header
    ends inside it; an error (or the whole file) is reported exactly as a scan of the whole
    file would report it, since the scan reads lines in order.
    """
    n = len(data)
    size = _HEADER_CHUNK
    while True:
        cut = n
        if size < n:
            cut = max(data.rfind(b"\n", 0, size), data.rfind(b"\r", 0, size)) + 1
            if cut and data[cut - 1] == 13 and cut < n and data[cut] == 10:
                cut += 1  # keep \r\n together
            if cut <= 0:
                cut = n if size * 2 >= n else 0
        if cut > 0:
            complete = cut >= n
            lines = _decode_lines(memoryview(data)[:cut])
            if not complete:
                lines = lines[:-1]  # the prefix ends with a line break: no partial last line
            try:
                scan = scan_header(lines, path, complete=complete)
            except NeedMoreText:
                pass
            else:
                if scan.data_start == 0:
                    return scan, 0
                breaks = _LINE_BREAK.finditer(memoryview(data)[:cut])
                for k, m in enumerate(breaks, 1):
                    if k == scan.data_start:
                        return scan, m.end()
                return scan, cut  # the Frame Time line is the last line, without a line break
        size *= 2


def _parse_motion(data, offset: int, scan: Scan, path: str, progress=None) -> np.ndarray:
    """The first ``scan.frames`` data rows as a (T, C) float64 array (``progress``: :func:`read_bvh`'s)."""
    T, C = scan.frames, scan.n_channels
    first_line = scan.data_start + 1
    block = memoryview(data)[offset:]
    if C == 0:
        return _parse_no_channels(bytes(block), scan, path)
    if len(block) < FAST_MIN_BYTES and not (PREFER_LOADED and "splicer.io.fastparse" in sys.modules):
        return _parse_small(bytes(block), scan, path)
    from .fastparse import count_rows, parse_block  # compiled on first use

    res = parse_block(block, C, first_line, max_rows=T, max_abs=limits.MAX_ABS_VALUE, progress=progress)
    err = res.error
    if err is not None:
        if err.kind == "count":
            raise BVHError(err.message, path=path, line=err.line)
        token = err.token.encode("latin-1")
        try:
            token = token.decode("utf-8")
        except UnicodeDecodeError:
            token = token.decode("latin-1")
        number(token, f"value {err.column} of the frame row", path, err.line)  # raises the message
        raise BVHError(f"value {err.column} of the frame row: {err.message}", path=path, line=err.line)
    rows = res.values.shape[0]
    if rows < T:
        last = res.last_row_line if rows else scan.data_start
        raise BVHError(f"Frames: says {T} but the data section has only {rows} rows "
                       f"(the file ends after line {last}): the file is truncated",
                       path=path, line=scan.frames_line)
    extra = count_rows(block[res.end:]) if res.end < len(block) else 0
    if extra:
        warnings.warn(f"{path}: the data section has {T + extra} rows but Frames: (line {scan.frames_line}) "
                      f"says {T}; the first {T} rows are used", SplicerWarning, stacklevel=3)
    return res.values


def _parse_small(block: bytes, scan: Scan, path: str) -> np.ndarray:
    """:func:`_parse_motion` for a small block, with numpy: the same values and errors."""
    T, C = scan.frames, scan.n_channels
    rows: list[str] = []
    row_lines: list[int] = []
    extra = 0
    for k, text in enumerate(_decode_lines(block)):
        if text.strip():
            if len(rows) < T:
                rows.append(text)
                row_lines.append(scan.data_start + 1 + k)
            else:
                extra += 1
    values = None
    if all(r.isascii() and len(r.split()) == C for r in rows):
        try:
            values = np.loadtxt(rows, dtype=np.float64, comments=None, ndmin=2) if rows else np.zeros((0, C))
        except ValueError:
            values = None
    if values is None or values.shape != (len(rows), C) or not (np.abs(values) <= limits.MAX_ABS_VALUE).all():
        for k, r in enumerate(rows):  # the first problem in file order, as the compiled parser reports it
            tokens = r.split()
            for col, t in enumerate(tokens):
                number(t, f"value {col + 1} of the frame row", path, row_lines[k])
            if len(tokens) != C:
                raise BVHError(f"expected {C} values per frame (one per channel), found {len(tokens)}",
                               path=path, line=row_lines[k])
        raise BVHError("the motion data could not be parsed as numbers", path=path, line=row_lines[0])
    if len(rows) < T:
        last = row_lines[-1] if row_lines else scan.data_start
        raise BVHError(f"Frames: says {T} but the data section has only {len(rows)} rows "
                       f"(the file ends after line {last}): the file is truncated",
                       path=path, line=scan.frames_line)
    if extra:
        warnings.warn(f"{path}: the data section has {T + extra} rows but Frames: (line {scan.frames_line}) "
                      f"says {T}; the first {T} rows are used", SplicerWarning, stacklevel=4)
    return values


def _parse_no_channels(block: bytes, scan: Scan, path: str) -> np.ndarray:
    """A hierarchy without channels: every non-blank data line is an error (no values expected)."""
    T = scan.frames
    lines = _decode_lines(block)
    rows = [(k, ln) for k, ln in enumerate(lines) if ln.strip()]
    if len(rows) < T:
        last = scan.data_start + 1 + rows[-1][0] if rows else scan.data_start
        raise BVHError(f"Frames: says {T} but the data section has only {len(rows)} rows "
                       f"(the file ends after line {last}): the file is truncated",
                       path=path, line=scan.frames_line)
    if T:
        k, ln = rows[0]
        raise BVHError(f"expected 0 values per frame (one per channel), found {len(ln.split())}",
                       path=path, line=scan.data_start + 1 + k)
    if rows:
        warnings.warn(f"{path}: the data section has {len(rows)} rows but Frames: (line {scan.frames_line}) "
                      f"says 0; the first 0 rows are used", SplicerWarning, stacklevel=4)
    return np.zeros((T, 0))
