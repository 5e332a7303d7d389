"""The BVH MOTION block written near the floor: compiled number formatters.

Fixed decimals (:func:`format_motion_block`)
--------------------------------------------
Each value ``v`` is written with a fixed number of decimals ``d`` as the integer
``k = rint(v * 10**d)`` printed with a decimal point (trailing zeros optionally trimmed).
For any ``v`` that has at most ``d`` decimals (a value read from such a file), the text is
the shortest one of ``'%.{d}f' % v`` and reads back to exactly ``v``.

Twelve significant digits (:func:`format_motion_block_g`, the BVH writer's format)
-----------------------------------------------------------------------------------
The text of ``'%.12g' % v`` (what ``np.savetxt(fmt="%.12g")`` wrote before), byte for byte.
For ``1e-11 <= |v| < 1e12`` the 12 digits are ``k = round(|v| * 10**s)`` with ``s = 11 - e``
(``e`` the decimal exponent) and ``10**s`` an exact double (``0 <= s <= 22``); the product
is computed exactly as the sum of two doubles (Dekker's TwoProduct, no fused multiply-add)
so ``k`` is rounded half to even on the exact value, as C's ``printf`` does.  Other
non-zero values (tiny or huge: rare in motion data) are formatted by Python beforehand and
copied in.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["format_motion_block", "format_motion_block_g"]

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


# ---------------------------------------------------------------------------------------
# '%.12g'
# ---------------------------------------------------------------------------------------
_G_LO, _G_HI = 1e-11, 1e12  # magnitudes formatted by the kernel; others by Python
_POW10 = np.array([10.0 ** k for k in range(23)])  # exact doubles


@njit(cache=True)
def _round_scaled(a, p):
    """``round_half_even(a * p)`` of the exact product, for doubles ``a``, ``p`` (no overflow)."""
    x = a * p
    c = 134217729.0  # 2**27 + 1: Dekker's split
    t = c * a
    ah = t - (t - a)
    al = a - ah
    t = c * p
    ph = t - (t - p)
    pl = p - ph
    err = ((ah * ph - x) + ah * pl + al * ph) + al * pl  # a * p == x + err exactly
    f = math.floor(x)
    d = (x - f) - 0.5 + err  # the sign of the exact (a * p - f - 0.5)
    if d > 0.0:
        return f + 1.0
    if d < 0.0:
        return f
    return f if f % 2.0 == 0.0 else f + 1.0


@njit(cache=True)
def _g12_kernel(values, out, fb_text, fb_off, fb_next, pow10, pairs):
    """Write rows of ``values`` as '%.12g' into ``out``.

    Returns (bytes used, index of the next fallback text); bytes used is -(flat index + 1)
    of a value the kernel could not format (never expected; the caller then uses Python).
    ``fb_text``/``fb_off`` hold the Python texts of the values outside ``[1e-11, 1e12)``
    in order of appearance.
    """
    T, C = values.shape
    p = 0
    for t in range(T):
        for c in range(C):
            v = values[t, c]
            a = abs(v)
            if v != v or a == np.inf:
                return -(t * C + c + 1), fb_next
            if a == 0.0:
                if math.copysign(1.0, v) < 0.0:
                    out[p] = 45
                    p += 1
                out[p] = 48
                p += 1
            elif a < 1e-11 or a >= 1e12:
                s0 = fb_off[fb_next]
                s1 = fb_off[fb_next + 1]
                for i in range(s0, s1):
                    out[p] = fb_text[i]
                    p += 1
                fb_next += 1
            else:
                if a >= 1.0:  # decimal exponent by comparisons (corrected below if off by one)
                    e = 0
                    while e < 11 and a >= pow10[e + 1]:
                        e += 1
                else:
                    e = -1
                    while e > -11 and a * pow10[-e] < 1.0:
                        e -= 1
                k = 0.0
                ok = False
                for _ in range(4):
                    s = 11 - e
                    if s < 0 or s > 22:
                        break
                    x = a * pow10[s]
                    f = math.floor(x)
                    d = x - f - 0.5
                    if d > 1e-3:  # far from a tie: the rounded product rounds the same way
                        k = f + 1.0
                    elif d < -1e-3:
                        k = f
                    else:
                        k = _round_scaled(a, pow10[s])
                    if k >= 1e12:
                        e += 1
                    elif k < 1e11:
                        e -= 1
                    else:
                        ok = True
                        break
                if not ok:
                    return -(t * C + c + 1), fb_next
                ik = np.int64(k)
                nd = 12  # significant digits kept; trailing zeros after the point are dropped
                keep = e + 1 if 0 <= e else 1
                while nd > keep:
                    q = ik // 10
                    if ik - q * 10 != 0:
                        break
                    ik = q
                    nd -= 1
                if v < 0.0:
                    out[p] = 45
                    p += 1
                if e >= 0:
                    frac = nd - e - 1
                elif e >= -4:  # 0.000ddd
                    out[p] = 48
                    out[p + 1] = 46
                    p += 2
                    for i in range(-e - 1):
                        out[p] = 48
                        p += 1
                    frac = 0
                else:
                    frac = nd - 1
                end = p + nd + (1 if frac > 0 else 0)
                w = end
                j = 0
                while j + 2 <= frac:
                    q = ik // 100
                    r = ik - q * 100
                    w -= 2
                    out[w] = pairs[2 * r]
                    out[w + 1] = pairs[2 * r + 1]
                    ik = q
                    j += 2
                if j < frac:
                    q = ik // 10
                    w -= 1
                    out[w] = 48 + (ik - q * 10)
                    ik = q
                if frac > 0:
                    w -= 1
                    out[w] = 46
                while w - p >= 2:
                    q = ik // 100
                    r = ik - q * 100
                    w -= 2
                    out[w] = pairs[2 * r]
                    out[w + 1] = pairs[2 * r + 1]
                    ik = q
                if w > p:
                    out[p] = 48 + ik
                p = end
                if e < -4:
                    out[p] = 101
                    out[p + 1] = 45
                    out[p + 2] = 48 + (-e) // 10
                    out[p + 3] = 48 + (-e) % 10
                    p += 4
            out[p] = 32 if c < C - 1 else 10
            p += 1
    return p, fb_next


def format_motion_block_g(values: np.ndarray, *, chunk_rows: int = 4096):
    """The rows of ``values`` as BVH motion text, each value as ``'%.12g' % v``.

    Parameters
    ----------
    values : np.ndarray [shape=(T, C)]
        Finite channel values (degrees, file units).
    chunk_rows : int
        Rows formatted per chunk (memory stays about ``chunk_rows * C * 20`` bytes).

    Yields
    ------
    bytes
        Consecutive pieces of the text: values separated by one space, rows ended by
        ``\\n``; the same bytes as ``np.savetxt(f, values, fmt="%.12g", delimiter=" ")``.

    Raises
    ------
    ValueError
        A non-finite value (BVH cannot store it).
    """
    values = np.asarray(values)
    if values.ndim != 2:
        raise ValueError(f"values must be 2-d (frames, channels), got shape {values.shape}")
    T, C = values.shape
    if C == 0:
        if T:
            yield b"\n" * T
        return
    chunk_rows = max(int(chunk_rows), 1)
    out = np.empty(min(chunk_rows, max(T, 1)) * C * 20, dtype=np.uint8)  # '%.12g' is at most 18 + 1 bytes
    for t0 in range(0, T, chunk_rows):
        block = np.ascontiguousarray(values[t0:t0 + chunk_rows], dtype=np.float64)
        if not np.isfinite(block).all():
            t, c = np.argwhere(~np.isfinite(block))[0]
            raise ValueError(f"value at frame {t0 + t}, column {c} is not finite ({block[t, c]})")
        a = np.abs(block)
        odd = block[(a != 0.0) & ((a < _G_LO) | (a >= _G_HI))]  # row-major: the kernel's order
        texts = [b"%.12g" % v for v in odd.tolist()]
        fb_off = np.zeros(len(texts) + 1, dtype=np.int64)
        fb_off[1:] = np.cumsum([len(x) for x in texts], dtype=np.int64)
        fb_text = np.frombuffer(b"".join(texts), dtype=np.uint8) if texts else np.zeros(1, np.uint8)
        p, _ = _g12_kernel(block, out, fb_text, fb_off, 0, _POW10, _PAIRS)
        if p < 0:  # not expected: the whole chunk in Python
            yield "".join(" ".join("%.12g" % v for v in row) + "\n" for row in block.tolist()).encode("ascii")
        else:
            yield out[:p].tobytes()
