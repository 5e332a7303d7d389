"""Skeleton roles on the naming conventions the README promises, and on the real files."""

import numpy as np
import pytest

from splicer.io.bvh import read_bvh
from splicer.errors import RoleError
from splicer.model.motion import Skeleton
from splicer.rig.roles import detect_up_axis, find_roles, joint_side


def _skeleton(spec):
    """spec: list of (name, parent name or None, offset)."""
    names = [s[0] for s in spec]
    parents = [-1 if s[1] is None else names.index(s[1]) for s in spec]
    offsets = [s[2] for s in spec]
    ch = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation") if p < 0
          else ("Zrotation", "Xrotation", "Yrotation") for p in parents]
    return Skeleton(tuple(names), np.array(parents), np.array(offsets, float), tuple(ch), None)


def _arm(prefix, side, names, sign=1):
    """Body with one arm; names: (upper, elbow, wrist, [(finger, [joints])])."""
    upper, elbow, wrist, fingers = names
    spec = [(f"{prefix}Hips", None, [0, 100, 0]), (f"{prefix}Spine", f"{prefix}Hips", [0, 20, 0]),
            (f"{prefix}Head", f"{prefix}Spine", [0, 50, 0]),
            (upper, f"{prefix}Spine", [sign * 15, 40, 0]), (elbow, upper, [sign * 28, 0, 0]),
            (wrist, elbow, [sign * 25, 0, 0])]
    for k, (f, joints) in enumerate(fingers):
        parent = wrist
        for s, j in enumerate(joints):
            spec.append((j, parent, [sign * (8 if s == 0 else 3), 0, 2.0 * (k - 2) if s == 0 else 0]))
            parent = j
    return _skeleton(spec)


@pytest.mark.parametrize("side,upper,elbow,wrist,index,prefix", [
    ("left", "LeftArm", "LeftForeArm", "LeftHand", ["LeftHandIndex1", "LeftHandIndex2"], ""),
    ("left", "mixamorig:LeftArm", "mixamorig:LeftForeArm", "mixamorig:LeftHand",
     ["mixamorig:LeftHandIndex1", "mixamorig:LeftHandIndex2"], "mixamorig:"),
    ("right", "right_shoulder", "right_elbow", "right_wrist", ["right_index1", "right_index2", "right_index3"], ""),
    ("left", "L_UpperArm", "L_Forearm", "L_Hand", ["L_Index1"], ""),
])
def test_body_conventions(side, upper, elbow, wrist, index, prefix):
    sk = _arm(prefix, side, (upper, elbow, wrist, [("index", index)]), sign=1 if side == "left" else -1)
    r = find_roles(sk, source="t.bvh")
    a = r.sides[side]
    assert sk.names[a.upper_arm] == upper
    assert sk.names[a.elbow] == elbow
    assert sk.names[a.wrist] == wrist
    assert [sk.names[j] for j in a.fingers["index"]] == index
    assert r.up == 1


def test_smpl_wrist_preferred_over_hand_end():
    sk = _arm("", "left", ("left_shoulder", "left_elbow", "left_wrist", [("index", ["left_hand"])]))
    a = find_roles(sk).sides["left"]
    assert sk.names[a.wrist] == "left_wrist"
    assert sk.names[a.upper_arm] == "left_shoulder"  # by topology, not by the word


def test_twist_joint_skipped():
    sk = _skeleton([("Hips", None, [0, 0, 0]), ("Spine", "Hips", [0, 50, 0]), ("LeftArm", "Spine", [10, 40, 0]),
                    ("LeftForeArm", "LeftArm", [28, 0, 0]), ("LeftForeArmTwist", "LeftForeArm", [12, 0, 0]),
                    ("LeftHand", "LeftForeArmTwist", [13, 0, 0]), ("LeftHandMiddle1", "LeftHand", [8, 0, 0])])
    a = find_roles(sk).sides["left"]
    assert sk.names[a.elbow] == "LeftForeArm" and sk.names[a.upper_arm] == "LeftArm"


def test_wrist_rooted_needs_side_and_takes_it_from_filename():
    sk = _skeleton([("WRIST", None, [0, 0, 0]), ("INDEX_MCP", "WRIST", [2, 0, 8]), ("INDEX_PIP", "INDEX_MCP", [0, 0, 4]),
                    ("MIDDLE_MCP", "WRIST", [0, 0, 8]), ("RING_MCP", "WRIST", [-2, 0, 8]),
                    ("PINKY_MCP", "WRIST", [-4, 0, 7])])
    with pytest.raises(RoleError, match="left or right"):
        find_roles(sk, source="hand.bvh")
    r = find_roles(sk, source="take_leftHand.bvh")
    assert set(r.sides) == {"left"}
    assert set(r.sides["left"].fingers) == {"index", "middle", "ring", "pinky"}
    assert r.sides["left"].elbow is None and r.sides["left"].upper_arm is None
    assert set(find_roles(sk, source="hand.bvh", side="right").sides) == {"right"}


def test_missing_role_message_names_file_and_joints():
    sk = _skeleton([("Hips", None, [0, 0, 0]), ("Spine", "Hips", [0, 50, 0]), ("Head", "Spine", [0, 30, 0])])
    with pytest.raises(RoleError, match=r"body\.bvh: no wrist/hand joint.*Hips, Spine, Head"):
        find_roles(sk, source="body.bvh")


def test_explicit_mapping_overrides():
    sk = _arm("", "left", ("Bone1", "Bone2", "Bone3", [("index", ["Bone4"])]))
    r = find_roles(sk, mapping={"left": {"wrist": "Bone3", "elbow": "Bone2", "upper_arm": "Bone1",
                                         "fingers": {"index": ["Bone4"]}}})
    assert sk.names[r.sides["left"].wrist] == "Bone3"
    with pytest.raises(RoleError, match="Bone9"):
        find_roles(sk, mapping={"left": {"wrist": "Bone9"}}, source="b.bvh")


def test_up_axis_z():
    sk = _skeleton([("Hips", None, [0, 0, 100]), ("Spine", "Hips", [0, 0, 20]), ("Head", "Spine", [0, 0, 50]),
                    ("LeftHand", "Spine", [20, 0, 0]), ("LeftHandIndex1", "LeftHand", [8, 0, 0])])
    assert detect_up_axis(sk) == 2
    assert find_roles(sk, up="y").up == 1


def test_joint_side_words():
    assert joint_side("RING_MCP") is None and joint_side("Root") is None
    assert joint_side("LHipJoint") == "left" and joint_side("rMid1") == "right"


@pytest.mark.filterwarnings("ignore::splicer.errors.SplicerWarning")
def test_roles_on_every_shared_file(shared_bvh):
    m = read_bvh(shared_bvh)
    r = find_roles(m.skeleton, source=str(shared_bvh))
    assert r.sides, "no side found"
    for a in r.sides.values():
        assert a.fingers, f"{a.side}: no finger joints"
        if "leap" not in str(shared_bvh) and "manipnet" not in str(shared_bvh):
            assert a.elbow is not None and a.upper_arm is not None
            assert "Arm" in m.skeleton.names[a.upper_arm]
    if "zeggs" in str(shared_bvh) or "movin" in str(shared_bvh):
        assert set(r.sides) == {"left", "right"}
        for a in r.sides.values():
            assert set(a.fingers) == {"thumb", "index", "middle", "ring", "pinky"}
