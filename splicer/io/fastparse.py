"""The BVH MOTION block near the floor: a compiled number parser and formatter.

Parsing (:func:`parse_motion_block`)
-------------------------------------
One pass over the raw bytes (no decoding, no line splitting, no per-token Python object).
Tokens are runs of bytes other than space, tab, ``\\v``, ``\\f``, ``\\r`` and ``\\n``; rows
are lines (``\\n``, ``\\r\\n`` or a lone ``\\r``); blank lines are skipped.  A token is
``[+-] digits [. digits] [(e|E) [+-] digits]`` with at least one mantissa digit.

Exactness: the significant mantissa digits are accumulated in an int64 and the decimal
exponent is applied by one multiplication or division by an exactly representable power
of ten (Clinger's fast path: mantissa <= 2**53 and ``|exponent| <= 22``).  Both operands are
exact doubles and IEEE arithmetic rounds the single operation correctly, so the result is
``float(token)`` bit for bit.  Tokens outside the fast path (more than 15-16 significant
digits, huge exponents) are handed to Python's ``float`` afterwards; in the real captures of
``../shared/motions`` that is 3,930 of 1.77 million values (0.2 %, all in the ZEGGS take,
e.g. ``-1.4024509999999992``).  ``nan``/``inf`` (and ``1e999``, which ``float`` makes
infinite), values beyond an optional magnitude limit and anything else are errors.

The formatters (:func:`format_motion_block`, :func:`format_motion_block_g`) are in
:mod:`splicer.io.fastformat` and re-exported here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["ParseError", "ParsedBlock", "parse_block", "parse_motion_block", "count_rows", "format_motion_block",
           "format_motion_block_g"]

_POW10 = np.array([10.0 ** k for k in range(23)])  # exactly representable: 1e0 .. 1e22
_MANT_MAX = 1 << 53
_FALLBACK_CAP = 4096

# kernel status codes
_DONE, _BAD_TOKEN, _BAD_COUNT, _FALLBACK_FULL, _ROWS_FULL, _BAD_RANGE = 0, 1, 2, 3, 4, 5
#: :func:`parse_block` parses about this many bytes of text per call of its kernel (and reports progress)
PROGRESS_BYTES = 16 << 20


@dataclass(frozen=True)
class ParseError:
    """The first problem in a motion block.

    Attributes
    ----------
    line : int
        1-based line number in the file (``first_line`` + lines before the problem).
    row : int
        0-based index of the data row (frame) among the non-blank rows.
    column : int
        1-based index of the value within the row: the malformed value, or for a wrong
        count the number of values found.
    kind : str
        ``"token"`` (not a number), ``"nonfinite"`` (nan/inf), ``"range"`` (beyond the
        ``max_abs`` limit) or ``"count"`` (too few or too many values in the row).
    token : str
        The offending text (``""`` for a count error).
    expected : int
        Values per row expected (the channel count).
    """

    line: int
    row: int
    column: int
    kind: str
    token: str
    expected: int

    @property
    def message(self) -> str:
        """One line for a :class:`~splicer.errors.BVHError` (the caller adds file and line)."""
        if self.kind == "count":
            return f"expected {self.expected} values per frame (one per channel), found {self.column}"
        if self.kind == "range":
            return f"value {self.column} of frame {self.row}: {self.token!r} is too large in magnitude"
        if self.kind == "nonfinite":
            return f"value {self.column} of frame {self.row} is not a finite number: {self.token!r}"
        return f"value {self.column} of frame {self.row}: expected a number, found {self.token!r}"


@njit(cache=True)
def _is_space(c):
    return c == 32 or c == 9 or c == 11 or c == 12 or c == 13


@njit(cache=True)
def _parse_kernel(buf, pos, line, row, C, out, fb, max_rows, pow10, max_abs):
    """Parse from byte ``pos`` (at a line start).

    Returns (status, pos, line, row, n_fb, err_start, err_end, err_col, last_row_line).
    ``out`` [shape=(R, C)] receives rows ``row ..``; ``fb`` [shape=(F, 5)] receives
    (start, end, row, col, line) of tokens left to Python's float; a value beyond
    ``max_abs`` in magnitude stops with ``_BAD_RANGE``.
    """
    n = buf.shape[0]
    nfb = 0
    F = fb.shape[0]
    col = 0  # values seen in the current row
    row_line = line
    while True:
        # skip separators within the line
        while pos < n:
            c = buf[pos]
            if c == 32 or c == 9 or c == 11 or c == 12 or (c == 13 and pos + 1 < n and buf[pos + 1] == 10):
                pos += 1
            else:
                break
        if pos >= n or buf[pos] == 10 or buf[pos] == 13:
            # end of a line: close the row (if any)
            if col > 0:
                if col != C:
                    return _BAD_COUNT, pos, row_line, row, nfb, pos, pos, col, row_line
                row += 1
                col = 0
            if pos >= n:
                return _DONE, pos, line, row, nfb, 0, 0, 0, row_line
            pos += 1
            line += 1
            if row >= max_rows:
                return _ROWS_FULL, pos, line, row, nfb, 0, 0, 0, row_line
            continue
        if col == 0:
            if nfb >= F - C:  # room for a whole row of fallbacks
                return _FALLBACK_FULL, pos, line, row, nfb, 0, 0, 0, row_line
            row_line = line
        # a token
        start = pos
        neg = False
        c = buf[pos]
        if c == 43 or c == 45:  # + -
            neg = c == 45
            pos += 1
        mant = 0
        dexp = 0
        digits = 0
        slow = False
        while pos < n:
            d = np.int64(buf[pos]) - 48
            if d < 0 or d > 9:
                break
            if mant < 100000000000000000:
                mant = mant * 10 + d
            else:
                slow = True
            digits += 1
            pos += 1
        if pos < n and buf[pos] == 46:  # .
            pos += 1
            while pos < n:
                d = np.int64(buf[pos]) - 48
                if d < 0 or d > 9:
                    break
                if mant < 100000000000000000:
                    mant = mant * 10 + d
                    dexp -= 1
                else:
                    slow = True
                digits += 1
                pos += 1
        ok = digits > 0
        if ok and pos < n and (buf[pos] == 101 or buf[pos] == 69):  # e E
            pos += 1
            eneg = False
            if pos < n and (buf[pos] == 43 or buf[pos] == 45):
                eneg = buf[pos] == 45
                pos += 1
            ed = 0
            e = 0
            while pos < n and 48 <= buf[pos] <= 57:
                if e < 100000:
                    e = e * 10 + (buf[pos] - 48)
                ed += 1
                pos += 1
            if ed == 0:
                ok = False
            dexp += -e if eneg else e
        if ok and pos < n and not (_is_space(buf[pos]) or buf[pos] == 10):
            ok = False
        if not ok:
            end = pos
            while end < n and not (_is_space(buf[end]) or buf[end] == 10):
                end += 1
            return _BAD_TOKEN, pos, line, row, nfb, start, end, col + 1, row_line
        if col < C:
            if slow or mant > _MANT_MAX or dexp > 22 or dexp < -22:
                if mant == 0:
                    out[row, col] = -0.0 if neg else 0.0
                else:
                    fb[nfb, 0] = start
                    fb[nfb, 1] = pos
                    fb[nfb, 2] = row
                    fb[nfb, 3] = col
                    fb[nfb, 4] = line
                    nfb += 1
            else:
                v = float(mant)
                if dexp >= 0:
                    v = v * pow10[dexp]
                else:
                    v = v / pow10[-dexp]
                if v > max_abs:
                    return _BAD_RANGE, pos, line, row, nfb, start, pos, col + 1, row_line
                out[row, col] = -v if neg else v
        col += 1


@njit(cache=True)
def _count_rows_kernel(buf):
    """Non-blank lines (``\\n``, ``\\r\\n`` or ``\\r`` endings) and line breaks."""
    n = buf.shape[0]
    rows = 0
    breaks = 0
    blank = True
    for i in range(n):
        c = buf[i]
        if c == 10 or (c == 13 and (i + 1 >= n or buf[i + 1] != 10)):
            breaks += 1
            if not blank:
                rows += 1
            blank = True
        elif not _is_space(c):
            blank = False
    if not blank:
        rows += 1
    return rows, breaks


def _as_u8(buf) -> np.ndarray:
    if isinstance(buf, np.ndarray):
        if buf.dtype != np.uint8 or buf.ndim != 1:
            raise TypeError(f"expected a 1-d uint8 array, got {buf.dtype} with shape {buf.shape}")
        return buf
    return np.frombuffer(buf, dtype=np.uint8)  # bytes, bytearray, memoryview, mmap: no copy


def count_rows(buf) -> int:
    """Number of non-blank lines in ``buf`` (bytes-like or 1-d uint8 array)."""
    return int(_count_rows_kernel(_as_u8(buf))[0])


def _nonfinite(token: str) -> bool:
    t = token.lower().lstrip("+-")
    return t in ("nan", "inf", "infinity")


@dataclass(frozen=True)
class ParsedBlock:
    """What :func:`parse_block` found.

    Attributes
    ----------
    values : np.ndarray [shape=(rows, C), dtype=float64]
        The rows parsed before the first problem.
    error : ParseError or None
        The first problem, in file order.
    end : int
        Byte offset in ``buf`` where parsing stopped: ``len(buf)``, or after the line break
        of row ``max_rows``, or at the problem.
    last_row_line : int
        1-based line of the last complete row (0 when there is none).
    """

    values: np.ndarray
    error: ParseError | None
    end: int
    last_row_line: int


def parse_motion_block(buf, n_channels: int, first_line: int, *, max_rows: int | None = None
                       ) -> tuple[np.ndarray, ParseError | None]:
    """Parse the data rows of a BVH MOTION block.

    Parameters
    ----------
    buf : bytes-like or np.ndarray [shape=(nbytes,), dtype=uint8]
        The bytes after the ``Frame Time:`` line (ASCII numbers, whitespace, line breaks).
        Not copied (a ``bytes``, ``mmap`` or memoryview is read in place).
    n_channels : int
        Values per row (the channel count of the hierarchy), >= 1.
    first_line : int
        1-based line number of the first line of ``buf`` in the file, for messages.
    max_rows : int, optional
        Stop after this many rows (the ``Frames:`` count); the rest of ``buf`` is not read
        (see :func:`count_rows` to count it).

    Returns
    -------
    values : np.ndarray [shape=(rows, n_channels), dtype=float64]
        The rows parsed before the first problem (all non-blank rows when there is none,
        at most ``max_rows``); each value equals ``float(token)`` exactly.
    error : ParseError or None
        The first malformed token (``nan``/``inf`` included) or row with a wrong number
        of values, in file order, with its line number.
    """
    res = parse_block(buf, n_channels, first_line, max_rows=max_rows)
    return res.values, res.error


def parse_block(buf, n_channels: int, first_line: int, *, max_rows: int | None = None,
                max_abs: float = math.inf, progress=None) -> ParsedBlock:
    """:func:`parse_motion_block` with a magnitude limit, also telling where it stopped.

    ``max_abs``: a value with ``abs(value) > max_abs`` is an error of kind ``"range"``.
    ``progress``: called as ``progress(fraction of buf's bytes parsed)`` after each
    :data:`PROGRESS_BYTES` or so (a 1 GB hands take parses for seconds); the rows are parsed
    in that many pieces either way, with the same values.
    """
    if isinstance(n_channels, bool) or not isinstance(n_channels, (int, np.integer)) or n_channels < 1:
        raise ValueError(f"n_channels must be a whole number >= 1, not {n_channels!r}")
    if not max_abs > 0:
        raise ValueError(f"max_abs must be positive, not {max_abs!r}")
    u8 = _as_u8(buf)
    C = int(n_channels)
    max_abs = float(max_abs)
    if max_rows is None:  # an estimate (line breaks); grown below if lone-CR lines make it short
        cap = 1 + sum(int(np.count_nonzero(u8[i:i + (1 << 22)] == 10)) for i in range(0, len(u8), 1 << 22))
    else:
        cap = max(int(max_rows), 0)
    out = np.empty((cap, C), dtype=np.float64)
    fb = np.empty((max(_FALLBACK_CAP, 4 * C), 5), dtype=np.int64)
    pos, line, row = 0, int(first_line), 0
    last_row_line = 0
    error = None
    # rows per call of the kernel: about PROGRESS_BYTES of text (it resumes at a row start)
    piece = max(1, int(cap * PROGRESS_BYTES / max(len(u8), 1)))
    while row < cap or max_rows is None:
        if row >= cap:  # more rows than line feeds (lone CR line ends): grow
            cap = 2 * cap + 16
            grown = np.empty((cap, C), dtype=np.float64)
            grown[:row] = out[:row]
            out = grown
        status, pos, line, row2, nfb, e0, e1, ecol, rl = _parse_kernel(u8, pos, line, row, C, out, fb,
                                                                       min(cap, row + piece), _POW10, max_abs)
        if row2 > row:  # rows completed in this call: rl is the line of the last one
            last_row_line = int(rl)
        row = row2
        bad = None
        for s, e, r, c, ln in fb[:nfb]:  # tokens outside the exact fast path
            v = float(u8[s:e].tobytes())
            out[r, c] = v
            if bad is None and not (math.isfinite(v) and abs(v) <= max_abs):  # 1e999: well formed, infinite
                kind = "nonfinite" if not math.isfinite(v) else "range"
                bad = ParseError(int(ln), int(r), int(c) + 1, kind, u8[s:e].tobytes().decode("latin-1"), C)
                bad_pos = int(s)
        if bad is not None:
            error, row, pos = bad, bad.row, bad_pos
            break
        if status == _BAD_TOKEN or status == _BAD_RANGE:
            tok = u8[e0:e1].tobytes().decode("latin-1")
            kind = "range" if status == _BAD_RANGE else ("nonfinite" if _nonfinite(tok) else "token")
            error = ParseError(line, row, int(ecol), kind, tok, C)
            pos = int(e0)
            break
        if status == _BAD_COUNT:
            error = ParseError(line, row, int(ecol), "count", "", C)
            break
        if status == _DONE:
            break
        if progress is not None:
            progress(pos / len(u8))
        # _FALLBACK_FULL: resume at the row start; _ROWS_FULL: a piece done, or stop, or grow when counting
    values = out if row == out.shape[0] else out[:row]  # the array itself: a Motion takes it over uncopied
    if row < 0.9 * out.shape[0]:
        values = values.copy()  # do not keep a much larger buffer alive
    return ParsedBlock(values, error, int(pos), last_row_line)


from .fastformat import format_motion_block, format_motion_block_g  # noqa: E402  (re-exported)
