"""Finger sanity: signed flexion angles with known answers, backward bending, DIP-PIP coupling."""

import numpy as np
import pytest

from splicer.rig.handgeom import hand_frame
from splicer.model.motion import Motion
from splicer.rig.roles import find_roles
from splicer.transfer.sanity import finger_angles, finger_sanity, sanity_warnings
from splicer.evaluation.synth import gesture_skeleton, make_gesture_take


def _about(axis, deg):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    h = np.radians(np.asarray(deg, float))[..., None] / 2
    return np.concatenate([np.cos(h), np.sin(h) * axis], axis=-1)


@pytest.fixture(scope="module")
def rest():
    sk = gesture_skeleton()
    return Motion(sk, np.zeros((5, sk.n_channels)), 1 / 30), find_roles(sk)


@pytest.mark.parametrize("side", ["right", "left"])
def test_pip_flexion_about_the_radial_axis_is_measured_exactly(rest, side):
    m, roles = rest
    arm = roles.sides[side]
    chi = 1 if side == "right" else -1
    r = hand_frame(m.skeleton, arm)[:, 1]
    theta = np.array([-40.0, -10.0, 0.0, 30.0, 80.0])
    pip, dip = arm.fingers["middle"][1], arm.fingers["middle"][2]
    # rest frames are world-aligned and the parents are at identity: local = world; a right
    # hand flexes by +theta about r, a left hand about -r
    q = np.stack([_about(chi * r, theta), _about(chi * r, 2 / 3 * theta)], axis=1)
    moved = m.with_rotations([pip, dip], q)
    before = finger_angles(m, arm, chi).angles["middle"]
    after = finger_angles(moved, arm, chi).angles["middle"]
    np.testing.assert_allclose(after["PIP"] - before["PIP"], theta, atol=1e-6)
    np.testing.assert_allclose(after["DIP"] - before["DIP"], 2 / 3 * theta, atol=1e-6)
    np.testing.assert_allclose(after["MCP"], before["MCP"], atol=1e-9)
    # read as the other hand, the same motion bends the other way
    other = finger_angles(moved, arm, -chi).angles["middle"]
    np.testing.assert_allclose(other["PIP"] - before["PIP"], -theta, atol=1e-6)
    rep = finger_sanity(moved, arm, chi)["middle"]
    assert rep["backward"] == pytest.approx(1 / 5)           # only -40 is beyond 15 deg of hyperextension
    assert rep["backward_max_deg"] == pytest.approx(40.0, abs=1e-3)
    assert rep["out_of_range"] == pytest.approx(1 / 5)       # PIP -40 < 0 - 10; 80 is inside 0..100
    assert rep["dip_pip_deg"] == pytest.approx(0.0, abs=1e-4)  # DIP = 2/3 PIP exactly


def test_twisting_a_finger_joint_about_its_bone_does_not_read_as_flexion(rest):
    m, roles = rest
    arm = roles.sides["right"]
    j = arm.fingers["index"][0]
    bone = m.skeleton.offsets[arm.fingers["index"][1]]
    moved = m.with_rotations([j], np.broadcast_to(_about(bone, 88.0), (5, 1, 4)).copy())
    a0, a1 = finger_angles(m, arm, 1).angles["index"], finger_angles(moved, arm, 1).angles["index"]
    for k in a0:
        np.testing.assert_allclose(a1[k], a0[k], atol=1e-6)


def test_a_synthetic_speaker_bends_its_fingers_properly():
    take = make_gesture_take(6.0, 30.0, np.random.default_rng(3))
    roles = find_roles(take.skeleton)
    for side, chi in (("right", 1), ("left", -1)):
        rep = finger_sanity(take, roles.sides[side], chi)
        assert rep["_reading"] == side
        for f in ("index", "middle", "ring", "pinky"):
            assert rep[f]["backward"] == 0.0 and rep[f]["out_of_range"] == 0.0
            assert rep[f]["dip_pip_deg"] < 5.0                  # synth drives the DIP at about 2/3 PIP
        assert sanity_warnings(rep, side) == []
        wrong = finger_sanity(take, roles.sides[side], -chi)
        assert max(wrong[f]["backward"] for f in ("index", "middle", "ring", "pinky")) > 0.5
        assert any("bends backwards" in w for w in sanity_warnings(wrong, side))

