"""splicer.io.fastparse: the compiled MOTION-block parser and formatter against float() and '%f'."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from splicer.io.fastparse import ParseError, count_rows, format_motion_block, parse_motion_block

_SPACE = " \t\v\f\r"


def reference_parse(buf: bytes, n_channels: int, first_line: int):
    """Slow plain-Python reference: split lines and tokens, float() each token."""
    text = buf.decode("latin-1").replace("\r\n", "\n").replace("\r", "\n")
    rows = []
    for k, line in enumerate(text.split("\n")):
        toks = line.split()
        if not toks:
            continue
        for col, t in enumerate(toks):
            try:
                if "_" in t or t.strip(_SPACE) != t:
                    raise ValueError
                v = float(t)
            except ValueError:
                return np.array(rows).reshape(-1, n_channels), ("token", first_line + k, len(rows), col + 1, t)
            if not np.isfinite(v):
                return np.array(rows).reshape(-1, n_channels), ("nonfinite", first_line + k, len(rows), col + 1, t)
        if len(toks) != n_channels:
            return np.array(rows).reshape(-1, n_channels), ("count", first_line + k, len(rows), len(toks), "")
        rows.append([float(t) for t in toks])
    return np.array(rows, dtype=np.float64).reshape(-1, n_channels), None


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def check_against_reference(buf: bytes, C: int, first_line: int = 1):
    got, err = parse_motion_block(buf, C, first_line)
    ref, ref_err = reference_parse(buf, C, first_line)
    assert same_bits(got, ref)
    if ref_err is None:
        assert err is None
    else:
        assert err is not None
        assert (err.kind, err.line, err.row, err.column, err.token) == ref_err
    return got, err


def random_token(rng) -> str:
    v = rng.choice([rng.normal(0, 100), rng.normal(0, 1e-3), rng.uniform(-360, 360), 0.0, -0.0,
                    float(rng.integers(-1000, 1000)), rng.normal(0, 1) * 10.0 ** rng.integers(-30, 30)])
    fmt = rng.choice(["%.4f", "%.6f", "%.12g", "%r", "%e", "%.3E", "%+.2f", "%g", "%.0f", "%.20f", "%.1f"])
    s = repr(float(v)) if fmt == "%r" else fmt % v
    if rng.random() < 0.05 and "." in s and s.lstrip("+-").startswith("0."):
        s = s.replace("0.", ".", 1)  # ".5"
    elif rng.random() < 0.05 and s.endswith("0") and "." in s and "e" not in s.lower():
        s = s.rstrip("0")  # "5."
    if s.strip("+-.") == "":
        s = "0" + s
    return s


def random_block(rng, rows: int, C: int) -> bytes:
    lines = []
    for _ in range(rows):
        seps = [rng.choice([" ", "  ", "\t", " \t "]) for _ in range(C - 1)]
        toks = [random_token(rng) for _ in range(C)]
        line = toks[0] + "".join(s + t for s, t in zip(seps, toks[1:]))
        if rng.random() < 0.2:
            line = " " * int(rng.integers(1, 3)) + line
        if rng.random() < 0.2:
            line += rng.choice([" ", "\t", "   "])
        lines.append(line)
        if rng.random() < 0.05:
            lines.append(rng.choice(["", "  ", "\t"]))
    eol = rng.choice(["\n", "\r\n", "\r"])
    return (eol.join(lines) + (eol if rng.random() < 0.7 else "")).encode()


@pytest.mark.parametrize("seed", range(6))
def test_random_blocks_equal_float(seed):
    rng = np.random.default_rng(seed)
    C = int(rng.integers(1, 9))
    buf = random_block(rng, int(rng.integers(1, 300)), C)
    got, err = check_against_reference(buf, C, first_line=int(rng.integers(1, 500)))
    assert err is None


@pytest.mark.parametrize("bad_row", [None, 170])
def test_parsing_in_pieces_gives_the_same_values_errors_and_progress(monkeypatch, bad_row):
    """The kernel resumes at row starts: pieces of about 300 bytes give float()'s values, the
    first problem with its line (a bad token in a late piece too), and a rising fraction."""
    from splicer.io import fastparse

    rng = np.random.default_rng(11)
    lines = random_block(rng, 200, 4).replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")
    if bad_row is not None:
        lines[bad_row] = b"1 2 x3 4"
    buf = b"\n".join(lines)
    monkeypatch.setattr(fastparse, "PROGRESS_BYTES", 300)
    seen = []
    res = fastparse.parse_block(buf, 4, 5, progress=seen.append)
    ref, ref_err = reference_parse(buf, 4, 5)
    assert same_bits(res.values, ref)
    assert len(seen) > 10 and seen == sorted(seen) and 0 < seen[0] and seen[-1] <= 1.0
    if bad_row is None:
        assert res.error is None
    else:
        e = res.error
        assert (e.kind, e.line, e.row, e.column, e.token) == ref_err and e.line == 5 + bad_row


def test_known_values():
    buf = b"0.1 -0 +2.5e-3 .5 5. 1E2 -0.0000 123456789.125 0.30000000000000004 1e-22 4e22\n"
    got, err = parse_motion_block(buf, 11, 7)
    assert err is None
    exp = np.array([[0.1, -0.0, 0.0025, 0.5, 5.0, 100.0, -0.0, 123456789.125, 0.30000000000000004, 1e-22, 4e22]])
    assert same_bits(got, exp)
    assert np.signbit(got[0, 1]) and np.signbit(got[0, 6])


def test_fallback_tokens_many_digits_and_huge_exponents():
    # 20+ significant digits, exponents beyond 1e22, leading zeros: exact through float()
    toks = ["1.23456789012345678901234", "1e300", "-2.5e-300", "000000000000000000000000012.5",
            "0.000000000000000000000000000001", "9007199254740993", "1e23"]
    buf = (" ".join(toks) + "\n").encode()
    got, err = parse_motion_block(buf, len(toks), 1)
    assert err is None
    assert same_bits(got, np.array([[float(t) for t in toks]]))


def test_many_fallback_tokens_resume():
    # more slow-path tokens than the kernel's fallback buffer holds: the parse resumes
    rng = np.random.default_rng(3)
    vals = rng.normal(0, 100, (3000, 5))
    buf = "\n".join(" ".join(repr(float(v)) for v in row) for row in vals).encode()
    got, err = parse_motion_block(buf, 5, 1)
    assert err is None
    assert same_bits(got, vals)


@pytest.mark.parametrize("token, kind", [
    ("1.2.3", "token"), ("e5", "token"), ("1e", "token"), ("1e+", "token"), ("--1", "token"), ("+", "token"),
    (".", "token"), ("1,5", "token"), ("0x10", "token"), ("1_000", "token"), ("12abc", "token"),
    ("\xe9", "token"), ("nan", "nonfinite"), ("inf", "nonfinite"), ("-Infinity", "nonfinite"),
    ("NaN", "nonfinite"), ("1e999", "nonfinite"), ("-1e400", "nonfinite")])
def test_malformed_token_line_and_column(token, kind):
    buf = f"1 2 3\n\n4 {token} 6\n7 8 9\n".encode("latin-1")
    got, err = parse_motion_block(buf, 3, 20)
    assert err == ParseError(line=22, row=1, column=2, kind=kind, token=token, expected=3)
    assert same_bits(got, np.array([[1.0, 2.0, 3.0]]))
    assert "frame 1" in err.message and repr(token) in err.message


@pytest.mark.parametrize("row, found", [("4 5", 2), ("4 5 6 7", 4), ("4 5 6 7 x", 4)])
def test_wrong_count_reports_line_and_found(row, found):
    buf = f"1 2 3\r\n{row}\r\n7 8 9\r\n".encode()
    got, err = parse_motion_block(buf, 3, 100)
    assert (err.kind, err.line, err.row, err.column) == ("count", 101, 1, found) or \
        (err.kind, err.line) == ("token", 101)
    assert got.shape == (1, 3)


def test_too_many_values_message():
    _, err = parse_motion_block(b"1 2 3 4\n", 3, 5)
    assert err.message == "expected 3 values per frame (one per channel), found 4"
    assert err.line == 5


def test_crlf_tabs_trailing_spaces_and_lone_cr_same_values():
    plain = b"1.5 2 3\n4 5 6.25\n"
    variants = [b"1.5\t2\t3\r\n4\t5\t6.25\r\n", b"  1.5 2 3   \n\t4 5 6.25\t\n\n", b"1.5 2 3\r4 5 6.25",
                b"\n\n1.5 2 3\r\n\r\n4 5 6.25 \r\n  \n"]
    ref, _ = parse_motion_block(plain, 3, 1)
    for v in variants:
        got, err = parse_motion_block(v, 3, 1)
        assert err is None and same_bits(got, ref)


def test_line_numbers_count_crlf_and_blank_lines():
    _, err = parse_motion_block(b"1 2\r\n\r\n\r\n3 ?\r\n", 2, 10)
    assert (err.line, err.row, err.column) == (13, 1, 2)
    _, err = parse_motion_block(b"1 2\r\r3 ?\r", 2, 1)  # old-Mac line ends
    assert err.line == 3


def test_max_rows_stops_and_count_rows():
    buf = b"1 2\n3 4\n\n5 6\nbad row here\n"
    got, err = parse_motion_block(buf, 2, 1, max_rows=3)
    assert err is None and got.tolist() == [[1, 2], [3, 4], [5, 6]]
    assert count_rows(buf) == 4
    assert count_rows(b"1\r\n\r\n  \n2") == 2


def test_empty_and_uint8_input():
    got, err = parse_motion_block(b"", 4, 1)
    assert err is None and got.shape == (0, 4)
    arr = np.frombuffer(b"1 2\n", dtype=np.uint8)
    got, err = parse_motion_block(arr, 2, 1)
    assert got.tolist() == [[1.0, 2.0]]
    with pytest.raises(ValueError):
        parse_motion_block(b"1\n", 0, 1)


def motion_block_of(path):
    data = path.read_bytes()
    i = data.index(b"Frame Time")
    start = data.index(b"\n", i) + 1
    return data[start:], data.count(b"\n", 0, start) + 1


def test_real_files_equal_float(shared_bvh):
    from splicer.io.bvh import read_bvh
    from splicer.errors import SplicerWarning

    block, line = motion_block_of(shared_bvh)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SplicerWarning)  # leap-hands files have one extra row
        m = read_bvh(shared_bvh)
    C = m.skeleton.n_channels
    got, err = parse_motion_block(block, C, line, max_rows=m.n_frames)
    assert err is None
    assert same_bits(got, m.channels)  # np.loadtxt (the current reader) gives the same bits
    ref, ref_err = reference_parse(block, C, line)
    assert same_bits(got, ref[:m.n_frames])


# ---------------------------------------------------------------- formatting

def fmt_text(values, decimals, trim):
    return b"".join(format_motion_block(values, decimals, trim=trim)).decode()


def test_format_known_text():
    v = np.array([[1.5, -0.25, 0.0, 100.0], [-1e-9, 123.4567891, 2.0000004, -0.0]])
    assert fmt_text(v, 6, True) == "1.5 -0.25 0 100\n-0 123.456789 2 -0\n"
    assert fmt_text(v, 2, False) == "1.50 -0.25 0.00 100.00\n-0.00 123.46 2.00 -0.00\n"
    assert fmt_text(v[:1], 0, False) == "2 -0 0 100\n"  # rint: half to even


@pytest.mark.parametrize("decimals", [0, 3, 6, 9])
def test_format_equals_python_percent_f(decimals, rng):
    v = np.concatenate([rng.normal(0, 100, 2000), rng.normal(0, 1e-4, 500), rng.uniform(-360, 360, 500)]).reshape(-1, 6)
    orig = v.copy()
    lines = fmt_text(v, decimals, False).splitlines()
    exp = [" ".join(f"{x:.{decimals}f}" for x in row) for row in v]
    mismatch = sum(a != b for a, b in zip(lines, exp))
    assert len(lines) == len(exp) and mismatch == 0
    trimmed = fmt_text(v, decimals, True).splitlines()
    assert trimmed == [" ".join(t.rstrip("0").rstrip(".") if "." in t else t for t in row.split()) for row in exp]
    assert np.array_equal(v, orig)  # input unchanged


def test_format_round_trip_exact_at_precision(rng):
    v = np.round(rng.normal(0, 200, (500, 7)), 6)
    text = b"".join(format_motion_block(v, 6))
    back, err = parse_motion_block(text, 7, 1)
    assert err is None and same_bits(back + 0.0, v + 0.0)
    # any value: parse(format(v)) is v rounded to 6 decimals, and formatting that again gives the same text
    w = rng.normal(0, 200, (300, 4))
    t1 = b"".join(format_motion_block(w, 6))
    back, _ = parse_motion_block(t1, 4, 1)
    assert np.array_equal(back, np.round(w, 6)) and np.abs(back - w).max() <= 0.5e-6 * (1 + 1e-9)
    assert b"".join(format_motion_block(back, 6)) == t1


def test_format_large_values_fall_back_and_chunks():
    v = np.array([[1e20, 2.5], [3.0, -4e18], [5.0, 6.0]])
    text = b"".join(format_motion_block(v, 3, chunk_rows=2)).decode()
    assert text == "100000000000000000000 2.5\n3 -4000000000000000000\n5 6\n"


def test_format_rejects_nonfinite():
    with pytest.raises(ValueError, match="frame 1, column 0"):
        list(format_motion_block(np.array([[1.0], [np.nan]]), 6))
