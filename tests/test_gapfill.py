"""Gap filling: rigid fill is exact for a rigid cluster; pattern, cubic and constant-velocity fills; reports."""

import numpy as np
import pytest

from splicer.rig.gapfill import fill_gaps, missing_runs, rigid_transform
from splicer.model.rotations import quat_to_matrix
from splicer.io.trajectories import Trajectories


def _rotations(rng, n):
    q = rng.normal(size=(n, 4))
    return quat_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))


def _rigid_cluster(rng, n=40, k=5):
    body = rng.normal(scale=50.0, size=(k, 3))
    rot = _rotations(rng, n)
    trans = np.cumsum(rng.normal(scale=5.0, size=(n, 3)), axis=0)
    return np.einsum("tij,kj->tki", rot, body) + trans[:, None, :]


def test_missing_runs():
    assert missing_runs(np.array([0, 1, 1, 0, 1, 0, 0, 1], bool)) == [(1, 3), (4, 5), (7, 8)]
    assert missing_runs(np.zeros(4, bool)) == []


def test_rigid_transform_matches_a_slow_reference(rng):
    src = rng.normal(size=(4, 3))
    rot = _rotations(rng, 6)
    t = rng.normal(size=(6, 3))
    dst = np.einsum("gij,kj->gki", rot, src) + t[:, None]
    r, tt = rigid_transform(src, dst)
    for g in range(6):  # reference: one frame at a time, the textbook Kabsch steps
        a, b = src - src.mean(0), dst[g] - dst[g].mean(0)
        u, _, vt = np.linalg.svd(a.T @ b)
        d = np.sign(np.linalg.det(vt.T @ u.T))
        ref = vt.T @ np.diag([1, 1, d]) @ u.T
        np.testing.assert_allclose(r[g], ref, atol=1e-10)
        np.testing.assert_allclose(r[g], rot[g], atol=1e-10)
    np.testing.assert_allclose(tt, t, atol=1e-9)


def test_rigid_fill_recovers_a_removed_marker_exactly(rng):
    pts = _rigid_cluster(rng)
    holed = pts.copy()
    holed[10:25, 0] = np.nan  # interior gap
    holed[35:, 1] = np.nan  # gap at the end
    traj = Trajectories(tuple("ABCDE"), holed, 100.0, 1, "mm", "c.c3d")
    out = fill_gaps(traj, {"forearm": range(5)})
    np.testing.assert_allclose(out.trajectories.points, pts, atol=1e-8)
    assert [(f.label, f.start, f.stop, f.method) for f in out.fills] == [("A", 10, 25, "rigid"), ("B", 35, 40, "rigid")]
    assert out.fills[0].donors == ("B", "C", "D", "E")
    assert out.fills[0].to_dict()["frames"] == [11, 25] and out.warnings == ()


def test_cubic_fill_reproduces_a_cubic(rng):
    t = np.arange(30, dtype=float)
    x = np.stack([0.01 * t**3 - t, 2 * t**2, 5 + 0 * t], axis=1)
    holed = x.copy()[:, None, :]
    holed[12:18, 0] = np.nan
    traj = Trajectories(("A",), holed, 100.0, 1, "mm", "c")
    out = fill_gaps(traj)
    np.testing.assert_allclose(out.trajectories.points[:, 0], x, atol=1e-9)
    assert out.fills[0].method == "cubic"


def test_end_gaps_constant_velocity_and_long_gap_warning():
    t = np.arange(100, dtype=float)
    x = np.stack([3 * t, -t, 0 * t + 7], axis=1)[:, None, :]
    holed = x.copy()
    holed[:4, 0] = np.nan
    holed[40:100, 0] = np.nan
    traj = Trajectories(("Sub:M",), holed, 100.0, 1, "mm", "e.c3d")
    out = fill_gaps(traj, max_gap_s=0.5)
    np.testing.assert_allclose(out.trajectories.points, x, atol=1e-9)
    assert [f.method for f in out.fills] == ["constant velocity", "constant velocity"]
    assert [f.too_long for f in out.fills] == [False, True]
    assert len(out.warnings) == 1
    assert "Sub:M: frames 41-100 (0.60 s) by constant velocity" in out.warnings[0]
    assert "0.5 s limit" in out.warnings[0]


def test_too_few_donors_for_a_rigid_fit_follow_the_pattern(rng):
    pts = _rigid_cluster(rng, k=4)
    holed = pts.copy()
    holed[10:15, 0] = np.nan
    holed[12, 3] = np.nan  # D hidden during A's gap: only B and C are donors, for either
    holed[20, 3] = np.nan  # D hidden alone: A, B, C carry it
    out = fill_gaps(Trajectories(tuple("ABCD"), holed, 100.0, 1, "mm", "c"), {"s": range(4)})
    assert [(f.label, f.method, set(f.donors)) for f in out.fills] == [
        ("A", "pattern", {"B", "C"}), ("D", "pattern", {"B", "C"}), ("D", "rigid", {"A", "B", "C"})]
    assert out.fills[0].describe() == "A: frames 11-15 (0.05 s) by pattern"


def test_pattern_fill_worked_answer():
    """The marker is its donors' path plus an offset moving linearly across the gap."""
    t = np.arange(12, dtype=float)
    donor1 = np.stack([np.sin(t), t**2, 0 * t], axis=1)  # any path
    donor2 = donor1 + [0.0, 0.0, 10.0]
    marker = donor1 + np.stack([1.0 + 0.5 * t, 0 * t, 5 + 0 * t], axis=1)  # offset from donor1: linear in time
    pts = np.stack([marker, donor1, donor2], axis=1)
    holed = pts.copy()
    holed[4:8, 0] = np.nan  # interior: offsets at rows 3 and 8 interpolated
    holed[10:, 0] = np.nan  # at the end: the offset at row 9 held
    out = fill_gaps(Trajectories(("M", "D1", "D2"), holed, 10.0, 1, "mm", "p"), {"hand": [0, 1, 2]}, columns=[0])
    got = out.trajectories.points[:, 0]
    np.testing.assert_allclose(got[:10], marker[:10], atol=1e-12)  # linear offsets are reproduced exactly
    np.testing.assert_allclose(got[10:], donor1[10:] + [1.0 + 0.5 * 9, 0.0, 5.0], atol=1e-12)  # held offset
    assert [(f.start, f.stop, f.method, f.donors) for f in out.fills] == [(4, 8, "pattern", ("D1", "D2")),
                                                                          (10, 12, "pattern", ("D1", "D2"))]


def test_pattern_fill_uses_the_two_nearest_donors():
    t = np.arange(10, dtype=float)[:, None]
    path = np.hstack([t, t**2, 0 * t])
    offs = [[0, 0, 0], [1, 0, 0], [0, 100, 0], [0, 0, 2]]  # M, then donors at 100, 1 and 2 units
    pts = np.stack([path + o for o in offs], axis=1)
    pts[:, 2, 0] += np.sin(t[:, 0])  # the far donor wobbles: it must not be used
    pts[:, 3, 2] += 0.1 * t[:, 0] ** 2  # the second-nearest bends: averaged with the nearest
    holed = pts.copy()
    holed[3:6, 0] = np.nan
    out = fill_gaps(Trajectories(("M", "A", "FAR", "B"), holed, 10.0, 1, "mm", "p"), {"s": [0, 1, 2]}, columns=[0])
    assert out.fills[0].donors == ("A", "FAR")  # only segment mates donate: B is in no segment with M
    out = fill_gaps(Trajectories(("M", "A", "FAR", "B"), holed, 10.0, 1, "mm", "p"), {"s": [0, 1, 2, 3]}, columns=[0])
    f = out.fills[0]
    assert (f.method, f.donors) == ("rigid", ("A", "FAR", "B"))  # three donors: a rigid fit instead
    out = fill_gaps(Trajectories(("M", "A", "FAR", "B"), holed, 10.0, 1, "mm", "p"), {"s": [0, 1, 2, 3]}, columns=[0],
                    min_donors=4)
    f = out.fills[0]
    assert (f.method, f.donors) == ("pattern", ("A", "B"))
    bend = 0.1 * t[3:6, 0] ** 2 - (0.1 * 4 + (0.1 * 36 - 0.1 * 4) * np.array([1, 2, 3]) / 4)  # B's bend less its line
    np.testing.assert_allclose(out.trajectories.points[3:6, 0], path[3:6] + np.outer(bend / 2, [0, 0, 1]), atol=1e-12)


def test_never_seen_is_reported():
    pts = np.full((5, 1, 3), np.nan)
    out = fill_gaps(Trajectories(("X",), pts, 10.0, 1, "mm", "n.c3d"))
    assert out.fills == () and "marker X is never seen" in out.warnings[0]


def test_min_donors_checked():
    with pytest.raises(ValueError):
        fill_gaps(Trajectories(("X",), np.zeros((2, 1, 3)), 10.0), min_donors=2)
