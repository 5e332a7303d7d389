"""Rigid segment fits, the wrist centre (SCoRE) and the paper's markers derived from them."""

import numpy as np
import pytest

from splicer.errors import RoleError
from splicer.io.trajectories import Trajectories
from splicer.rig.marker_arm import arm_from_trajectories
from splicer.rig.segment_fit import cluster_shape, fit_segment, joint_centre, rigid_markers


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


SHAPE = np.array([[0.0, 0.0, 0.0], [40.0, 0.0, 0.0], [0.0, 30.0, 0.0], [10.0, 10.0, 20.0]])


def test_fit_segment_recovers_a_known_rigid_motion():
    # frame t: turned by 0.1 t rad about z and moved by (t, 2t, 0): the fit places the shape exactly
    rots = np.stack([_rot_z(0.1 * t) for t in range(6)])
    moves = np.array([[t, 2.0 * t, 0.0] for t in range(6)])
    pts = np.einsum("tij,kj->tki", rots, SHAPE) + moves[:, None, :]
    fit = fit_segment(pts)
    assert fit.rms < 1e-9
    # the shape keeps the cluster's distances (hand-checked: |m0 m1| = 40, |m0 m2| = 30, |m1 m2| = 50)
    d = np.linalg.norm(fit.shape[:, None] - fit.shape[None], axis=-1)
    np.testing.assert_allclose([d[0, 1], d[0, 2], d[1, 2]], [40.0, 30.0, 50.0], atol=1e-9)
    # the marker 0 (the origin of SHAPE) is carried exactly: at the move of each frame
    np.testing.assert_allclose(fit.world(fit.shape[0]), moves, atol=1e-9)
    np.testing.assert_allclose(fit.local(moves), np.broadcast_to(fit.shape[0], (6, 3)), atol=1e-9)
    # relative rotations between frames are those applied
    np.testing.assert_allclose(fit.rotation[3] @ fit.rotation[0].T, _rot_z(0.3), atol=1e-9)


def test_cluster_shape_is_centred_and_fit_averages_noise():
    rng = np.random.default_rng(3)
    rots = np.stack([_rot_z(0.02 * t) @ _rot_x(0.01 * t) for t in range(200)])
    clean = np.einsum("tij,kj->tki", rots, SHAPE) + np.array([5.0, -3.0, 1.0])
    noisy = clean + rng.normal(0.0, 1.0, clean.shape)
    shape = cluster_shape(noisy)
    np.testing.assert_allclose(shape.mean(axis=0), 0.0, atol=1e-9)
    fit = fit_segment(noisy)
    # the cluster's centre from the fit is the mean of the four markers: noise sd 1 / sqrt(4) = 0.5 per axis
    err_fit = fit.world(fit.shape.mean(axis=0)) - clean.mean(axis=1)
    assert 0.35 < err_fit.std() < 0.65
    assert 0.6 < fit.rms < 1.6  # about sqrt(3 * (1 - 6/12))... of the per-marker noise of 1 per axis
    with pytest.raises(ValueError, match="fill the gaps"):
        fit_segment(np.where(np.arange(200)[:, None, None] == 5, np.nan, noisy))
    with pytest.raises(ValueError, match="K>=3"):
        fit_segment(noisy[:, :2])


def test_joint_centre_of_two_segments_turning_about_a_common_point():
    # segment a still; segment b swings about the point (100, 0, 0) of the world (= of a's frame at rest)
    centre = np.array([100.0, 0.0, 0.0])
    a_pts = np.broadcast_to(SHAPE, (30, 4, 3))
    b_rest = SHAPE + [130.0, 0.0, 0.0]
    rots = np.stack([_rot_z(0.5 * np.sin(0.3 * t)) @ _rot_x(0.3 * np.cos(0.2 * t)) for t in range(30)])
    b_pts = np.einsum("tij,kj->tki", rots, b_rest - centre) + centre
    fa, fb = fit_segment(a_pts), fit_segment(b_pts)
    ca, cb = joint_centre(fa, fb)
    np.testing.assert_allclose(fa.world(ca), np.broadcast_to(centre, (30, 3)), atol=1e-6)
    np.testing.assert_allclose(fb.world(cb), np.broadcast_to(centre, (30, 3)), atol=1e-6)
    # a prior far away barely moves a well-posed answer; with no motion at all the prior decides
    ca2, _ = joint_centre(fa, fb, prior_in_a=fa.local(np.broadcast_to([90.0, 0, 0], (30, 3)))[0])
    assert np.linalg.norm(fa.world(ca2)[0] - centre) < 1.0
    still = fit_segment(np.broadcast_to(b_rest, (30, 4, 3)))
    prior = fa.local(np.broadcast_to([90.0, 5.0, 0], (30, 3)))[0]
    ca3, _ = joint_centre(fa, still, prior_in_a=prior)
    # the still pair fixes c_b only up to c_a (any common point fits): the prior picks it
    np.testing.assert_allclose(fa.world(ca3)[0], [90.0, 5.0, 0.0], atol=1e-6)


def _arm(flex):
    """A forearm along -x ending at the wrist (origin), still; a hand along +x flexing about z by ``flex[t]``.

    Forearm: styloids at (0, +-20, 0) (columns 0, 1), cluster at x = -120 (2, 3, 4); hand markers at
    x = 70..80 (5..8); girdle (9..11) far up the arm, still.
    """
    fore = np.array([[0.0, 20.0, 0.0], [0.0, -20.0, 0.0], [-120.0, 25.0, 10.0], [-120.0, -25.0, 10.0],
                     [-150.0, 0.0, -20.0]])
    hand = np.array([[80.0, 25.0, 10.0], [80.0, -25.0, 10.0], [50.0, 10.0, 12.0], [50.0, -15.0, 12.0]])
    girdle = np.array([[-300.0, 0.0, 40.0], [-310.0, 30.0, 30.0], [-290.0, -30.0, 25.0]])
    t = len(flex)
    pts = np.concatenate([np.broadcast_to(fore, (t, 5, 3)),
                          np.einsum("tij,kj->tki", np.stack([_rot_z(f) for f in flex]), hand),
                          np.broadcast_to(girdle, (t, 3, 3))], axis=1)
    roles = {"p1": (0,), "p2": (1,), "p3": (2, 3, 4), "p4": (5, 6), "shoulder": (9,)}
    segments = {"forearm": (0, 1, 2, 3, 4), "hand": (5, 6, 7, 8), "shoulder": (9, 10, 11)}
    return pts, roles, segments


def test_rigid_markers_follow_wrist_flexion():
    flex = 0.6 * np.sin(np.linspace(0.0, 6.0, 40))  # radians about z through the wrist centre (origin)
    pts, roles, segments = _arm(flex)
    out, notes = rigid_markers(pts, roles, segments)
    # the wrist centre is the origin; the styloid vector (0, 40, 0), seen from the hand, turns by -flex: its
    # mean direction there is (mean sin f, mean cos f, 0); 40 long, carried by the hand (turned by flex)
    v = np.array([np.sin(flex).mean(), np.cos(flex).mean(), 0.0])
    across = np.stack([_rot_z(f) @ (40.0 * v / np.linalg.norm(v)) for f in flex])
    np.testing.assert_allclose(out["p1"], 0.5 * across, atol=1e-6)
    np.testing.assert_allclose(out["p2"], -0.5 * across, atol=1e-6)
    np.testing.assert_allclose(out["p4"], np.stack([_rot_z(f) @ [80.0, 0.0, 10.0] for f in flex]), atol=1e-6)
    np.testing.assert_allclose(out["p3"], np.broadcast_to([-130.0, 0.0, 0.0], (40, 3)), atol=1e-6)
    np.testing.assert_allclose(out["shoulder"], np.broadcast_to([-300.0, 0.0, 40.0], (40, 3)), atol=1e-6)
    assert "hand fit rms 0.00" in notes[0]
    # too few hand markers (besides the wrist ones): no rigid derivation
    assert rigid_markers(pts, roles, {"forearm": (0, 1, 2, 3, 4), "hand": (5, 6, 0, 1)}) is None


def test_arm_from_trajectories_derive_option():
    flex = 0.5 * np.sin(np.linspace(0.0, 4.0, 30))
    pts, _, _ = _arm(flex)
    names = ("STYLr", "STYLu", "LARMl", "LARMm", "LARM_elb", "INDEX", "LASTC", "MEDH", "LATH", "ACRO_tip",
             "CLAV_AC", "SCAP_AA")
    t = Trajectories(tuple(f"R_{n}" for n in names), pts, 100.0, 1, "mm", "arm.c3d")
    avg = arm_from_trajectories(t, "right", mapping={"up": "z"})
    rig = arm_from_trajectories(t, "right", mapping={"up": "z", "derive": "rigid"})
    assert avg.derivation == "role averages" and rig.derivation == "rigid segments"
    assert rig.report(t)["derivation"] == "rigid segments"
    np.testing.assert_allclose(avg.markers.points[:, 0], pts[:, 0])  # the styloid itself: still
    v = np.array([np.sin(flex).mean(), np.cos(flex).mean(), 0.0])
    np.testing.assert_allclose(rig.markers.points[:, 0], np.stack([_rot_z(f) @ (20.0 * v / np.linalg.norm(v))
                                                                   for f in flex]), atol=1e-6)
    with pytest.raises(RoleError, match="derive must be rigid or averages"):
        arm_from_trajectories(t, "right", mapping={"derive": "splines"})


def test_rigid_derivation_on_the_shared_capture(shared_motions):
    from splicer.io.trajectories import read_c3d

    t = read_c3d(shared_motions / "c3d" / "markers_analogs.c3d")
    avg = arm_from_trajectories(t, "right")
    rig = arm_from_trajectories(t, "right", rigid=True)
    assert rig.derivation == "rigid segments" and np.isfinite(rig.markers.points).all()
    # the segment markers are filled too (MEDH, LATH, the girdle...): a superset of the role markers' fills
    assert {(f.label, f.start) for f in avg.gaps.fills} < {(f.label, f.start) for f in rig.gaps.fills}
    # the wrist centre sits within a few cm of the mid-styloid point; p4 is the same knuckle midpoint
    mid_avg = avg.markers.points[:, :2].mean(axis=1)
    mid_rig = rig.markers.points[:, :2].mean(axis=1)
    assert np.median(np.linalg.norm(mid_rig - mid_avg, axis=1)) < 40.0
    assert np.median(np.linalg.norm(rig.markers.points[:, 3] - avg.markers.points[:, 3], axis=1)) < 5.0


def test_constraints_file_takes_derive():
    from splicer.errors import ConstraintError
    from splicer.io.config import parse_config

    cfg = parse_config("markers:\n  hands: {derive: rigid}\n  body: {derive: averages, up: z}\n")
    assert cfg.markers == {"hands": {"derive": "rigid"}, "body": {"derive": "averages", "up": "z"}}
    with pytest.raises(ConstraintError, match=r"line 1: 'markers' takes .*'derive:' \(rigid or averages\)"):
        parse_config("markers:\n  hands: {smooth: 3}\n")
