"""read_bvh/write_bvh: the compiled path (large files) and the numpy path (small files) agree.

Small files go through ``np.loadtxt`` / ``np.savetxt`` (no numba import), large ones through
:mod:`splicer.io.fastparse` / :mod:`splicer.io.fastformat`; the size thresholds are lowered or
raised here so every case runs through both: same values, same bytes, same messages.
"""

from __future__ import annotations

import io
import warnings

import numpy as np
import pytest

from splicer.errors import BVHError, SplicerWarning
from splicer.io import bvh_read, bvh_write
from splicer.io.bvh import read_bvh, write_bvh
from splicer.io.fastformat import format_motion_block_g
from splicer.model.motion import Motion

from test_bvh import BASE_LINES, DATA, FIXTURES, MALFORMED, _edit


@pytest.fixture(params=["numpy", "compiled"])
def parser(request, monkeypatch):
    """Run the test with reading and writing forced through one path."""
    big = request.param == "compiled"
    monkeypatch.setattr(bvh_read, "FAST_MIN_BYTES", 0 if big else 1 << 62)
    monkeypatch.setattr(bvh_write, "FAST_MIN_VALUES", 0 if big else 1 << 62)
    monkeypatch.setattr(bvh_read, "PREFER_LOADED", big)  # this module loads the compiled code: numpy stays numpy
    monkeypatch.setattr(bvh_write, "PREFER_LOADED", big)
    return request.param


def _read_quiet(path):
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=SplicerWarning, message=".*data section has")
        return read_bvh(path)


@pytest.mark.parametrize("text,line,words", [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED])
def test_malformed_both_paths(parser, tmp_path, text, line, words):
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    with pytest.raises(BVHError) as info:
        read_bvh(path)
    assert info.value.line == line, str(info.value)
    assert str(info.value).startswith(f"{path}, line {line}: ") and words in str(info.value)


# data-block problems: (id, file text, line, exact message after "path, line N: ")
DATA_ERRORS = [
    ("too-large", _edit(20, "1 2 3 10 20 30 90 0 12345678"), 20,
     "value 9 of the frame row: '12345678' is too large (the limit is 1e+07 in magnitude)"),
    ("too-large-many-digits", _edit(19, "0 0 0 0 -10000001.000000000000000001 0 0 0 0"), 19,
     "value 5 of the frame row: '-10000001.000000000000000001' is too large (the limit is 1e+07 in magnitude)"),
    ("infinite-exponent", _edit(20, "1 2 3 10 20 30 90 0 1e999"), 20,
     "value 9 of the frame row: expected a number, found '1e999'"),
    ("token-before-count", "\n".join(BASE_LINES[:18] + ["0 0 0 0 x 0 0 0 0", "1 2"]) + "\n", 19,
     "value 5 of the frame row: expected a number, found 'x'"),
    ("count-before-token", "\n".join(BASE_LINES[:18] + ["1 2", "0 0 0 0 x 0 0 0 0"]) + "\n", 19,
     "expected 9 values per frame (one per channel), found 2"),
    ("bad-token-in-long-row", _edit(20, "1 2 3 10 20 30 90 0 0 5 y"), 20,
     "value 11 of the frame row: expected a number, found 'y'"),
    ("non-ascii", _edit(20, "1 2 3 10 20 30 90 0 \u00e9"), 20,
     "value 9 of the frame row: expected a number, found '\u00e9'"),
]


@pytest.mark.parametrize("text,line,message", [m[1:] for m in DATA_ERRORS], ids=[m[0] for m in DATA_ERRORS])
def test_data_errors_exact_message(parser, tmp_path, text, line, message):
    path = tmp_path / "bad.bvh"
    path.write_bytes(text.encode("utf-8"))
    with pytest.raises(BVHError) as info:
        read_bvh(path)
    assert str(info.value) == f"{path}, line {line}: {message}"


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])
def test_truncated_names_last_row_line(parser, tmp_path, ending):
    """Frames: 9 with 3 rows (lines 19, 21, 22; line 20 blank): the message names line 22 as the last."""
    lines = BASE_LINES[:16] + ["Frames: 9", BASE_LINES[17], BASE_LINES[18], "", BASE_LINES[19], BASE_LINES[20]]
    path = tmp_path / "t.bvh"
    path.write_bytes((ending.join(lines) + ending + ending).encode())
    with pytest.raises(BVHError) as info:
        read_bvh(path)
    assert str(info.value) == (f"{path}, line 17: Frames: says 9 but the data section has only 3 rows "
                               "(the file ends after line 22): the file is truncated")


def test_extra_rows_warn_and_are_dropped(parser, tmp_path):
    path = tmp_path / "x.bvh"
    path.write_text(_edit(17, "Frames: 1") + "\n\n7 7 7\n")
    with pytest.warns(SplicerWarning, match=r"4 rows but Frames: \(line 17\) says 1; the first 1 rows"):
        m = read_bvh(path)
    assert m.channels.shape == (1, 9)


@pytest.mark.parametrize("src", FIXTURES, ids=[p.name for p in FIXTURES])
def test_fixtures_same_values_and_bytes_both_ways(src, tmp_path, monkeypatch):
    out = {}
    for kind, read_min, write_min in (("numpy", 1 << 62, 1 << 62), ("compiled", 0, 0)):
        monkeypatch.setattr(bvh_read, "FAST_MIN_BYTES", read_min)
        monkeypatch.setattr(bvh_write, "FAST_MIN_VALUES", write_min)
        monkeypatch.setattr(bvh_read, "PREFER_LOADED", kind == "compiled")
        monkeypatch.setattr(bvh_write, "PREFER_LOADED", kind == "compiled")
        m = _read_quiet(src)
        write_bvh(m, tmp_path / f"{kind}.bvh")
        out[kind] = (m.channels, (tmp_path / f"{kind}.bvh").read_bytes())
    assert out["numpy"][0].tobytes() == out["compiled"][0].tobytes()  # bit for bit, -0.0 included
    assert out["numpy"][1] == out["compiled"][1]


def test_written_file_reads_back_equal(parser, tmp_path):
    """read -> write -> read: equal values and hierarchy (a file with at most 12 digits)."""
    src = DATA / "two_joints_zxy.bvh"
    m = _read_quiet(src)
    write_bvh(m, tmp_path / "a.bvh")
    m2 = read_bvh(tmp_path / "a.bvh")
    np.testing.assert_array_equal(m2.channels, m.channels)
    assert m2.skeleton.names == m.skeleton.names and m2.skeleton.channels == m.skeleton.channels
    np.testing.assert_array_equal(m2.skeleton.offsets, m.skeleton.offsets)
    write_bvh(m2, tmp_path / "b.bvh")
    assert (tmp_path / "a.bvh").read_bytes() == (tmp_path / "b.bvh").read_bytes()


def test_header_longer_than_the_first_chunk(parser, tmp_path, monkeypatch):
    """A header that does not fit the first decoded prefix is read in larger prefixes."""
    monkeypatch.setattr(bvh_read, "_HEADER_CHUNK", 64)
    m = read_bvh(DATA / "two_joints_zxy.bvh")
    monkeypatch.setattr(bvh_read, "_HEADER_CHUNK", 1 << 16)
    m2 = read_bvh(DATA / "two_joints_zxy.bvh")
    np.testing.assert_array_equal(m.channels, m2.channels)
    assert m.skeleton.names == m2.skeleton.names


def test_header_chunk_does_not_change_a_header_error(tmp_path, monkeypatch):
    """The end-of-file error names the file's last non-blank line whatever the prefix size."""
    path = tmp_path / "bad.bvh"
    path.write_text("\n".join(BASE_LINES[:9]) + "\n\n\n")
    for chunk in (16, 64, 1 << 16):
        monkeypatch.setattr(bvh_read, "_HEADER_CHUNK", chunk)
        with pytest.raises(BVHError, match=r", line 9: the file ends here"):
            read_bvh(path)


# -- the '%.12g' formatter against np.savetxt ------------------------------------------------------
def _savetxt(values) -> bytes:
    buf = io.BytesIO()
    np.savetxt(buf, values, fmt="%.12g", delimiter=" ")
    return buf.getvalue()


@pytest.mark.parametrize("scale", [1e-13, 1e-9, 1e-5, 1e-3, 1.0, 360.0, 1e5, 1e11, 1e14])
def test_g12_equals_savetxt(scale, rng):
    v = rng.standard_normal((300, 17)) * scale
    v[::3, 2] = np.round(v[::3, 2], 6)  # values typed with few decimals
    v[::4, 5] = -0.0
    assert b"".join(format_motion_block_g(v, chunk_rows=7)) == _savetxt(v)


def test_g12_known_text():
    v = np.array([[0.0, -0.0, 5.0, 5000.0, 0.5, 1.5e-7, -2.5e-5, 1e-4, 0.000123456789012345, 1 / 3,
                   99999.99999995, 999999999999.4, 999999999999.7, 1e-11, 9.99999999999e-12, 123456789012.0]])
    assert b"".join(format_motion_block_g(v)) == (
        b"0 -0 5 5000 0.5 1.5e-07 -2.5e-05 0.0001 0.000123456789012 0.333333333333 99999.9999999 "
        b"999999999999 1e+12 1e-11 9.99999999999e-12 123456789012\n")


def test_g12_ties_round_half_even_on_the_exact_value():
    """Values whose 13th digit is exactly 5 (x.5 * 10**-k) and their neighbours: as printf."""
    base = np.arange(100000000000, 100000000040, dtype=np.float64) + 0.5
    v = np.concatenate([base / 10.0 ** k for k in (0, 1, 3, 7, 11)]).reshape(-1, 8)
    v = np.concatenate([v, np.nextafter(v, 0), np.nextafter(v, np.inf)])
    assert b"".join(format_motion_block_g(v)) == _savetxt(v)


def test_g12_empty_and_no_channels():
    assert b"".join(format_motion_block_g(np.zeros((0, 3)))) == b""
    assert b"".join(format_motion_block_g(np.zeros((2, 0)))) == b"\n\n"
    with pytest.raises(ValueError, match="not finite"):
        list(format_motion_block_g(np.array([[1.0, np.nan]])))


def test_large_take_round_trip_through_the_compiled_path(tmp_path, rng):
    """A take above both thresholds: written and read back exactly (values with 6 decimals)."""
    sk = read_bvh(DATA / "two_joints_zxy.bvh").skeleton
    T = bvh_write.FAST_MIN_VALUES // sk.n_channels + 10
    ch = np.round(rng.uniform(-400, 400, (T, sk.n_channels)), 6)
    write_bvh(Motion(sk, ch, 1 / 120, source="big"), tmp_path / "big.bvh")
    assert (tmp_path / "big.bvh").stat().st_size > bvh_read.FAST_MIN_BYTES
    np.testing.assert_array_equal(read_bvh(tmp_path / "big.bvh").channels, ch)


# -- parse_block: the limit, the stop position, the last row's line ---------------------------------
def test_parse_block_end_and_last_row_line():
    from splicer.io.fastparse import parse_block

    buf = b"1 2\n\n3 4\r\n5 6\n7 8\n"  # lines 10..14 (line 11 blank)
    res = parse_block(buf, 2, 10, max_rows=3)
    assert res.error is None and res.values.tolist() == [[1, 2], [3, 4], [5, 6]]
    assert res.end == buf.index(b"7") and res.last_row_line == 13
    res = parse_block(buf, 2, 10)
    assert res.end == len(buf) and res.last_row_line == 14 and res.values.shape == (4, 2)
    assert parse_block(b"\n\n", 2, 1).last_row_line == 0


@pytest.mark.parametrize("token, kind", [("100.5", "range"), ("-100.5", "range"), ("100", None),
                                         ("1" * 30, "range"), ("1e999", "nonfinite"), ("99.999999999999999999", None)])
def test_parse_block_max_abs(token, kind):
    from splicer.io.fastparse import parse_block

    res = parse_block(f"0 0\n1 {token}\n".encode(), 2, 5, max_abs=100.0)
    if kind is None:
        assert res.error is None and res.values[1, 1] == float(token)
    else:
        assert (res.error.kind, res.error.line, res.error.column, res.error.token) == (kind, 6, 2, token)
        assert res.values.shape == (1, 2)  # the rows before the problem


@pytest.mark.parametrize("size_change", [0, +100, -100])
def test_read_input_reads_a_file_that_shrinks_or_grows_after_it_was_sized(tmp_path, monkeypatch, size_change):
    """A regular file is read into a buffer of the size fstat gave, in READ_PIECE pieces with
    progress; if it shrank meanwhile the buffer is cut, if it grew the rest is appended: either way
    the bytes are the file's."""
    from splicer.io import limits

    data = bytes(np.random.default_rng(0).integers(32, 127, 5000, dtype=np.uint8))
    path = tmp_path / "f.txt"
    path.write_bytes(data)
    real_fstat = limits.os.fstat

    class Sized:  # fstat's answer with another size, as if the file changed after it
        def __init__(self, st):
            self.st_mode, self.st_size = st.st_mode, st.st_size + size_change

    monkeypatch.setattr(limits.os, "fstat", lambda fd: Sized(real_fstat(fd)))
    monkeypatch.setattr(limits, "READ_PIECE", 1024)
    seen = []
    got = limits.read_input(path, max_bytes=10_000, error=ValueError, progress=seen.append)
    assert bytes(got) == data
    size = len(data) + size_change
    n_full = min(len(data), size) // 1024
    assert seen[:n_full] == pytest.approx([k * 1024 / size for k in range(1, n_full + 1)])
    assert seen == sorted(seen) and seen[-1] == pytest.approx(min(1.0, len(data) / size))


def test_loaded_compiled_code_reads_and_writes_small_files(tmp_path, monkeypatch):
    """Once the compiled parser and formatter are loaded (as in splice-server), a small file goes
    through them: proven by making the numpy path fail; the same values and bytes."""
    src = DATA / "two_joints_zxy.bvh"
    m0 = _read_quiet(src)
    assert m0.channels.size
    write_bvh(m0, tmp_path / "numpy.bvh")
    import splicer.io.fastformat  # noqa: F401
    import splicer.io.fastparse  # noqa: F401

    def fail(*a, **k):
        raise AssertionError("the numpy path ran")

    monkeypatch.setattr(bvh_read, "_parse_small", fail)
    monkeypatch.setattr(bvh_write.np, "savetxt", fail)
    m1 = _read_quiet(src)
    write_bvh(m1, tmp_path / "compiled.bvh")
    assert m0.channels.tobytes() == m1.channels.tobytes()
    assert (tmp_path / "numpy.bvh").read_bytes() == (tmp_path / "compiled.bvh").read_bytes()
