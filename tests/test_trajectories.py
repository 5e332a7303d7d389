"""Marker readers: known-answer C3D, TRC and CSV files written in the test; damaged files."""

import numpy as np
import pytest

c3d = pytest.importorskip("c3d")

from splicer.io.trajectories import Trajectories, TrajectoryError, read_c3d, read_trajectories, read_trc  # noqa: E402
from splicer.io.trajectory_csv import read_csv  # noqa: E402
from splicer.io.trajectory_writers import write_c3d, write_trc  # noqa: E402


def _tiny_c3d(path, *, first=5, rate=50.0, units="mm  "):
    """Three frames, two markers; B is missing (residual -1) in frame 2."""
    w = c3d.Writer(point_rate=rate, analog_rate=0.0, point_scale=-1.0, point_units=units)
    w.set_point_labels(["Subj:STYLr", "Subj:STYLu"])
    w.set_start_frame(first)
    frames = []
    for t in range(3):
        pts = np.zeros((2, 5), np.float32)
        pts[0, :3] = [10.0 * t, 1.0, 2.0]
        pts[1, :3] = [0.0, 20.0 + t, 5.0]
        if t == 1:
            pts[1, :3] = 0.0
            pts[1, 3] = -1.0
        frames.append((pts, np.zeros((0, 0), np.float32)))
    w.add_frames(frames)
    with open(path, "wb") as f, pytest.warns(UserWarning, match="No analog"):
        w.write(f)


def test_c3d_known_answer(tmp_path):
    p = tmp_path / "tiny.c3d"
    _tiny_c3d(p)
    t = read_c3d(p)
    assert t.labels == ("Subj:STYLr", "Subj:STYLu")
    assert t.names == ("STYLr", "STYLu")
    assert t.fps == 50.0 and t.first_frame == 5 and t.units == "mm" and t.n_frames == 3
    np.testing.assert_allclose(t.points[:, 0], [[0, 1, 2], [10, 1, 2], [20, 1, 2]])
    assert np.isnan(t.points[1, 1]).all() and not np.isnan(t.points[[0, 2], 1]).any()
    np.testing.assert_allclose(t.points[2, 1], [0, 22, 5])
    assert t.index("stylu") == 1 and t.index("Subj:STYLr") == 0 and t.index("WRA") is None


def test_c3d_units_converted(tmp_path):
    p = tmp_path / "tiny.c3d"
    _tiny_c3d(p)
    t = read_c3d(p, units="m")
    assert t.units == "m"
    np.testing.assert_allclose(t.points[2, 0], [0.02, 0.001, 0.002])
    assert read_c3d(p, units=None).units == "mm"


def test_c3d_round_trip(tmp_path):
    pts = np.arange(24, dtype=float).reshape(4, 2, 3) + 1.0
    pts[2, 0] = np.nan
    t = Trajectories(("A", "B"), pts, 120.0, 7, "mm", "x")
    write_c3d(t, tmp_path / "r.c3d")
    u = read_c3d(tmp_path / "r.c3d")
    assert (u.labels, u.fps, u.first_frame, u.n_frames) == (("A", "B"), 120.0, 7, 4)
    np.testing.assert_array_equal(np.isnan(u.points), np.isnan(pts))
    np.testing.assert_allclose(u.points[~np.isnan(pts)], pts[~np.isnan(pts)])


@pytest.mark.parametrize("data", [b"", b"hello\n" * 50, bytes(range(256)) * 4])
def test_c3d_damaged_is_one_line(tmp_path, data):
    p = tmp_path / "bad.c3d"
    p.write_bytes(data)
    with pytest.raises(TrajectoryError, match=r"bad\.c3d: not a readable C3D file") as e:
        read_c3d(p)
    assert "\n" not in str(e.value)


def test_c3d_cut_short_is_reported(tmp_path):
    p = tmp_path / "tiny.c3d"
    _tiny_c3d(p)
    data = p.read_bytes()
    # the data section is the last 512-byte block: 3 frames x 2 markers x 16 bytes; cut inside frame 3
    (tmp_path / "cut.c3d").write_bytes(data[:len(data) - 512 + 2 * 32 + 8])
    t = read_c3d(tmp_path / "cut.c3d")
    assert t.n_frames == 2
    assert any("ends after 2 of its 3 frames" in w for w in t.warnings)


TRC = """PathFileType\t4\t(X/Y/Z)\tx.trc
DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames
60\t60\t3\t2\tm\t60\t11\t3
Frame#\tTime\tRWRA\t\t\tRWRB
\t\tX1\tY1\tZ1\tX2\tY2\tZ2

11\t0.0\t0.1\t0.2\t0.3\t1.0\t1.0\t1.0
12\t0.0167\t0.2\t0.2\t0.3\t\t\t
13\t0.0333\t0.3\t0.2\t0.3\tNaN\tNaN\tNaN
"""


def test_trc_known_answer(tmp_path):
    p = tmp_path / "x.trc"
    p.write_text(TRC)
    t = read_trajectories(p)
    assert t.labels == ("RWRA", "RWRB") and t.fps == 60.0 and t.first_frame == 11 and t.units == "mm"
    np.testing.assert_allclose(t.points[:, 0], [[100, 200, 300], [200, 200, 300], [300, 200, 300]])
    np.testing.assert_allclose(t.points[0, 1], [1000, 1000, 1000])
    assert np.isnan(t.points[1:, 1]).all()
    write_trc(t, tmp_path / "y.trc")
    u = read_trc(tmp_path / "y.trc")
    np.testing.assert_allclose(u.points, t.points)
    assert (u.first_frame, u.fps) == (11, 60.0)


def test_trc_bad_number_names_line(tmp_path):
    p = tmp_path / "x.trc"
    p.write_text(TRC.replace("0.2\t0.2\t0.3\t\t\t", "0.2\tfoo\t0.3\t\t\t"))
    with pytest.raises(TrajectoryError, match=r"x\.trc, line 8, column 4: expected a number, got 'foo'"):
        read_trc(p)


def test_csv_plain_known_answer(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("frame,time,RWRA_x,RWRA_y,RWRA_z,RWRB:X,RWRB:Y,RWRB:Z\n"
                 "3,0.00,1,2,3,4,5,6\n4,0.01,1.5,2,3,,,\n5,0.02,2,2,3,4,5,7\n")
    t = read_csv(p, file_units="cm")
    assert t.labels == ("RWRA", "RWRB") and t.first_frame == 3 and t.units == "mm"
    assert t.fps == pytest.approx(100.0)
    np.testing.assert_allclose(t.points[1, 0], [15, 20, 30])
    assert np.isnan(t.points[1, 1]).all()
    np.testing.assert_allclose(t.points[2, 1], [40, 50, 70])


def test_csv_without_rate_is_an_error(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("A_x,A_y,A_z\n1,2,3\n")
    with pytest.raises(TrajectoryError, match="give the rate"):
        read_csv(p)
    assert read_csv(p, fps=25.0).fps == 25.0


def test_csv_nexus_export(tmp_path):
    p = tmp_path / "n.csv"
    p.write_text("Trajectories\n100\n,,Daphnee:STYLr,,,Daphnee:STYLu,,\nFrame,Sub Frame,X,Y,Z,X,Y,Z\n"
                 ",,mm,mm,mm,mm,mm,mm\n1,0,1,2,3,4,5,6\n2,0,1,2,4,,,\n\nModel Outputs\n")
    t = read_csv(p)
    assert t.labels == ("Daphnee:STYLr", "Daphnee:STYLu") and t.fps == 100.0 and t.first_frame == 1
    np.testing.assert_allclose(t.points[1, 0], [1, 2, 4])
    assert np.isnan(t.points[1, 1]).all()


def test_unknown_extension(tmp_path):
    with pytest.raises(TrajectoryError, match="unknown marker file type '.mkr'"):
        read_trajectories(tmp_path / "a.mkr")
