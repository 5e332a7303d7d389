"""Tests of splicer.io.bvh: reading, writing, round trips and messages for malformed files."""

from __future__ import annotations

import hashlib
import os
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from splicer.io import bvh as bvh_module
from splicer.io import bvh_header
from splicer.io.bvh import read_bvh, write_bvh
from splicer.errors import BVHError, SplicerWarning
from splicer.model.motion import Motion, Skeleton

DATA = Path(__file__).resolve().parent / "data"
FIXTURES = sorted(DATA.glob("*.bvh"))
TOL = 1e-4  # degrees / file units, the required round-trip accuracy


def _read(path) -> Motion:
    """read_bvh, accepting the extra-data-row warning (tested on its own below)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=SplicerWarning, message=".*data section has")
        return read_bvh(path)


def _sha(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def assert_same_hierarchy(a: Skeleton, b: Skeleton) -> None:
    assert a.names == b.names
    assert a.channels == b.channels
    np.testing.assert_array_equal(a.parents, b.parents)
    np.testing.assert_array_equal(a.offsets, b.offsets)
    np.testing.assert_array_equal(a.end_sites, b.end_sites)  # NaN == NaN here


def assert_round_trip(src: Path, tmp_path: Path) -> None:
    m = _read(src)
    before = _sha(src)
    out = tmp_path / "out.bvh"
    write_bvh(m, out)
    m2 = read_bvh(out)  # what we write has no quirks: no warning allowed
    assert_same_hierarchy(m.skeleton, m2.skeleton)
    assert m2.channels.shape == m.channels.shape
    np.testing.assert_allclose(m2.channels, m.channels, rtol=0, atol=TOL)
    assert m2.frame_time == m.frame_time
    assert _sha(src) == before
    assert [p.name for p in tmp_path.iterdir()] == ["out.bvh"]  # no temporary left


# -- round trips ----------------------------------------------------------------------------
@pytest.mark.parametrize("src", FIXTURES, ids=[p.name for p in FIXTURES])
def test_round_trip_fixtures(src, tmp_path):
    assert_round_trip(src, tmp_path)


@pytest.mark.shared
def test_round_trip_shared(shared_bvh, tmp_path):
    assert_round_trip(shared_bvh, tmp_path)


def test_round_trip_random_values(rng, tmp_path):
    """Computed (not file-typed) values survive the %.12g text form well within 1e-4."""
    sk = _read(DATA / "xyz_six_channel_child.bvh").skeleton
    ch = np.concatenate([rng.uniform(-1e4, 1e4, (50, 6)), rng.uniform(-720, 720, (50, 9))], axis=1)
    m = Motion(sk, ch, 1 / 120, source="random")
    write_bvh(m, tmp_path / "r.bvh")
    m2 = read_bvh(tmp_path / "r.bvh")
    np.testing.assert_allclose(m2.channels, ch, rtol=1e-11, atol=1e-9)
    assert m2.frame_time == 1 / 120


@pytest.mark.parametrize("frames", [50, 70_000])
def test_writing_reports_the_share_of_frames_written(rng, tmp_path, frames):
    """A small block in one piece (1.0 once); a large one (70,000 x 15 values, over FAST_MIN_VALUES)
    in pieces of 4,096 frames: 18 calls, rising to 1.0; the file is the same as without it."""
    sk = _read(DATA / "xyz_six_channel_child.bvh").skeleton
    m = Motion(sk, rng.uniform(-90, 90, (frames, 15)), 1 / 120, source="random")
    seen = []
    write_bvh(m, tmp_path / "p.bvh", progress=seen.append)
    write_bvh(m, tmp_path / "q.bvh")
    assert (tmp_path / "p.bvh").read_bytes() == (tmp_path / "q.bvh").read_bytes()
    if frames == 50:
        assert seen == [1.0]
    else:
        assert len(seen) == 18 and seen == sorted(seen) and seen[0] == pytest.approx(4096 / 70_000) and seen[-1] == 1.0


def test_reading_reports_bytes_read_then_parsed_and_keeps_the_parsed_array(rng, tmp_path, monkeypatch):
    """A 3 MB file read in 1 MB pieces (0.1, 0.2, 0.3 of the bar: READ_SHARE) and parsed in pieces
    of about 0.5 MB (the rest, rising), ending at 1.0; the values are those of one piece; the
    Motion holds the parser's array itself (a 1 GB take was copied once more: 0.76 s, 640 MB)."""
    from splicer.io import bvh_read, fastparse, limits

    sk = _read(DATA / "xyz_six_channel_child.bvh").skeleton
    m = Motion(sk, rng.uniform(-90, 90, (15_000, 15)), 1 / 120, source="random")
    path = tmp_path / "big.bvh"
    write_bvh(m, path)
    size = path.stat().st_size
    monkeypatch.setattr(bvh_read, "FAST_MIN_BYTES", 0)  # the compiled parser, as for a large take
    whole = read_bvh(path)
    monkeypatch.setattr(limits, "READ_PIECE", 1 << 20)
    monkeypatch.setattr(fastparse, "PROGRESS_BYTES", 1 << 19)
    seen = []
    got = read_bvh(path, progress=seen.append)
    assert np.array_equal(got.channels, whole.channels) and got.channels.flags.owndata
    reading = [f for f in seen if f <= bvh_read.READ_SHARE]
    n_read = -(-size // (1 << 20))
    assert reading == pytest.approx([bvh_read.READ_SHARE * min(1.0, k * (1 << 20) / size) for k in range(1, n_read + 1)])
    parsing = seen[len(reading):]
    assert len(parsing) >= 5 and parsing == sorted(parsing) and parsing[-1] == 1.0


def test_written_file_is_accepted_by_bvhio(tmp_path):
    write_bvh(_read(DATA / "two_joints_zxy.bvh"), tmp_path / "o.bvh")
    bvh = bvh_module._bvhio().readAsBvh(str(tmp_path / "o.bvh"))
    assert [j[0].Name for j in bvh.Root.layout()] == ["Hips", "Arm"]
    assert bvh.FrameCount == 3 and bvh.FrameTime == 0.04


@pytest.mark.parametrize("src", FIXTURES, ids=[p.name for p in FIXTURES])
def test_bvhio_parses_every_fixture_hierarchy(src):
    """The fixtures go through bvhio (the parser of record), not the scanner fallback."""
    bvh = bvh_module._bvhio().readAsBvh(str(src), loadKeyFrames=False)
    assert [j[0].Name for j in bvh.Root.layout()] == list(_read(src).skeleton.names)


# -- known values (worked out by hand from the fixture text) ---------------------------------
def test_two_joints_known_values():
    m = read_bvh(DATA / "two_joints_zxy.bvh")
    sk = m.skeleton
    assert sk.names == ("Hips", "Arm")
    np.testing.assert_array_equal(sk.parents, [-1, 0])
    np.testing.assert_array_equal(sk.offsets, [[0, 0, 0], [1.5, 0, 0]])
    assert sk.channels == (
        ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
        ("Zrotation", "Xrotation", "Yrotation"),
    )
    assert sk.rotation_order(0) == "ZXY" and sk.rotation_order(1) == "ZXY"
    assert np.isnan(sk.end_sites[0]).all()
    np.testing.assert_array_equal(sk.end_sites[1], [0, 2, 0])
    assert m.frame_time == 0.04 and m.n_frames == 3
    np.testing.assert_array_equal(m.channels[1], [1, 2, 3, 10, 20, 30, 90, 0, 0])
    np.testing.assert_array_equal(m.channels[2], [-1.5, 0.25, 7, -10, -20, -30, 0, 45, 0])
    assert m.source == str(DATA / "two_joints_zxy.bvh")
    # Arm: Zrotation 90 alone -> quaternion (cos 45, 0, 0, sin 45)
    np.testing.assert_allclose(m.rotations[1, 1], [np.sqrt(0.5), 0, 0, np.sqrt(0.5)], atol=1e-12)


def test_crlf_tabs_same_as_plain():
    raw = (DATA / "crlf_tabs.bvh").read_bytes()
    assert b"\r\n" in raw and b"\t" in raw  # guard against line-ending normalisation
    a, b = read_bvh(DATA / "crlf_tabs.bvh"), read_bvh(DATA / "two_joints_zxy.bvh")
    assert_same_hierarchy(a.skeleton, b.skeleton)
    np.testing.assert_array_equal(a.channels, b.channels)


def test_six_channel_non_root_joint_xyz():
    m = read_bvh(DATA / "xyz_six_channel_child.bvh")
    sk = m.skeleton
    assert sk.rotation_order(0) == sk.rotation_order(1) == sk.rotation_order(2) == "XYZ"
    assert sk.position_columns(1) == [7, 8, 6]  # Hand lists Z, X, Y position
    np.testing.assert_array_equal(m.translations[1, 1], [0.25, 10.125, 0.5])
    assert m.frame_time == 0.008333333


def test_no_end_site_written_without_end_site(tmp_path):
    m = read_bvh(DATA / "no_end_site_wrap360.bvh")
    assert np.isnan(m.skeleton.end_sites).all()
    np.testing.assert_array_equal(m.skeleton.parents, [-1, 0, 1, 0])
    write_bvh(m, tmp_path / "o.bvh")
    assert "End Site" not in (tmp_path / "o.bvh").read_text()


def test_rotations_in_0_360_kept_verbatim(tmp_path):
    m = read_bvh(DATA / "no_end_site_wrap360.bvh")
    assert m.channels[0, 3] == 356.4469 and m.channels[1, 11] == 360.0
    write_bvh(m, tmp_path / "o.bvh")
    np.testing.assert_array_equal(read_bvh(tmp_path / "o.bvh").channels, m.channels)


def test_lowercase_channels_normalised_and_prefixed_names_kept():
    m = read_bvh(DATA / "mixamo_lowercase.bvh")
    assert m.skeleton.names == ("mixamorig:Hips", "mixamorig:LeftHand")
    assert m.skeleton.channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    assert m.skeleton.channels[1] == ("Zrotation", "Xrotation", "Yrotation")
    assert m.skeleton.index("mixamorig:LeftHand") == 1


def test_joint_name_with_space_uses_scanner(tmp_path):
    """bvhio keeps the first word of a name only; the scan keeps the whole name."""
    text = (DATA / "two_joints_zxy.bvh").read_text().replace("JOINT Arm", "JOINT Left Arm")
    (tmp_path / "s.bvh").write_text(text)
    m = read_bvh(tmp_path / "s.bvh")
    assert m.skeleton.names == ("Hips", "Left Arm")
    out_dir = tmp_path / "rt"
    out_dir.mkdir()
    assert_round_trip(tmp_path / "s.bvh", out_dir)


# -- extra data rows -----------------------------------------------------------------------
def test_extra_row_warns_and_uses_header_count():
    with pytest.warns(SplicerWarning, match=r"3 rows but Frames: \(line 17\) says 2"):
        m = read_bvh(DATA / "extra_row.bvh")
    assert m.n_frames == 2
    np.testing.assert_array_equal(m.channels[0], np.zeros(9))
    np.testing.assert_array_equal(m.channels[1, -3:], [1.5, 2.5, 3.5])


@pytest.mark.shared
def test_leap_hands_extra_row(shared_motions):
    files = sorted((shared_motions / "leap-hands").glob("*.bvh"))
    assert files
    for f in files:
        header = int(re.search(r"Frames:\s*(\d+)", f.read_text()).group(1))
        with pytest.warns(SplicerWarning, match=f"{header + 1} rows but Frames"):
            m = read_bvh(f)
        assert m.n_frames == header
        assert m.skeleton.names[0] == "rForeArm" and m.skeleton.n_joints == 17


@pytest.mark.shared
def test_shared_quirks(shared_motions):
    zeggs = read_bvh(shared_motions / "zeggs" / "067_Speech_2_x_1_0.bvh")
    assert zeggs.channels.shape == (2065, 228) and zeggs.skeleton.n_joints == 75
    assert zeggs.skeleton.rotation_order(1) == "ZYX"
    movin = read_bvh(shared_motions / "movin" / "test1.bvh")  # CRLF, no End Site, 0..360, YXZ
    assert np.isnan(movin.skeleton.end_sites).all()
    assert movin.skeleton.rotation_order(0) == "YXZ" and movin.channels.max() > 180
    hand = read_bvh(shared_motions / "manipnet-hands" / "teapot3_leftHand.bvh")
    assert hand.skeleton.names[0] == "WRIST" and hand.n_frames == 4000


# -- malformed input -----------------------------------------------------------------------
BASE = (DATA / "two_joints_zxy.bvh").read_text()
BASE_LINES = BASE.splitlines()


def _edit(line: int, new: str | None) -> str:
    """BASE with 1-based ``line`` replaced by ``new`` (deleted when None)."""
    lines = list(BASE_LINES)
    if new is None:
        del lines[line - 1]
    else:
        lines[line - 1] = new
    return "\n".join(lines) + "\n"


MALFORMED = [
    # id, text, line, words the message must contain
    ("truncated-hierarchy", "\n".join(BASE_LINES[:9]) + "\n", 9, "end of file"),
    ("truncated-last-row", "\n".join(BASE_LINES[:20] + ["-1.5 0.25 7"]) + "\n", 21, "expected 9 values"),
    ("too-few-values", _edit(20, "1 2 3 10 20 30 90 0"), 20, "found 8"),
    ("too-many-values", _edit(20, "1 2 3 10 20 30 90 0 0 5"), 20, "found 10"),
    ("non-numeric", _edit(20, "1 2 3 10 abc 30 90 0 0"), 20, "'abc'"),
    ("nan-value", _edit(19, "0 0 0 0 nan 0 0 0 0"), 19, "'nan'"),
    ("missing-motion", _edit(16, None), 16, "expected MOTION"),
    ("missing-hierarchy", _edit(1, None), 1, "expected HIERARCHY"),
    ("unknown-channel", _edit(9, "CHANNELS 3 Zrotation Qrotation Yrotation"), 9, "unknown channel 'Qrotation'"),
    ("channel-count", _edit(9, "CHANNELS 4 Zrotation Xrotation Yrotation"), 9, "count says 4 but 3"),
    ("frames-not-number", _edit(17, "Frames: abc"), 17, "whole number"),
    ("frames-missing", _edit(17, None), 17, "expected Frames:"),
    ("frame-time-zero", _edit(18, "Frame Time: 0"), 18, "positive"),
    ("frame-time-negative", _edit(18, "Frame Time: -0.04"), 18, "positive"),
    ("frame-time-text", _edit(18, "Frame Time: fast"), 18, "expected a number"),
    ("fewer-rows-than-frames", _edit(17, "Frames: 5"), 17, "truncated"),
    ("missing-close-brace", _edit(14, None), 15, "closing joint 'Hips' (opened at line 2)"),
    ("extra-close-brace", "\n".join(BASE_LINES[:15] + ["}"] + BASE_LINES[15:]) + "\n", 16, "unbalanced braces"),
    ("missing-open-brace", _edit(7, None), 7, "expected '{'"),
    ("missing-offset", _edit(8, None), 8, "expected OFFSET"),
    ("offset-not-number", _edit(8, "OFFSET 1.5 x 0"), 8, "'x'"),
    ("root-without-name", _edit(2, "ROOT"), 2, "joint name"),
    ("duplicate-joint", _edit(6, "JOINT Hips"), 6, "duplicate joint name 'Hips'"),
    ("empty", "", 1, "empty"),
    ("blank-only", "\n  \n\t\n", 1, "empty"),
]


@pytest.mark.parametrize("text,line,words", [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED])
def test_malformed(tmp_path, text, line, words):
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    with pytest.raises(BVHError) as info:
        read_bvh(path)
    err = info.value
    assert err.line == line, str(err)
    assert str(err).startswith(f"{path}, line {line}: "), str(err)
    assert words in str(err)


def test_malformed_crlf_line_numbers(tmp_path):
    path = tmp_path / "bad.bvh"
    path.write_bytes(_edit(20, "1 2 3").replace("\n", "\r\n").encode())
    with pytest.raises(BVHError, match=r", line 20: expected 9 values"):
        read_bvh(path)


def test_binary_garbage_with_nul(tmp_path):
    path = tmp_path / "bad.bvh"
    path.write_bytes(b"HIERARCHY\nROOT a\n\x00\x01\x02\xff")
    with pytest.raises(BVHError, match=r", line 3: binary data"):
        read_bvh(path)


def test_binary_garbage_without_nul(tmp_path, rng):
    path = tmp_path / "bad.bvh"
    path.write_bytes(b"\x89PNG" + rng.integers(1, 256, 4000, dtype=np.uint8).tobytes())
    with pytest.raises(BVHError, match=r"expected HIERARCHY") as info:
        read_bvh(path)
    assert info.value.line == 1 and str(path) in str(info.value)


def test_file_not_found(tmp_path):
    with pytest.raises(BVHError, match="file not found") as info:
        read_bvh(tmp_path / "nope.bvh")
    assert str(tmp_path / "nope.bvh") in str(info.value)


def test_directory(tmp_path):
    with pytest.raises(BVHError, match="is a directory") as info:
        read_bvh(tmp_path)
    assert str(info.value).startswith(str(tmp_path))


# -- inputs untouched, atomic output -----------------------------------------------------------
def test_read_and_write_do_not_modify_input(tmp_path):
    src = DATA / "two_joints_zxy.bvh"
    before, mtime = _sha(src), src.stat().st_mtime_ns
    m = read_bvh(src)
    channels = np.array(m.channels)
    write_bvh(m, tmp_path / "o.bvh")
    assert _sha(src) == before and src.stat().st_mtime_ns == mtime
    np.testing.assert_array_equal(m.channels, channels)


def test_write_missing_directory(tmp_path):
    dest = tmp_path / "no" / "such" / "out.bvh"
    with pytest.raises(BVHError, match="does not exist") as info:
        write_bvh(_read(DATA / "two_joints_zxy.bvh"), dest)
    assert str(dest) in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_write_to_directory_path(tmp_path):
    with pytest.raises(BVHError, match="is a directory"):
        write_bvh(_read(DATA / "two_joints_zxy.bvh"), tmp_path)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0,
                    reason="root ignores directory permissions, so an unwritable directory cannot be made")
def test_write_unwritable_directory(tmp_path):
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o500)
    try:
        with pytest.raises(BVHError, match="cannot write") as info:
            write_bvh(_read(DATA / "two_joints_zxy.bvh"), d / "out.bvh")
        assert str(d / "out.bvh") in str(info.value)
        assert list(d.iterdir()) == []
    finally:
        d.chmod(0o700)


@pytest.mark.parametrize("exc", [OSError(28, "No space left on device"), RuntimeError("boom")])
def test_failed_write_leaves_no_temp_and_keeps_destination(tmp_path, monkeypatch, exc):
    dest = tmp_path / "out.bvh"
    dest.write_text("old content\n")
    m = _read(DATA / "two_joints_zxy.bvh")

    def fail(*args, **kwargs):
        raise exc

    from splicer.io import bvh_write

    monkeypatch.setattr(bvh_write, "_motion_text", fail)  # fails mid-write, after the header
    expected = BVHError if isinstance(exc, OSError) else RuntimeError
    with pytest.raises(expected) as info:
        write_bvh(m, dest)
    if expected is BVHError:
        assert str(dest) in str(info.value) and "No space left" in str(info.value)
    assert dest.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bvh"]


def test_failed_replace_removes_temp(tmp_path, monkeypatch):
    dest = tmp_path / "out.bvh"

    def fail(src, dst):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(bvh_module.os, "replace", fail)
    with pytest.raises(BVHError, match="Permission denied"):
        write_bvh(_read(DATA / "two_joints_zxy.bvh"), dest)
    assert list(tmp_path.iterdir()) == []


def test_write_replaces_existing_file(tmp_path):
    dest = tmp_path / "out.bvh"
    dest.write_text("old\n")
    write_bvh(_read(DATA / "two_joints_zxy.bvh"), dest)
    assert dest.read_text().startswith("HIERARCHY\n")
    assert [p.name for p in tmp_path.iterdir()] == ["out.bvh"]


def test_write_rejects_non_finite_values(tmp_path):
    m = _read(DATA / "two_joints_zxy.bvh")
    ch = np.array(m.channels)
    ch[2, 7] = np.nan
    with pytest.raises(BVHError, match=r"not finite at frame 2 \(joint 'Arm'"):
        write_bvh(m.with_channels(ch), tmp_path / "o.bvh")
    assert list(tmp_path.iterdir()) == []


def test_written_text_is_standard(tmp_path):
    write_bvh(_read(DATA / "two_joints_zxy.bvh"), tmp_path / "o.bvh")
    text = (tmp_path / "o.bvh").read_text()
    assert text.splitlines()[:5] == [
        "HIERARCHY",
        "ROOT Hips",
        "{",
        "\tOFFSET 0 0 0",
        "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    ]
    assert "\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 2 0\n\t\t}\n" in text
    assert "MOTION\nFrames: 3\nFrame Time: 0.04\n0 0 0 0 0 0 0 0 0\n1 2 3 10 20 30 90 0 0\n" in text


# -- the bvhio cross-check -----------------------------------------------------------------
def test_scanner_used_when_bvhio_fails(monkeypatch):
    class Broken:
        def readAsBvh(self, path, loadKeyFrames):
            raise SyntaxError("bvhio cannot parse this")

    monkeypatch.setattr(bvh_header, "load_bvhio", Broken)
    m = read_bvh(DATA / "two_joints_zxy.bvh")
    assert m.skeleton.names == ("Hips", "Arm")


def test_bvhio_disagreement_is_reported(monkeypatch):
    real = bvh_module._bvhio()

    class Shifted:
        def readAsBvh(self, path, loadKeyFrames):
            bvh = real.readAsBvh(path, loadKeyFrames=loadKeyFrames)
            bvh.Root.Children[0].Offset.x += 1.0
            return bvh

    monkeypatch.setattr(bvh_header, "load_bvhio", Shifted)
    with pytest.raises(BVHError, match="offset of joint 'Arm' differs"):
        read_bvh(DATA / "two_joints_zxy.bvh")


def test_utf8_bom(tmp_path):
    path = tmp_path / "bom.bvh"
    path.write_bytes(b"\xef\xbb\xbf" + (DATA / "two_joints_zxy.bvh").read_bytes())
    np.testing.assert_array_equal(read_bvh(path).channels, read_bvh(DATA / "two_joints_zxy.bvh").channels)


def test_zero_frames(tmp_path):
    path = tmp_path / "z.bvh"
    path.write_text("\n".join(BASE_LINES[:16] + ["Frames: 0", "Frame Time: 0.04"]) + "\n")
    m = read_bvh(path)
    assert m.channels.shape == (0, 9)
    write_bvh(m, tmp_path / "o.bvh")
    assert read_bvh(tmp_path / "o.bvh").channels.shape == (0, 9)
