"""Marker roles by name for common marker sets, overrides, errors; the shared Vicon capture."""

import numpy as np
import pytest

from splicer.io.config import parse_config
from splicer.errors import RoleError
from splicer.rig.marker_arm import arm_from_trajectories
from splicer.rig.marker_roles import detect_marker_up, find_marker_roles, marker_sides
from splicer.io.trajectories import Trajectories


def _traj(labels, n=6, source="m.c3d", seed=0):
    pts = np.random.default_rng(seed).normal(size=(n, len(labels), 3))
    return Trajectories(tuple(labels), pts, 100.0, 1, "mm", source)


PIG = ["RWRA", "RWRB", "RFRM", "RFIN", "RSHO", "LWRA", "LWRB", "LFRM", "LFIN", "LSHO", "RELB", "C7"]


def test_plug_in_gait_both_sides():
    t = _traj(PIG)
    r = find_marker_roles(t, "left")
    assert r.marker_set == "Plug-in Gait" and r.sided
    assert r.labels(t) == {"p1": ["LWRA"], "p2": ["LWRB"], "p3": ["LFRM"], "p4": ["LFIN"], "shoulder": ["LSHO"]}
    assert sorted(marker_sides(t)) == ["left", "right"]


def test_biomechanics_unsided_with_subject_prefix_and_clusters():
    names = ["STYLr", "STYLu", "LARMl", "LARMm", "LARM_elb", "LARM_ant", "INDEX", "LASTC", "MEDH", "LATH", "ACRO_tip"]
    t = _traj([f"Daphnee:{s}" for s in names])
    r = find_marker_roles(t, "right")
    assert r.marker_set == "biomechanics" and not r.sided
    assert r.segments["hand"] == (6, 7, 8, 9)
    assert r.roles["p3"] == (2, 3, 4, 5) and r.roles["p4"] == (6, 7) and r.roles["shoulder"] == (10,)
    assert marker_sides(t) == {}  # the names tell no side
    arm = arm_from_trajectories(t, "right", mapping={"up": "z"})
    np.testing.assert_allclose(arm.markers.points[:, 2], t.points[:, 2:6].mean(axis=1))  # cluster averaged
    np.testing.assert_allclose(arm.markers.shoulder, t.points[:, 10])
    assert any("tell no side" in n for n in arm.notes)


def test_biomechanics_shoulder_is_the_acromion_cluster_mean():
    """The shoulder (every marker's reference) is the mean of the acromion's neighbours the set
    has; a set with only one of them uses it, and far scapula markers never join."""
    arm_names = ["STYLr", "STYLu", "LARMl", "LARMm", "INDEX", "LASTC", "MEDH", "LATH"]
    t = _traj(arm_names + ["ACRO_tip", "CLAV_AC", "SCAP_AA", "SCAP_IA"])
    r = find_marker_roles(t, "right")
    assert r.roles["shoulder"] == (8, 9, 10)
    arm = arm_from_trajectories(t, "right", mapping={"up": "z"})
    np.testing.assert_allclose(arm.markers.shoulder, t.points[:, 8:11].mean(axis=1))
    for only in ("CLAV_AC", "ACRO"):
        t1 = _traj(arm_names + [only, "SCAP_IA"])
        assert find_marker_roles(t1, "right").labels(t1)["shoulder"] == [only]


def test_optitrack_style_sided():
    t = _traj(["RWristOut", "RWristIn", "RForeArm", "RHandOut", "RHandIn", "RShoulderTop", "LWristOut"])
    r = find_marker_roles(t, "right")
    assert r.marker_set == "OptiTrack/Qualisys"
    assert r.labels(t)["p4"] == ["RHandOut", "RHandIn"]
    assert list(marker_sides(t)) == ["right"]


def test_mapping_overrides_and_missing_role_error():
    t = _traj(["W1", "W2", "F", "H", "S", "X"])
    cfg = parse_config("markers:\n  hands:\n    right: {p1: W1, p2: W2, p3: [F, X], p4: H, shoulder: S}\n")
    r = find_marker_roles(t, "right", mapping=cfg.markers["hands"])
    assert r.roles == {"p1": (0,), "p2": (1,), "p3": (2, 5), "p4": (3,), "shoulder": (4,)}
    with pytest.raises(RoleError) as e:
        find_marker_roles(t, "right")
    msg = str(e.value)
    assert "\n" not in msg and "no right-side marker for p1, p2, p3, p4, shoulder" in msg
    assert "Labels found: W1, W2, F, H, S, X" in msg
    with pytest.raises(RoleError, match="marker 'nope' is not in"):
        find_marker_roles(t, "right", mapping={"right": {"p1": "nope"}})


def test_up_axis_from_the_trunk_and_upright():
    pts = np.zeros((3, 2, 3))
    pts[:, 0] = [0, 0, 1000]  # C7 above the sacrum along +z
    pts[:, 1] = [0, 0, 100]  # SACR
    t = Trajectories(("C7", "SACR"), pts, 100.0, 1, "mm", "x.trc")
    assert detect_marker_up(t)[:2] == (2, 1.0)
    pts[:, :, [1, 2]] = -pts[:, :, [2, 1]]
    assert detect_marker_up(Trajectories(("C7", "SACR"), pts, 100.0, 1, "mm", "x.trc"))[:2] == (1, -1.0)
    assert detect_marker_up(Trajectories(("A",), pts[:, :1], 100.0, 1, "mm", "x.trc"))[:2] == (1, 1.0)  # TRC: y
    labels = PIG[:5]
    q = np.random.default_rng(1).normal(size=(4, 5, 3))
    arm = arm_from_trajectories(Trajectories(tuple(labels), q, 50.0), "right", mapping={"up": "-y"})
    np.testing.assert_allclose(arm.markers.points[:, 0], q[:, 0] * [1, -1, -1])  # a half turn about x
    assert arm.markers.up == 1


def test_shared_vicon_capture(shared_motions):
    from splicer.io.trajectories import read_c3d

    t = read_c3d(shared_motions / "c3d" / "markers_analogs.c3d")
    assert (t.n_frames, t.n_markers, t.fps, t.units) == (580, 51, 100.0, "mm")
    assert 0.005 < t.missing.mean() < 0.02
    arm = arm_from_trajectories(t, "right")  # no configuration
    assert arm.roles.labels(t)["p1"] == ["Daphnee:STYLr"]
    # the acromion's neighbours are averaged with it (its noise is every coordinate's); the
    # scapula's far markers (SCAP_IA, SCAP_RS, ...) are not
    assert arm.roles.labels(t)["shoulder"] == [f"Daphnee:{s}" for s in ("ACRO_tip", "CLAV_AC", "SCAP_AA")]
    assert arm.roles.labels(t)["p3"] == [f"Daphnee:{s}" for s in ("LARMl", "LARMm", "LARM_elb", "LARM_ant")]
    assert arm.markers.up == 2 and np.isfinite(arm.markers.points).all()
    filled = {(f.label, f.start) for f in arm.gaps.fills}
    role_cols = sorted({c for cols in arm.roles.roles.values() for c in cols})
    expected = {(t.labels[c], a) for c in role_cols
                for a in np.flatnonzero(np.diff(np.concatenate([[0], t.missing[:, c].astype(int)])) == 1)}
    assert filled == expected and len(filled) == 13
    assert {f.method for f in arm.gaps.fills} == {"rigid", "pattern"}
    seen = ~t.missing[:, role_cols]
    np.testing.assert_array_equal(arm.gaps.trajectories.points[:, role_cols][seen], t.points[:, role_cols][seen])
    rep = arm.report(t)
    assert rep["marker_set"] == "biomechanics" and len(rep["gaps_filled"]) == 13


def test_on_frames_resamples_onto_the_take(rng):
    from splicer.rig.marker_arm import on_frames
    from splicer.rig.markers import Markers

    t = np.arange(101) / 100.0  # 1 s at 100 Hz, moving at (3, -1, 2) units per second
    pts = np.stack([3 * t, -t, 2 * t], axis=1)[:, None, :] + np.zeros((1, 4, 3))
    mk = Markers(pts, pts[:, 0], np.zeros(101), 2, 100.0, "right")
    out, notes = on_frames(mk, 31, 30.0, what="m.c3d")
    assert out.n_frames == 31 and out.fps == 30.0 and notes == ()
    i = np.arange(5, 26)  # away from the ends, where the anti-aliasing filter sees both sides
    np.testing.assert_allclose(out.points[i, 2], np.stack([3 * i / 30, -i / 30, 2 * i / 30], axis=1), atol=1e-9)
    longer, notes = on_frames(mk, 40, 30.0, what="m.c3d")
    assert longer.n_frames == 40 and np.all(longer.points[30:] == longer.points[30])
    assert "the markers last 1.00 s but the take 1.30 s" in notes[0]


def test_retime_known_answer():
    from splicer.markers_cli import retime

    pts = np.arange(5, dtype=float)[:, None, None] * np.ones((1, 2, 3))
    pts[3, 1] = np.nan
    t = Trajectories(("A", "B"), pts, 10.0)
    out = retime(t, np.array([0.0, 1.5, 2.0, 2.5, 3.0, 4.0]), fps=5.0, first_frame=1)
    np.testing.assert_allclose(out[:, 0, 0], [0, 1.5, 2, 2.5, 3, 4])
    np.testing.assert_allclose(out[:, 1, 0], [0, 1.5, 2, np.nan, np.nan, 4])  # next to B's gap: missing
