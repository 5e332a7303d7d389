"""Coarse and odd skeletons: finger anchors off the wrist, a finite hand frame, graft scale."""

import numpy as np
import pytest

from splicer.rig.handgeom import (HAND_PER_FOREARM, finger_anchors, graft_scale, hand_frame, hand_length,
                              same_anatomical_joint)
from splicer.rig.markers import arm_markers
from splicer.model.motion import Motion, Skeleton
from splicer.rig.roles import ArmRoles, find_roles
from splicer.model.rotations import quat_from_matrix

NAN3 = (np.nan, np.nan, np.nan)


def _cmu_like(finger_base_offset=(0.0, 0.0, 0.0)) -> Skeleton:
    """CMU's right arm: RightFingerBase and RThumb at the wrist's place (offset 0 0 0)."""
    rows = [  # name, parent, offset, end site
        ("Hips", -1, (0, 0, 0), NAN3),
        ("Spine", 0, (0, 4, 0), NAN3),
        ("Head", 1, (0, 4, 0), (0, 1, 0)),
        ("RightShoulder", 1, (0, 0, 0), NAN3),
        ("RightArm", 3, (-3, 1, 0), NAN3),
        ("RightForeArm", 4, (-5, 0, 0), NAN3),
        ("RightHand", 5, (-3.5, 0, 0), NAN3),
        ("RightFingerBase", 6, finger_base_offset, NAN3),
        ("RFingers", 7, (-0.6, 0, 0), (-0.5, 0, 0)),
        ("RThumb", 6, (0, 0, 0), (-0.5, 0, 0.5)),
    ]
    ch = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
        [("Zrotation", "Yrotation", "Xrotation")] * (len(rows) - 1)
    return Skeleton([r[0] for r in rows], [r[1] for r in rows], [r[2] for r in rows], ch, [r[3] for r in rows])


def test_coincident_finger_joints_get_anchors_away_from_the_wrist():
    sk = _cmu_like()
    arm = find_roles(sk).sides["right"]
    anchors = finger_anchors(sk, arm)
    assert anchors["hand"][0] == sk.index("RFingers") and not np.any(anchors["hand"][1])
    j, off = anchors["thumb"]  # nothing below RThumb: its End Site
    assert j == sk.index("RThumb")
    np.testing.assert_allclose(off, [-0.5, 0, 0.5])
    assert hand_length(sk, arm) == pytest.approx(0.6)


def test_hand_frame_of_a_coarse_hand_is_finite_and_proper():
    sk = _cmu_like()
    arm = find_roles(sk).sides["right"]
    F, how = hand_frame(sk, arm, explain=True)
    np.testing.assert_allclose(F[:, 0], [-1, 0, 0], atol=1e-12)   # toward RFingers
    np.testing.assert_allclose(F[:, 1], [0, 0, 1], atol=1e-12)    # thumb (End Site) side, off the long axis
    assert np.linalg.det(F) == pytest.approx(1.0)
    assert "finger bases" in how
    assert np.all(np.isfinite(quat_from_matrix(F @ F.T)))


def test_hand_frame_without_any_finger_falls_back_to_the_forearm():
    sk = _cmu_like()
    arm = ArmRoles("right", sk.index("RightHand"), sk.index("RightForeArm"), sk.index("RightArm"), {})
    F, how = hand_frame(sk, arm, explain=True)
    np.testing.assert_allclose(F[:, 0], [-1, 0, 0], atol=1e-12)
    assert "forearm" in how and np.all(np.isfinite(F))


def test_quat_from_matrix_refuses_nan_with_a_clear_message():
    with pytest.raises(ValueError, match="NaN"):
        quat_from_matrix(np.full((3, 3), np.nan))


def test_markers_of_a_coarse_hand_are_not_collapsed_onto_the_wrist():
    sk = _cmu_like()
    m = Motion(sk, np.zeros((3, sk.n_channels)), 1 / 30)
    arm = find_roles(sk).sides["right"]
    mk = arm_markers(m, arm, 1)
    w = np.array([-11.5, 5, 0])  # Spine 4 + arm: (-3 -5 -3.5, 4 + 1, 0)
    np.testing.assert_allclose(mk.points[0, 3], w + [-0.6, 0, 0])        # p4: RFingers
    assert np.linalg.norm(mk.points[0, 0] - mk.points[0, 1]) > 0.1          # p1 != p2


def _hand_only(scale: float, forearm: float | None) -> tuple[Skeleton, ArmRoles]:
    """A Leap-like right hand: root rForeArm (length ``forearm`` or at the wrist), knuckles ``52 * scale`` away."""
    names = ["rForeArm", "rHand", "rIndex1", "rMid1", "rPinky1"]
    offs = [(0, 0, 0), (0, 0, forearm or 0.0), (-30 * scale, 0, 42 * scale), (0, 0, 52 * scale), (45 * scale, 0, 28 * scale)]
    ch = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + [("Zrotation", "Yrotation", "Xrotation")] * 4
    sk = Skeleton(names, [-1, 0, 1, 1, 1], offs, ch, [NAN3] * 5)
    return sk, find_roles(sk).sides["right"]


def test_graft_scale_prefers_hand_length_then_forearm_then_proportion():
    body = _cmu_like(finger_base_offset=(0, 0, 0))
    barm = find_roles(body).sides["right"]                       # hand length 0.6, forearm 3.5
    hsk, harm = _hand_only(1.0, forearm=None)                    # hand length 52 mm, forearm at the wrist
    g = graft_scale(body, barm, hsk, harm)
    assert g.scale == pytest.approx(0.6 / 52) and g.method.startswith("hand length")
    bare = ArmRoles("right", barm.wrist, barm.elbow, barm.upper_arm, {})  # a body without finger joints
    g = graft_scale(body, bare, hsk, harm)
    assert g.scale == pytest.approx(HAND_PER_FOREARM * 3.5 / 52) and "typical" in g.method
    hsk2, harm2 = _hand_only(1.0, forearm=260.0)
    harm2 = ArmRoles("right", harm2.wrist, 0, None, harm2.fingers)
    g = graft_scale(body, bare, hsk2, harm2)
    assert g.scale == pytest.approx(3.5 / 260) and g.method.startswith("forearm")


def test_two_axes_of_one_joint_are_recognised():
    assert same_anatomical_joint("THUMB_CMC_FE", "THUMB_CMC_AA")
    assert not same_anatomical_joint("THUMB_CMC_AA", "THUMB_MCP_FE")
    assert not same_anatomical_joint("rThumb1", "rThumb2")


def test_a_coarse_body_hand_follows_the_middle_finger_from_its_knuckle():
    from splicer.transfer.fingers import finger_map

    body = _cmu_like()
    barm = find_roles(body).sides["right"]
    hsk, harm = _hand_only(1.0, forearm=None)
    fmap = finger_map(body, barm, hsk, harm)
    pairs = {body.names[b]: [hsk.names[j] for j in g] for b, g in zip(fmap.body, fmap.hands)}
    # RightFingerBase sits at the wrist: RFingers, the first joint away from it, takes the MCP
    assert pairs == {"RFingers": ["rMid1"]}
    assert np.all(np.isfinite(fmap.conj))


def test_a_rig_with_non_parallel_rest_bones_transfers_the_same_finger_positions():
    """A hands rig whose rest bone is bent (and straightened again by constant rotations, as
    ManipNet's thumb) must drive the body's bones to the same places as a plain rig."""
    from splicer.model.kinematics import global_transforms
    from splicer.model.rotations import quat_conj, quat_mul, quat_rotate
    from splicer import splice
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(4.0, 30.0, np.random.default_rng(11))
    sk = take.skeleton
    roles = find_roles(sk)
    fj = sorted(j for a in roles.sides.values() for j in a.finger_joints)
    flat = np.zeros((take.n_frames, len(fj), 4))
    flat[..., 0] = 1
    body = take.with_rotations(fj, flat)
    j, c = roles.sides["right"].fingers["index"][1:3]           # PIP and DIP
    r0 = np.array([np.cos(0.6), 0.3 * np.sin(0.6), 0.9 * np.sin(0.6), 0.3 * np.sin(0.6)])
    r0 = r0 / np.linalg.norm(r0)                                  # a turn of 69 deg, not about the bone
    offs = np.array(sk.offsets)
    offs[c] = quat_rotate(quat_conj(r0), offs[c])              # the bone bent at rest ...
    odd_sk = Skeleton(sk.names, sk.parents, offs, sk.channels, sk.end_sites)
    odd = Motion(odd_sk, take.channels, take.frame_time)
    q = take.rotations
    odd = odd.with_rotations([j, c], np.stack([quat_mul(q[:, j], r0[None]),        # ... and straightened
                                               quat_mul(quat_conj(r0)[None], q[:, c])], axis=1))
    np.testing.assert_allclose(global_transforms(odd)[1], global_transforms(take)[1], atol=1e-9)
    a, b = splice(body, take), splice(body, odd)
    np.testing.assert_allclose(a.report["sides"]["right"]["hands_frame"], b.report["sides"]["right"]["hands_frame"])
    pa, pb = global_transforms(a.motion, fj)[1], global_transforms(b.motion, fj)[1]
    np.testing.assert_allclose(pb, pa, atol=1e-6)   # cm



def test_a_guessed_hand_frame_is_reported():
    from splicer.rig.handgeom import hand_frame_warnings

    sk = _cmu_like()
    arm = find_roles(sk).sides["right"]
    assert hand_frame_warnings(sk, arm, "cmu.bvh") == []          # fingers and thumb give both axes
    no_thumb = ArmRoles("right", arm.wrist, arm.elbow, arm.upper_arm, {"hand": arm.fingers["hand"]})
    (w,) = hand_frame_warnings(sk, no_thumb, "cmu.bvh")
    assert w.startswith("cmu.bvh: the right hand's rest frame is a guess (long axis from finger bases, radial axis from none")
