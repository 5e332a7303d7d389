"""Tests written to kill mutants that survived the mutation run (tests/mutation_survivors.md):
each states the behaviour the surviving mutant changed."""

from __future__ import annotations

import numpy as np
import pytest

from splicer.model.motion import Motion, Skeleton
from splicer.rig.roles import ArmRoles
from splicer.transfer.fingers import graft_fingers
from test_transfer import BASES, ROOT, ROT, SEG, _body, _hands


def test_graft_first_clash_gets_suffix_2():
    # a hands finger joint called "Neck" clashes with the body's Neck only: it becomes "Neck_2"
    # (the first free suffix is 2), its child "Tip" keeps its name
    body_sk, _ = _body(fingers=())
    arm = ArmRoles("left", 3, 2, 1, {})
    names = ("LeftForeArm", "LeftHand", "Neck", "Tip")
    hk = Skeleton(names, np.array([-1, 0, 1, 2]), np.array([(5, 100, 3), (25, 0, 0), BASES["index"], SEG]),
                  (ROOT, ROT, ROT, ()), None)
    harm = ArmRoles("left", 1, 0, None, {"index": (2, 3)})
    body = Motion(body_sk, np.zeros((2, body_sk.n_channels)), 1 / 30)
    out, new_arm = graft_fingers(body, arm, hk, harm, 1.0)
    assert out.skeleton.names[4:6] == ("Neck_2", "Tip") and out.skeleton.names[-1] == "Neck"
    assert new_arm.fingers == {"index": (4, 5)}


def _coarse_body(last_channels=ROT, index=False):
    """A CMU-like coarse hand: LeftHand -> LeftFingerBase (at the wrist) -> LFingers -> LFingers2
    -> LFingers3, one generic finger (role "hand"); optionally an index finger too."""
    names = ["Hips", "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase", "LFingers", "LFingers2", "LFingers3"]
    parents = [-1, 0, 1, 2, 3, 4, 5, 6]
    offsets = [(0, 100, 0), (10, 40, 0), (25, 0, 0), (25, 0, 0), (0, 0, 0), (10, 0, 0), SEG, SEG]
    channels = [ROOT, ROT, ROT, ROT, ROT, ROT, ROT, last_channels]
    fingers = {"hand": (4, 5, 6, 7)}
    if index:
        names += ["LeftHandIndex1", "LeftHandIndex2"]
        parents += [3, 8]
        offsets += [BASES["index"], SEG]
        channels += [ROT, ROT]
        fingers = {"index": (8, 9), **fingers}
    sk = Skeleton(tuple(names), np.array(parents), np.array(offsets, float), tuple(channels), None)
    return sk, ArmRoles("left", 3, 2, 1, fingers)


def _hands_with(fingers):
    """The hands take of test_transfer with only ``fingers`` in its roles (its helper always
    builds an index finger)."""
    hk, harm = _hands(fingers=tuple(dict.fromkeys(("index",) + tuple(fingers))))
    return hk, ArmRoles(harm.side, harm.wrist, harm.elbow, harm.upper_arm,
                        {f: c for f, c in harm.fingers.items() if f in fingers})


@pytest.mark.parametrize("hands_fingers, source", [
    (("thumb", "index", "middle"), "middle"),  # the middle finger first
    (("thumb", "index", "ring"), "index"),     # then the index
    (("thumb", "ring"), "ring"),               # then the ring finger
])
def test_coarse_body_hand_follows_the_hands_middle_finger_from_its_knuckle(hands_fingers, source):
    from splicer.transfer.fingers import finger_map

    body_sk, arm = _coarse_body()
    hk, harm = _hands_with(hands_fingers)
    fm = finger_map(body_sk, arm, hk, harm)
    # LeftFingerBase sits at the wrist: the chain starts at LFingers, which takes the knuckle
    src = harm.fingers[source]
    assert fm.body == (5, 6, 7)
    assert fm.hands == ((src[0],), (src[1],), (src[2],))


def test_coarse_body_hand_skips_a_joint_without_three_rotations():
    from splicer.transfer.fingers import finger_map

    body_sk, arm = _coarse_body(last_channels=())
    hk, harm = _hands_with(("thumb", "middle"))
    fm = finger_map(body_sk, arm, hk, harm)
    m = harm.fingers["middle"]
    assert fm.body == (5, 6) and fm.hands == ((m[0],), (m[1],))


def test_coarse_body_hand_unused_without_a_source_finger_or_beside_real_fingers():
    from splicer.transfer.fingers import finger_map

    body_sk, arm = _coarse_body()
    hk, harm = _hands_with(("thumb", "pinky"))  # no middle, index or ring in the hands take
    assert finger_map(body_sk, arm, hk, harm).body == ()
    # a body with an index finger besides the generic chain maps its index finger only
    body_sk, arm = _coarse_body(index=True)
    hk, harm = _hands(fingers=("thumb", "index", "middle"))
    fm = finger_map(body_sk, arm, hk, harm)
    assert fm.body == (8, 9) and fm.hands == ((harm.fingers["index"][0],), (harm.fingers["index"][1],))


def test_finger_map_bone_alignment_of_a_bent_hands_finger():
    # body index: base, then bones (3, 0, 0) and (3, 0, 0); its last joint has no bone (no End
    # Site, no child) and continues the previous one.  The hands index (in the -Z convention,
    # C turns it back) has its first bone bent to (0, 0, 3), then (3, 0, 0), End Site (2, 0, 0).
    from splicer.model.rotations import quat_rotate
    from splicer.transfer.fingers import finger_map
    from test_transfer import _to_hands

    body_sk, arm = _body(fingers=("index",))
    hk, harm = _hands(fingers=("index",))
    h0, h1, h2 = harm.fingers["index"]
    offsets = np.array(hk.offsets)
    offsets[h1] = _to_hands((0.0, 0.0, 3.0))
    hk = Skeleton(hk.names, hk.parents, offsets, hk.channels, hk.end_sites)
    fm = finger_map(body_sk, arm, hk, harm)
    b0, b1, b2 = arm.fingers["index"]
    assert fm.body == (b0, b1, b2) and fm.hands == ((h0,), (h1,), (h2,))
    ident = np.array([1.0, 0.0, 0.0, 0.0])
    # A of the base: the body bone +X onto the hands bone +Z (90 degrees about -Y)
    parent0, a0 = fm.bones[b0]
    np.testing.assert_allclose(parent0, ident, atol=1e-12)
    np.testing.assert_allclose(quat_rotate(a0, np.array([1.0, 0.0, 0.0])), [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(abs(a0[0]), np.cos(np.pi / 4), atol=1e-12)
    # the middle bones are parallel (+X both): A = identity, its parent's A is the base's
    parent1, a1 = fm.bones[b1]
    np.testing.assert_allclose(parent1, a0, atol=1e-12)
    np.testing.assert_allclose(quat_rotate(a1, np.array([0.3, -0.5, 0.7])), [0.3, -0.5, 0.7], atol=1e-12)
    # the last body joint continues its previous bone (+X); the hands End Site is +X: identity
    parent2, a2 = fm.bones[b2]
    np.testing.assert_allclose(quat_rotate(parent2, np.array([0.3, -0.5, 0.7])), [0.3, -0.5, 0.7], atol=1e-12)
    np.testing.assert_allclose(quat_rotate(a2, np.array([0.3, -0.5, 0.7])), [0.3, -0.5, 0.7], atol=1e-12)


def test_finger_map_bone_alignment_without_a_hands_end_site_continues_the_previous_bone():
    # the same bent finger without the hands' End Site: the hands' last bone continues its
    # previous one (+X), so the last A is the identity again; the base still turns +X onto +Z
    from splicer.model.rotations import quat_rotate
    from splicer.transfer.fingers import finger_map
    from test_transfer import _to_hands

    body_sk, arm = _body(fingers=("index",))
    hk, harm = _hands(fingers=("index",))
    h0, h1, h2 = harm.fingers["index"]
    offsets = np.array(hk.offsets)
    offsets[h1] = _to_hands((0.0, 0.0, 3.0))
    offsets[h2] = _to_hands((0.0, 3.0, 0.0))  # the second hands bone along +Y
    hk = Skeleton(hk.names, hk.parents, offsets, hk.channels, np.full((len(hk.names), 3), np.nan))
    fm = finger_map(body_sk, arm, hk, harm)
    b0, b1, b2 = arm.fingers["index"]
    x = np.array([1.0, 0.0, 0.0])
    np.testing.assert_allclose(quat_rotate(fm.bones[b0][1], x), [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(quat_rotate(fm.bones[b1][1], x), [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(quat_rotate(fm.bones[b2][1], x), [0.0, 1.0, 0.0], atol=1e-12)


def test_finger_map_last_paired_joint_takes_its_bone_from_its_child():
    # the body pinky's third joint has no rotation channels, so the pinky pairs two joints; the
    # second one's bone is the offset of that unpaired child, +X (3, 0, 0), as is the hands'
    # (its next joint): A = identity
    from splicer.model.rotations import quat_rotate
    from splicer.transfer.fingers import finger_map

    body_sk, arm = _body(fingers=("index", "pinky"), pinky3_channels=())
    hk, harm = _hands(fingers=("index", "pinky"))
    fm = finger_map(body_sk, arm, hk, harm)
    p1, p2, p3 = arm.fingers["pinky"]
    assert p3 not in fm.body and fm.body[-2:] == (p1, p2)
    v = np.array([0.3, -0.5, 0.7])
    np.testing.assert_allclose(quat_rotate(fm.bones[p2][1], v), v, atol=1e-12)
    np.testing.assert_allclose(quat_rotate(fm.bones[p1][1], v), v, atol=1e-12)
