"""Zero rows are found within a stated tolerance (issue 13: Blender's BVH round trip of a Leap file)."""

from pathlib import Path

import numpy as np

from splicer.io.bvh import read_bvh
from splicer.rig.repair import ZERO_ROW_ATOL, Repair, detect_problems, hand_joints, repair_motion
from splicer.rig.roles import find_roles

HANDS_BVH = Path(__file__).resolve().parents[1] / "motions" / "sample_hands.bvh"


def _hands():
    return read_bvh(HANDS_BVH)


def test_near_zero_row_is_a_zero_row():
    """Blender's import/export leaves 1.5e-6 in the Leap's all-zero first row: still a zero row."""
    hands = _hands()
    ch = np.array(hands.channels)
    ch[0] = 0.0
    ch[0, ::3] = 1.5e-6  # what Blender writes back for the all-zero row
    ch[0, 1::5] = -1.5e-6
    joints = hand_joints(hands.skeleton, find_roles(hands.skeleton, source=hands.source).sides.values())
    _, reps = repair_motion(hands.with_channels(ch), joints)
    assert reps[0] == Repair("*", 0, 0, "zero_row", "extrapolated")


def test_a_row_just_beyond_the_tolerance_is_not_a_zero_row():
    hands = _hands()
    ch = np.array(hands.channels)
    ch[0] = 0.0
    ch[0, 7] = 2 * ZERO_ROW_ATOL  # one channel clearly off zero: a pose, not a dropout
    found = detect_problems(hands.with_channels(ch))
    assert -1 not in found
    ch[0, 7] = 0.5 * ZERO_ROW_ATOL
    assert detect_problems(hands.with_channels(ch))[-1]["zero_row"].tolist() == [True] + [False] * (hands.n_frames - 1)
