"""Handedness from finger flexion, mirroring, and the mirrored-hand splice (issue 9, item 2)."""

import warnings

import numpy as np
import pytest

from splicer.io.config import parse_config
from splicer.errors import SplicerError
from splicer.rig.handedness import hand_handedness, mirror_motion
from splicer.model.kinematics import global_transforms
from splicer.rig.roles import find_roles
from splicer.model.rotations import quat_angle_deg, quat_conj
from splicer.evaluation.separate import separate
from splicer import splice
from splicer.evaluation.synth import make_gesture_take

from conftest import SHARED_MOTIONS, SHARED_SKIP_REASON


@pytest.fixture(scope="module")
def take():
    return make_gesture_take(12.0, 30.0, np.random.default_rng(7))


@pytest.fixture(scope="module")
def sep(take):
    return separate(take, rng=np.random.default_rng(8), hand_only="wrist")


def test_proper_hands_are_told_apart_by_their_flexion(take):
    roles = find_roles(take.skeleton)
    for side in ("left", "right"):
        h = hand_handedness(take, roles.sides[side])
        assert (h.geometric, h.status) == (side, "flexion")
        assert h.right_share == (1.0 if side == "right" else 0.0)


def test_a_long_take_votes_on_evenly_spaced_frames(take, monkeypatch):
    """Above VOTE_FRAMES frames the vote reads that many, spread over the whole take, and
    decides as the whole take does (here: 361 frames read 100 at a time)."""
    from splicer.rig import handedness as H

    roles = find_roles(take.skeleton)
    whole = {s: hand_handedness(take, roles.sides[s]) for s in ("left", "right")}
    read = []
    real = H.finger_angles
    monkeypatch.setattr(H, "finger_angles", lambda m, *a: read.append(m.n_frames) or real(m, *a))
    monkeypatch.setattr(H, "VOTE_FRAMES", 100)
    for s in ("left", "right"):
        h = hand_handedness(take, roles.sides[s])
        assert (h.geometric, h.status, h.right_share) == (whole[s].geometric, "flexion", whole[s].right_share)
        assert 0 < h.votes < whole[s].votes
    assert take.n_frames == 361 and read == [100, 100]


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_mirror_reflects_world_positions_and_swaps_handedness(take, axis):
    short = take.slice(0, 60)
    m = mirror_motion(short, axis)
    _, p0 = global_transforms(short)
    _, p1 = global_transforms(m)
    flip = np.ones(3)
    flip[axis] = -1
    np.testing.assert_allclose(p1, p0 * flip, atol=1e-9)
    np.testing.assert_array_equal(mirror_motion(m, axis).channels, short.channels)
    roles = find_roles(take.skeleton)
    for side in ("left", "right"):
        assert hand_handedness(take.slice(0, 200), roles.sides[side]).geometric == side
        assert hand_handedness(mirror_motion(take.slice(0, 200), axis), roles.sides[side]).geometric != side


def _fingers(result, side):
    roles = find_roles(result.motion.skeleton)
    fj = roles.sides[side].finger_joints
    return result.motion.rotations[:, fj]


def test_a_mirrored_hand_splices_to_the_originals_result(sep):
    hands = sep.hand_only["right"]
    mirrored = mirror_motion(hands, 0)  # a plane other than the one splice mirrors back through
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = splice(sep.body, hands)
        b = splice(sep.body, mirrored)
    assert not a.report["handedness"]["mirrored"]
    assert b.report["handedness"]["mirrored"]
    assert b.report["handedness"]["hands"]["right"]["geometric"] == "left"
    assert any("mirror image" in w for w in b.report["warnings"])
    fa, fb = np.asarray(a.report["sides"]["right"]["hands_frame"]), np.asarray(b.report["sides"]["right"]["hands_frame"])
    # mirrored back through another plane than the test's: the original turned by a half turn
    # about the vertical, to which the alignment is blind (measured: identical paths, 4e-6 deg)
    np.testing.assert_allclose(fb, fa, atol=1e-6)
    err = quat_angle_deg(_fingers(a, "right"), _fingers(b, "right"))
    assert err.max() < 1e-3  # degrees
    # forced off: the mirror image is kept, its fingers bend backwards, and the report says so
    # (fixed ends: with open ends the mirror image matches so badly that the hands take is found to
    # cover only 12 body frames, which the report says instead)
    c = splice(sep.body, mirrored, mirror_hands="no", ends="fixed")
    assert not c.report["handedness"]["mirrored"]
    back = [v["backward"] for f, v in c.report["sides"]["right"]["finger_sanity"].items() if f in ("index", "middle")]
    assert min(back) > 0.5
    assert any("bends backwards" in w for w in c.report["warnings"])
    assert all(v["backward"] == 0.0 for f, v in b.report["sides"]["right"]["finger_sanity"].items() if not f.startswith("_"))


def test_forcing_a_mirror_on_a_proper_hand(sep):
    r = splice(sep.body, sep.hand_only["right"], mirror_hands="yes")
    assert r.report["handedness"]["mirrored"]
    assert any("forced" in w for w in r.report["warnings"])


def test_contradictory_flexion_is_refused_in_one_line(sep):
    hands = sep.hand_only["right"]
    roles = find_roles(hands.skeleton, source=hands.source)
    fj = roles.sides["right"].finger_joints
    q = np.array(hands.rotations[:, fj])
    half = hands.n_frames // 2
    q[half:] = quat_conj(q[half:])  # the second half flexes the other way
    odd = hands.with_rotations(fj, q)
    assert hand_handedness(odd, roles.sides["right"]).status == "contradictory"
    with pytest.raises(SplicerError, match=r"cannot tell whether the right hand is mirrored.*--mirror-hands") as e:
        splice(sep.body, odd)
    assert "\n" not in str(e.value)
    splice(sep.body, odd, mirror_hands="no")  # forced: no refusal


@pytest.mark.parametrize(("text", "value"), [("mirror_hands: yes\n", "yes"), ("mirror_hands: no\n", "no"),
                                             ("mirror_hands: auto\n", "auto"), ("side: both\n", None)])
def test_mirror_hands_in_the_config(text, value):
    assert parse_config(text, "c.yaml").mirror_hands == value


def test_mirror_hands_bad_value_names_the_line():
    with pytest.raises(SplicerError, match=r"c.yaml, line 2: mirror_hands must be auto, yes or no"):
        parse_config("side: both\nmirror_hands: maybe\n", "c.yaml")


@pytest.mark.shared
@pytest.mark.parametrize("body", ["zeggs/067_Speech_2_x_1_0.bvh", "movin/test1.bvh"])
@pytest.mark.parametrize("side", ["left", "right"])
def test_manipnet_hands_bend_like_the_original_capture(body, side):
    """Acceptance: no more backward bending than the source read with its own (geometric) handedness."""
    if not SHARED_MOTIONS.is_dir():
        pytest.skip(SHARED_SKIP_REASON)
    from splicer.io.bvh import read_bvh
    from splicer.transfer.sanity import finger_sanity

    hpath = SHARED_MOTIONS / "manipnet-hands" / f"teapot3_{side}Hand.bvh"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hands = read_bvh(hpath)
        r = splice(read_bvh(SHARED_MOTIONS / body).slice(0, 1200), hands, side=side)
        # as the issue measured it (fixed ends: the whole body shows the hands take)
        unfixed = splice(read_bvh(SHARED_MOTIONS / body).slice(0, 1200), hands, side=side, mirror_hands="no",
                         ends="fixed")
    assert r.report["handedness"]["mirrored"]  # the ManipNet files are mirror images
    h = r.report["handedness"]["hands"][side]
    assert h["geometric"] != side and h["status"] == "flexion"
    arm = find_roles(hands.skeleton, source=str(hpath)).sides[side]
    src = finger_sanity(hands, arm, +1 if h["geometric"] == "right" else -1)
    out = r.report["sides"][side]["finger_sanity"]
    bad = unfixed.report["sides"][side]["finger_sanity"]
    same = r.report["sides"][side]["finger_sanity_hands"]  # the source over the frames the output shows
    for f in ("index", "middle", "ring", "pinky"):
        assert out[f]["backward"] <= src[f]["backward"] + 0.01, (f, out[f], src[f])
    for f in ("thumb", "index", "middle", "ring", "pinky"):
        assert out[f]["backward"] <= same[f]["backward"] + 0.01, (f, out[f], same[f])
        assert out[f]["out_of_range"] <= same[f]["out_of_range"] + 0.2, (f, out[f], same[f])
    assert bad["middle"]["backward"] > 0.5  # as reported in the issue: 64-89 % without the fix


def test_a_hand_without_an_across_the_palm_axis_is_left_undecided(sep):
    from splicer.model.motion import Motion, Skeleton

    hands = sep.hand_only["right"]
    arm = find_roles(hands.skeleton, source=hands.source).sides["right"]
    sk = hands.skeleton
    offs = np.array(sk.offsets)
    for chain in arm.fingers.values():
        offs[chain[0]] = 0.0  # every finger base at the wrist: no knuckle line
    flat = Motion(Skeleton(sk.names, sk.parents, offs, sk.channels, sk.end_sites), hands.channels, hands.frame_time,
                  hands.source)
    h = hand_handedness(flat, arm)
    assert (h.geometric, h.status) == (None, "no axis")
    r = splice(sep.body, flat)
    assert not r.report["handedness"]["mirrored"]
    assert any("across-the-palm" in w for w in r.report["warnings"])
