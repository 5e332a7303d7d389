"""Worked answers for splicer.transfer.fingers: the rest hand frame, finger pairing, carrying rotations
between axis conventions and grafting fingers onto a body without any (ALGORITHM.md section 7).

The two rigs below are the same left hand in two conventions: the body's hand points along
+X with the thumb side towards +Z (a Mixamo-like T-pose); the hands file's points along -Z
with the thumb side towards +X (a Leap-like hand).  A body offset (a, b, c) is the hands
offset (c, b, -a), and the rotation taking the hands' hand frame onto the body's is
``C = R_y(-90 deg)``: (x, y, z) -> (-z, y, x), quaternion (cos 45, 0, -sin 45, 0).
"""

import numpy as np
import pytest

from splicer.model.motion import Motion, Skeleton
from splicer.rig.roles import ArmRoles
from splicer.model.kinematics import rest_positions
from splicer.model.rotations import quat_angle, quat_between, quat_from_euler, quat_to_matrix
from splicer.transfer.fingers import carried_rotations, finger_map, graft_fingers, hand_frame

ROT = ("Zrotation", "Xrotation", "Yrotation")
ROOT = ("Xposition", "Yposition", "Zposition") + ROT

# body-convention finger offsets from the wrist (base) and along the finger
BASES = {"thumb": (2.0, 0.0, 3.0), "index": (9.0, 0.0, 2.0), "middle": (10.0, 0.0, 0.0),
         "ring": (9.5, 0.0, -1.0), "pinky": (9.0, 0.0, -2.0)}
SEG = (3.0, 0.0, 0.0)
C_QUAT = np.array([np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0])


def _to_hands(v):
    a, b, c = v
    return (c, b, -a)


def _body(fingers=("thumb", "index", "middle", "ring", "pinky"), pinky3_channels=ROT):
    """Hips -> LeftArm -> LeftForeArm -> LeftHand -> fingers (3 segments each), Hips -> Neck."""
    names, parents, offsets, channels = ["Hips", "LeftArm", "LeftForeArm", "LeftHand"], [-1, 0, 1, 2], \
        [(0, 100, 0), (10, 40, 0), (25, 0, 0), (25, 0, 0)], [ROOT, ROT, ROT, ROT]
    chains = {}
    for f in fingers:
        chain = []
        for s in range(3):
            chain.append(len(names))
            names.append(f"LeftHand{f.title()}{s + 1}")
            parents.append(3 if s == 0 else chain[-2])
            offsets.append(BASES[f] if s == 0 else SEG)
            channels.append(pinky3_channels if (f, s) == ("pinky", 2) else ROT)
        chains[f] = tuple(chain)
    names.append("Neck")
    parents.append(0)
    offsets.append((0, 50, 0))
    channels.append(ROT)
    sk = Skeleton(tuple(names), np.array(parents), np.array(offsets, float), tuple(channels), None)
    return sk, ArmRoles("left", 3, 2, 1, chains)


def _hands(fingers=("thumb", "index", "middle", "ring", "pinky")):
    """LeftForeArm (root) -> LeftHand -> fingers in the -Z convention; the thumb base is a
    two-axis knuckle: two joints at the same place (the second with a zero offset)."""
    names, parents, offsets, channels = ["LeftForeArm", "LeftHand"], [-1, 0], \
        [(0, 0, 0), _to_hands((25, 0, 0))], [ROOT, ROT]
    chains = {}
    for f in fingers:
        chain = []
        segs = [BASES[f], (0, 0, 0), SEG, SEG] if f == "thumb" else [BASES[f], SEG, SEG]
        for s, off in enumerate(segs):
            chain.append(len(names))
            names.append(f"h_{f}{s}")
            parents.append(1 if s == 0 else chain[-2])
            offsets.append(_to_hands(off))
            channels.append(ROT)
        chains[f] = tuple(chain)
    end_sites = np.full((len(names), 3), np.nan)
    end_sites[chains["index"][-1]] = _to_hands((2.0, 0.0, 0.0)) if "index" in chains else np.nan
    sk = Skeleton(tuple(names), np.array(parents), np.array(offsets, float), tuple(channels), end_sites)
    return sk, ArmRoles("left", 1, 0, None, chains)


def test_hand_frame_columns_are_long_radial_and_palm_normal():
    # body: long axis wrist -> middle base = +X; radial = index - pinky base = (0, 0, 4) -> +Z;
    # normal = X x Z = -Y
    sk, arm = _body()
    np.testing.assert_allclose(hand_frame(sk, arm), [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)
    # hands: long -Z, radial (4, 0, 0) -> +X, normal (-Z) x X = -Y
    hk, harm = _hands()
    np.testing.assert_allclose(hand_frame(hk, harm), [[0, 1, 0], [0, 0, -1], [-1, 0, 0]], atol=1e-12)


def test_hand_frame_falls_back_to_the_thumb_and_ring_and_to_any_perpendicular():
    # no index and no pinky: radial = thumb base (2, 0, 3), ulnar = ring base (9.5, 0, -1):
    # v = (-7.5, 0, 4); minus its +X part -> (0, 0, 4) -> +Z: the same frame
    sk, arm = _body(fingers=("thumb", "middle", "ring"))
    np.testing.assert_allclose(hand_frame(sk, arm), [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)
    # a middle finger only: no across-the-palm axis; u = +X is not vertical, so
    # v = u x (0, 1, 0) = +Z
    sk, arm = _body(fingers=("middle",))
    np.testing.assert_allclose(hand_frame(sk, arm), [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)


def test_finger_map_pairs_segments_merges_two_axis_knuckles_and_finds_C():
    sk, arm = _body()
    hk, harm = _hands()
    fm = finger_map(sk, arm, hk, harm)
    # body joints in FINGERS order, every segment (all have three rotation channels)
    assert fm.body == tuple(j for f in ("thumb", "index", "middle", "ring", "pinky") for j in arm.fingers[f])
    t = harm.fingers["thumb"]
    assert fm.hands[:3] == ((t[0], t[1]), (t[2],), (t[3],))  # the zero-offset joint joins its parent
    assert fm.hands[3:6] == tuple((j,) for j in harm.fingers["index"])
    assert quat_angle(fm.conj, C_QUAT) == pytest.approx(0.0, abs=1e-5)


def test_finger_map_skips_fingers_missing_on_either_side_and_joints_without_three_axes():
    sk, arm = _body(pinky3_channels=("Zrotation",))
    hk, harm = _hands(fingers=("thumb", "index", "middle", "pinky"))  # no ring in the hands file
    fm = finger_map(sk, arm, hk, harm)
    want = [*arm.fingers["thumb"], *arm.fingers["index"], *arm.fingers["middle"], *arm.fingers["pinky"][:2]]
    assert list(fm.body) == want
    assert fm.hands[-2:] == tuple((j,) for j in harm.fingers["pinky"][:2])


def test_carried_rotations_turn_the_axis_by_C_and_compose_knuckles():
    sk, arm = _body()
    hk, harm = _hands()
    fm = finger_map(sk, arm, hk, harm)
    T = 2
    q = np.zeros((T, hk.n_joints, 4))
    q[..., 0] = 1.0
    # hands thumb knuckle: 20 then 30 degrees about hands +X (the radial axis): composed, a
    # 50-degree turn about hands +X = body +Z (C maps (1, 0, 0) to (0, 0, 1))
    t = harm.fingers["thumb"]
    q[:, t[0]] = quat_from_euler(np.array([20.0, 0, 0]), "XYZ")
    q[:, t[1]] = quat_from_euler(np.array([30.0, 0, 0]), "XYZ")
    # hands index base: 40 degrees about hands +Z = body -X (C maps (0, 0, 1) to (-1, 0, 0))
    q[:, harm.fingers["index"][0]] = quat_from_euler(np.array([0, 0, 40.0]), "XYZ")
    out = carried_rotations(q, fm)
    assert out.shape == (T, len(fm.body), 4)
    np.testing.assert_allclose(quat_angle(out[:, 0], quat_from_euler(np.array([0, 0, 50.0]), "XYZ")), 0, atol=1e-5)
    np.testing.assert_allclose(quat_angle(out[:, 3], quat_from_euler(np.array([-40.0, 0, 0]), "XYZ")), 0, atol=1e-5)
    np.testing.assert_allclose(quat_angle(out[:, 4], np.array([1.0, 0, 0, 0])), 0, atol=1e-5)


def test_carried_rotations_are_copied_when_the_conventions_agree():
    sk, arm = _body()
    fm = finger_map(sk, arm, sk, arm)
    assert quat_angle(fm.conj, np.array([1.0, 0, 0, 0])) < 1e-6
    rng = np.random.default_rng(3)
    q = rng.standard_normal((4, sk.n_joints, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    out = carried_rotations(q, fm)
    np.testing.assert_array_equal(out, q[:, list(fm.body)])
    assert carried_rotations(q, type(fm)((), (), fm.conj)).shape == (4, 0, 4)


def test_carried_rotations_skip_C_only_below_a_millionth_of_a_degree():
    sk, arm = _body()
    fm = finger_map(sk, arm, sk, arm)
    rng = np.random.default_rng(4)
    q = rng.standard_normal((3, sk.n_joints, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    # C 1e-7 degrees from the identity: the rotations are copied bit for bit
    tiny = quat_from_euler(np.array([0.0, 1e-7, 0.0]), "XYZ")
    np.testing.assert_array_equal(carried_rotations(q, type(fm)(fm.body, fm.hands, tiny)), q[:, list(fm.body)])
    # C half a degree about Y: q -> C q C^-1, which turns each rotation's axis by 0.5 degrees
    half = quat_from_euler(np.array([0.0, 0.5, 0.0]), "XYZ")
    out = carried_rotations(q, type(fm)(fm.body, fm.hands, half))
    from splicer.model.rotations import quat_conj, quat_mul
    want = quat_mul(quat_mul(half, q[:, list(fm.body)]), quat_conj(half))
    np.testing.assert_allclose(out, want, atol=1e-15)
    assert np.abs(out - q[:, list(fm.body)]).max() > 1e-4


def test_graft_puts_the_hands_fingers_under_the_wrist_turned_and_scaled():
    body_sk, _ = _body(fingers=())
    arm = ArmRoles("left", 3, 2, 1, {})
    hk, harm = _hands(fingers=("thumb", "index"))
    T = 3
    ch = np.arange(T * body_sk.n_channels, dtype=float).reshape(T, -1)
    body = Motion(body_sk, ch, 1 / 30)
    out, new_arm = graft_fingers(body, arm, hk, harm, 2.0)
    sk = out.skeleton
    # preorder: the fingers follow the wrist, the Neck (a later child of the root) comes last
    assert sk.names == ("Hips", "LeftArm", "LeftForeArm", "LeftHand", "h_thumb0", "h_thumb1", "h_thumb2",
                        "h_thumb3", "h_index0", "h_index1", "h_index2", "Neck")
    assert sk.parents.tolist() == [-1, 0, 1, 2, 3, 4, 5, 6, 3, 8, 9, 0]
    # C takes the hands forearm (-Z) onto the body's (+X): hands (c, b, -a) -> (a, b, c), x 2
    np.testing.assert_allclose(sk.offsets[4], 2 * np.array(BASES["thumb"]), atol=1e-12)
    np.testing.assert_allclose(sk.offsets[5], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(sk.offsets[8], 2 * np.array(BASES["index"]), atol=1e-12)
    np.testing.assert_allclose(sk.offsets[9], 2 * np.array(SEG), atol=1e-12)
    np.testing.assert_allclose(sk.end_sites[10], [4.0, 0, 0], atol=1e-12)
    assert np.isnan(sk.end_sites[9]).all()
    assert all(sk.channels[j] == ROT for j in range(4, 11))
    # body channels copied, new joints at identity (zeros), Neck's columns moved to the end
    np.testing.assert_array_equal(out.channels[:, :15], ch[:, :15])
    np.testing.assert_array_equal(out.channels[:, 15:36], 0.0)
    np.testing.assert_array_equal(out.channels[:, 36:], ch[:, 15:])
    assert new_arm.wrist == 3 and new_arm.elbow == 2 and new_arm.upper_arm == 1
    assert new_arm.fingers == {"thumb": (4, 5, 6, 7), "index": (8, 9, 10)}
    assert out.frame_time == body.frame_time


def test_graft_renames_clashes_and_keeps_C_identity_for_the_same_convention():
    body_sk, _ = _body(fingers=())
    arm = ArmRoles("left", 3, 2, 1, {})
    # a hands file in the body's own convention (its forearm root away from the origin) whose
    # finger joints are called "Neck_2" and "Neck": the first keeps its name, the second
    # clashes with the body's Neck and then with "Neck_2", and becomes "Neck_3"
    names = ("LeftForeArm", "LeftHand", "Neck_2", "Neck")
    hk = Skeleton(names, np.array([-1, 0, 1, 2]), np.array([(5, 100, 3), (25, 0, 0), BASES["index"], SEG]),
                  (ROOT, ROT, ("Xrotation", "Yrotation", "Zrotation"), ()), None)
    harm = ArmRoles("left", 1, 0, None, {"index": (2, 3)})
    body = Motion(body_sk, np.zeros((2, body_sk.n_channels)), 1 / 30)
    out, new_arm = graft_fingers(body, arm, hk, harm, 1.0)
    sk = out.skeleton
    assert sk.names[4:6] == ("Neck_2", "Neck_3") and sk.names[-1] == "Neck"
    np.testing.assert_allclose(sk.offsets[4], BASES["index"], atol=1e-12)
    # the hands' own channel order is kept; a joint without channels gets Z X Y rotations
    assert sk.channels[4] == ("Xrotation", "Yrotation", "Zrotation") and sk.channels[5] == ROT


def test_graft_of_a_wrist_rooted_hand_uses_its_long_axis():
    body_sk, _ = _body(fingers=())
    arm = ArmRoles("left", 3, 2, 1, {})
    hk, harm = _hands(fingers=("index", "middle", "pinky"))
    harm = ArmRoles("left", 1, None, None, harm.fingers)  # no forearm: the hand's long axis
    body = Motion(body_sk, np.zeros((1, body_sk.n_channels)), 1 / 30)
    out, _ = graft_fingers(body, arm, hk, harm, 1.0)
    np.testing.assert_allclose(out.skeleton.offsets[4], BASES["index"], atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(C_QUAT) @ hk.offsets[3], SEG, atol=1e-12)


def test_graft_without_a_body_elbow_or_a_hands_forearm_length_keeps_the_axes():
    # no body elbow, or a hands forearm of zero length: no direction to match, C = identity,
    # the hands offsets are copied as they are (here in the -Z convention, unturned)
    hk, harm = _hands(fingers=("index",))
    body_sk, _ = _body(fingers=())
    body = Motion(body_sk, np.zeros((1, body_sk.n_channels)), 1 / 30)
    out, _ = graft_fingers(body, ArmRoles("left", 3, None, None, {}), hk, harm, 1.0)
    np.testing.assert_allclose(out.skeleton.offsets[4], _to_hands(BASES["index"]), atol=1e-12)
    # a hands forearm of zero length (Leap's rForeArm at the wrist) has no direction: the hands'
    # long hand axis stands in for it and is turned onto the body's forearm direction
    flat = Skeleton(hk.names, hk.parents, np.vstack([[0, 0, 0], [0, 0, 0], hk.offsets[2:]]), hk.channels, None)
    out, _ = graft_fingers(body, ArmRoles("left", 3, 2, 1, {}), flat, harm, 2.0)
    rb = rest_positions(body_sk)
    C = quat_to_matrix(quat_between(hand_frame(flat, harm)[:, 0], rb[3] - rb[2]))
    np.testing.assert_allclose(out.skeleton.offsets[5], 2 * C @ np.array(_to_hands(SEG)), atol=1e-12)


def test_hand_frame_without_a_middle_finger_or_pointing_down():
    # no middle finger: the long axis points at the mean of the knuckles other than the thumb's
    # (the thumb base sits off the knuckle line), index (9, 0, 2) and pinky (9, 0, -2): (9, 0, 0),
    # so +X; radial = index - pinky = (0, 0, 4): +Z; normal = long x radial = X x Z = -Y
    sk, arm = _body(fingers=("thumb", "index", "pinky"))
    f = hand_frame(sk, arm)
    np.testing.assert_allclose(f[:, 0], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(f[:, 1], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(f[:, 2], [0, -1, 0], atol=1e-12)
    # a hand hanging down (-Y) with one finger: u = -Y is vertical, so v = u x X = +Z, n = u x v = -X
    names = ("Hand", "Mid1")
    sk = Skeleton(names, np.array([-1, 0]), np.array([(0, 0, 0), (0, -8.0, 0)]), (ROOT, ROT), None)
    np.testing.assert_allclose(hand_frame(sk, ArmRoles("left", 0, None, None, {"middle": (1,)})),
                               [[0, 0, -1], [-1, 0, 0], [0, 1, 0]], atol=1e-12)


def _flat_hand(bases, second=None):
    """A wrist at the origin with finger bases at ``bases`` (and a second joint at ``second``
    offsets from the base, where given); the hand's rotation channels only."""
    names, parents, offsets = ["Wrist"], [-1], [(0.0, 0.0, 0.0)]
    chains = {}
    for f, p in bases.items():
        chain = [len(names)]
        names.append(f"{f}1")
        parents.append(0)
        offsets.append(p)
        if second and f in second:
            chain.append(len(names))
            names.append(f"{f}2")
            parents.append(chain[0])
            offsets.append(second[f])
        chains[f] = tuple(chain)
    sk = Skeleton(tuple(names), np.array(parents), np.array(offsets, float), (ROOT,) + (ROT,) * (len(names) - 1), None)
    return sk, ArmRoles("left", 0, None, None, chains)


PALM_Z = {"thumb": (2.0, 3.0, 0.0), "index": (9.0, 2.0, 0.0), "middle": (10.0, 0.0, 0.0),
          "ring": (9.5, -1.0, 0.0), "pinky": (9.0, -2.0, 0.0)}  # fingers along X, spread along Y


@pytest.mark.parametrize("drop", [(), ("index",), ("pinky",), ("index", "pinky")])
def test_hand_frame_radial_axis_from_index_or_thumb_and_pinky_or_ring(drop):
    # long axis X; radial - ulnar: index - pinky = (0, 4, 0), thumb - pinky = (-7, 5, 0),
    # index - ring = (-0.5, 3, 0), thumb - ring = (-7.5, 4, 0): once the X part is removed, +Y
    # every time (the fallback for a missing axis would give X x Y = +Z); normal X x Y = +Z
    sk, arm = _flat_hand({f: p for f, p in PALM_Z.items() if f not in drop})
    np.testing.assert_allclose(hand_frame(sk, arm), np.eye(3), atol=1e-12)


def test_hand_frame_narrow_hand_and_first_segments():
    # index and pinky bases 0.5 apart: still an across-the-palm axis (|u x v| = 0.5 > 1e-9)
    sk, arm = _flat_hand({"index": (9.0, 0.25, 0.0), "middle": (10.0, 0.0, 0.0), "pinky": (9.0, -0.25, 0.0)})
    np.testing.assert_allclose(hand_frame(sk, arm), np.eye(3), atol=1e-12)
    # a hand in metres (bases a hundredth of the above): |u x v| = 0.1 x 0.04 is small but not 0
    sk, arm = _flat_hand({f: tuple(0.01 * np.array(p)) for f, p in PALM_Z.items()})
    np.testing.assert_allclose(hand_frame(sk, arm), np.eye(3), atol=1e-12)
    # an index finger but no ulnar finger: the other knuckles (here the middle's) stand in for the
    # ulnar side: v = index - middle = (-1, 2, 0), minus its part along u = +X: +Y; n = X x Y = +Z
    sk, arm = _flat_hand({"index": (9.0, 2.0, 0.0), "middle": (10.0, 0.0, 0.0)})
    np.testing.assert_allclose(hand_frame(sk, arm), np.eye(3), atol=1e-12)
    # the bases are the chains' first joints: second joints bent out of the palm change nothing
    sk, arm = _flat_hand(PALM_Z, second={f: (2.0, 0.0, 2.0 + k) for k, f in enumerate(PALM_Z)})
    np.testing.assert_allclose(hand_frame(sk, arm), np.eye(3), atol=1e-12)


@pytest.mark.parametrize("middle,frame", [
    # u = +Z (|u_y| < 0.9 |u|): v = Z x Y = -X, n = Z x -X = -Y
    ((0.0, 0.0, 10.0), [[0, -1, 0], [0, 0, -1], [1, 0, 0]]),
    # u = (0.8, 0.6, 0): v = (8, 6, 0) x Y = (0, 0, 8) -> +Z, n = u x Z = (0.6, -0.8, 0)
    ((8.0, 6.0, 0.0), [[0.8, 0, 0.6], [0.6, 0, -0.8], [0, 1, 0]]),
    # u = (0, -8, 1) / sqrt 65 (nearly vertical): v = u x X = (0, 1, 8) / sqrt 65, n = u x v = -X
    ((0.0, -8.0, 1.0), [[0, 0, -1], [-8 / 65 ** 0.5, 1 / 65 ** 0.5, 0], [1 / 65 ** 0.5, 8 / 65 ** 0.5, 0]]),
])
def test_hand_frame_with_one_finger_picks_a_perpendicular(middle, frame):
    sk, arm = _flat_hand({"middle": middle})
    np.testing.assert_allclose(hand_frame(sk, arm), frame, atol=1e-12)


@pytest.mark.parametrize("unit", [1.0, 0.01])  # centimetres, metres
def test_segments_merge_joints_within_a_millionth_of_the_skeleton_size(unit):
    from splicer.model.kinematics import rest_positions
    from splicer.transfer.fingers import _segments

    # root at (100, 0, 0), a finger straight down -Z: A 40 below, B eps below A, C 5 below B.
    # The skeleton's size is its largest extent along one axis: 45 (z), not the 145 between
    # coordinates of different axes; joints closer than 1e-6 x 45 = 4.5e-5 to their parent merge
    def finger(eps):
        offs = unit * np.array([(100.0, 0, 0), (0, 0, -40.0), (0, 0, -eps), (0, 0, -5.0)])
        sk = Skeleton(("root", "A", "B", "C"), np.array([-1, 0, 1, 2]), offs, (ROOT, ROT, ROT, ROT), None)
        return _segments(sk, (1, 2, 3), rest_positions(sk))

    assert finger(3e-5) == [(1, 2), (3,)]
    assert finger(6e-5) == [(1,), (2,), (3,)]


def test_graft_keeps_the_source_and_the_side():
    body_sk, _ = _body(fingers=())
    hk, harm = _hands(fingers=("index",))
    body = Motion(body_sk, np.zeros((1, body_sk.n_channels)), 1 / 30, source="body.bvh")
    out, new_arm = graft_fingers(body, ArmRoles("right", 3, 2, 1, {}), hk, harm, 1.0)
    assert out.source == "body.bvh" and new_arm.side == "right"
