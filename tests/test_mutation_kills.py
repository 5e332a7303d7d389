"""Tests written to kill mutants that survived the mutation run (tests/mutation_survivors.md):
each states the behaviour the surviving mutant changed."""

from __future__ import annotations

import numpy as np

from splicer.model.motion import Motion, Skeleton
from splicer.rig.roles import ArmRoles
from splicer.transfer.fingers import graft_fingers
from test_transfer import BASES, ROOT, ROT, SEG, _body


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
