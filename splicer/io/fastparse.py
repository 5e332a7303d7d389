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
infinite) and anything else are errors.

Formatting (:func:`format_motion_block`)
-----------------------------------------
Each value ``v`` is written with a fixed number of decimals ``d`` as the integer
``k = rint(v * 10**d)`` printed with a decimal point (trailing zeros optionally trimmed).
For any ``v`` that has at most ``d`` decimals (a value read from such a file), the text is
the shortest one of ``'%.{d}f' % v`` and reads back to exactly ``v``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["ParseError", "parse_motion_block", "count_rows", "format_motion_block"]

_POW10 = np.array([10.0 ** k for k in range(23)])  # exactly representable: 1e0 .. 1e22
_MANT_MAX = 1 << 53
_FALLBACK_CAP = 4096

# kernel status codes
_DONE, _BAD_TOKEN, _BAD_COUNT, _FALLBACK_FULL, _ROWS_FULL = 0, 1, 2, 3, 4


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
        ``"token"`` (not a number), ``"nonfinite"`` (nan/inf) or ``"count"`` (too few or
        too many values in the row).
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
        if self.kind == "nonfinite":
            return f"value {self.column} of frame {self.row} is not a finite number: {self.token!r}"
        return f"value {self.column} of frame {self.row}: expected a number, found {self.token!r}"


@njit(cache=True)
def _is_space(c):
    return c == 32 or c == 9 or c == 11 or c == 12 or c == 13


@njit(cache=True)
def _parse_kernel(buf, pos, line, row, C, out, fb, max_rows, pow10):
    """Parse from byte ``pos`` (at a line start).  Returns (status, pos, line, row, n_fb, err_pos, err_end, err_col).

    ``out`` [shape=(R, C)] receives rows ``row ..``; ``fb``
    [shape=(F, 5)] receives (start, end, row, col, line) of tokens left to Python's float.
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
                    return _BAD_COUNT, pos, row_line, row, nfb, pos, pos, col
                row += 1
                col = 0
            if pos >= n:
                return _DONE, pos, line, row, nfb, 0, 0, 0
            pos += 1
            line += 1
            if row >= max_rows:
                return _ROWS_FULL, pos, line, row, nfb, 0, 0, 0
            continue
        if col == 0:
            row_line = line
            if nfb >= F - C:  # room for a whole row of fallbacks
                return _FALLBACK_FULL, pos, line, row, nfb, 0, 0, 0
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
            return _BAD_TOKEN, pos, line, row, nfb, start, end, col + 1
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
    if isinstance(n_channels, bool) or not isinstance(n_channels, (int, np.integer)) or n_channels < 1:
        raise ValueError(f"n_channels must be a whole number >= 1, not {n_channels!r}")
    u8 = _as_u8(buf)
    C = int(n_channels)
    if max_rows is None:  # an estimate (line breaks); grown below if lone-CR lines make it short
        cap = 1 + sum(int(np.count_nonzero(u8[i:i + (1 << 22)] == 10)) for i in range(0, len(u8), 1 << 22))
    else:
        cap = max(int(max_rows), 0)
    out = np.empty((cap, C), dtype=np.float64)
    fb = np.empty((max(_FALLBACK_CAP, 4 * C), 5), dtype=np.int64)
    pos, line, row = 0, int(first_line), 0
    error = None
    while row < cap or max_rows is None:
        if row >= cap:  # more rows than line feeds (lone CR line ends): grow
            cap = 2 * cap + 16
            grown = np.empty((cap, C), dtype=np.float64)
            grown[:row] = out[:row]
            out = grown
        status, pos, line, row, nfb, e0, e1, ecol = _parse_kernel(u8, pos, line, row, C, out, fb, cap, _POW10)
        bad = None
        for s, e, r, c, ln in fb[:nfb]:  # tokens outside the exact fast path
            v = float(u8[s:e].tobytes())
            out[r, c] = v
            if bad is None and not math.isfinite(v):  # e.g. 1e999: well formed but infinite
                bad = ParseError(int(ln), int(r), int(c) + 1, "nonfinite", u8[s:e].tobytes().decode("latin-1"), C)
        if bad is not None:
            error, row = bad, bad.row
            break
        if status == _BAD_TOKEN:
            tok = u8[e0:e1].tobytes().decode("latin-1")
            error = ParseError(line, row, int(ecol), "nonfinite" if _nonfinite(tok) else "token", tok, C)
            break
        if status == _BAD_COUNT:
            error = ParseError(line, row, int(ecol), "count", "", C)
            break
        if status == _DONE:
            break
        # _FALLBACK_FULL: resume at the row start; _ROWS_FULL: stop, or grow when counting
    values = out[:row]
    if row < 0.9 * out.shape[0]:
        values = values.copy()  # do not keep a much larger buffer alive
    return values, error


# ---------------------------------------------------------------------------------------
# formatting
# ---------------------------------------------------------------------------------------
_PAIRS = np.frombuffer("".join(f"{i:02d}" for i in range(100)).encode(), dtype=np.uint8).copy()
_P10U = np.array([10 ** k for k in range(20)], dtype=np.uint64)


@njit(cache=True)
def _format_kernel(values, decimals, scale, trim, out, pairs, p10):
    """Write rows of ``values`` into ``out``; returns bytes used, or -(flat index + 1) of a value to do in Python.

    Each value is the integer ``rint(v * scale)`` written right to left two digits at a time
    (``pairs``: "00".."99"), with the point ``decimals`` digits from the right.
    """
    T, C = values.shape
    p = 0
    ten = np.uint64(10)
    hundred = np.uint64(100)
    for t in range(T):
        for c in range(C):
            v = values[t, c]
            x = v * scale
            if not (abs(x) < 9.0e15):  # beyond the exact integer range (or nan/inf)
                return -(t * C + c + 1)
            if math.copysign(1.0, v) < 0.0:  # sign bit, as '%f' writes it (-0.0 -> "-0")
                out[p] = 45
                p += 1
            ik = np.uint64(abs(np.rint(x)))
            nd = decimals + 1  # digits printed: at least one before the point
            while nd < 19 and ik >= p10[nd]:
                nd += 1
            frac = decimals
            if trim:
                while frac > 0:
                    q = ik // ten
                    if ik - q * ten != 0:
                        break
                    ik = q
                    frac -= 1
                    nd -= 1
            e = p + nd + (1 if frac > 0 else 0)
            w = e
            k = 0
            while k + 2 <= frac:
                q = ik // hundred
                r = ik - q * hundred
                w -= 2
                out[w] = pairs[2 * r]
                out[w + 1] = pairs[2 * r + 1]
                ik = q
                k += 2
            if k < frac:
                q = ik // ten
                w -= 1
                out[w] = np.uint8(48 + (ik - q * ten))
                ik = q
            if frac > 0:
                w -= 1
                out[w] = 46
            while w - p >= 2:
                q = ik // hundred
                r = ik - q * hundred
                w -= 2
                out[w] = pairs[2 * r]
                out[w + 1] = pairs[2 * r + 1]
                ik = q
            if w > p:
                out[p] = np.uint8(48 + ik % ten)
            out[e] = 32 if c < C - 1 else 10
            p = e + 1
    return p


def format_motion_block(values: np.ndarray, decimals: int = 6, *, trim: bool = True,
                        chunk_rows: int = 4096):
    """The rows of ``values`` as BVH motion text, one frame per line.

    Parameters
    ----------
    values : np.ndarray [shape=(T, C)]
        Finite channel values (degrees, file units).
    decimals : int
        Digits after the point, 0..15.
    trim : bool
        Drop trailing zeros after the point (and the point itself when nothing follows):
        ``12.5`` rather than ``12.500000``; the value read back is the same.
    chunk_rows : int
        Rows formatted per chunk (memory stays about ``chunk_rows * C * 24`` bytes).

    Yields
    ------
    bytes
        Consecutive pieces of the text (ASCII, ``\\n`` line ends); join or write them.
        Without trimming each value reads ``'%.{decimals}f' % v`` (Python's text) for
        ``|v| * 10**decimals < 9e15``; values beyond go through Python's formatting.

    Raises
    ------
    ValueError
        A non-finite value (BVH cannot store it), or ``decimals`` out of range.
    """
    values = np.ascontiguousarray(values, dtype=np.float64)
    if values.ndim != 2:
        raise ValueError(f"values must be 2-d (frames, channels), got shape {values.shape}")
    if isinstance(decimals, bool) or not isinstance(decimals, (int, np.integer)) or not 0 <= decimals <= 15:
        raise ValueError(f"decimals must be a whole number in 0..15, not {decimals!r}")
    if not np.isfinite(values).all():
        t, c = np.argwhere(~np.isfinite(values))[0]
        raise ValueError(f"value at frame {t}, column {c} is not finite ({values[t, c]})")
    T, C = values.shape
    if C == 0:
        if T:
            yield b"\n" * T
        return
    scale = 10.0 ** decimals
    buf = np.empty(min(chunk_rows, max(T, 1)) * C * (22 + decimals), dtype=np.uint8)
    for t0 in range(0, T, chunk_rows):
        block = values[t0:t0 + chunk_rows]
        while len(block):
            p = _format_kernel(block, decimals, scale, trim, buf, _PAIRS, _P10U)
            if p >= 0:
                yield buf[:p].tobytes()
                break
            idx = -p - 1  # a value too large for the integer path: this row in Python
            r = idx // C
            if r:
                p2 = _format_kernel(block[:r], decimals, scale, trim, buf, _PAIRS, _P10U)
                yield buf[:p2].tobytes()
            yield (" ".join(_py_format(v, decimals, trim) for v in block[r]) + "\n").encode("ascii")
            block = block[r + 1:]


def _py_format(v: float, decimals: int, trim: bool) -> str:
    s = f"{v:.{decimals}f}"
    if trim and "." in s:
        s = s.rstrip("0").rstrip(".")
    return s
