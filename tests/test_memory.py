"""Memory of long takes (issue 12): the per-joint rotations the hands checks and the markers convert are
not kept for the rest of the splice, and the stages' fresh channel arrays are taken over, not copied."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from splicer.io.bvh import read_bvh
from splicer.options import resolve_options
from splicer.pipeline import Log, condition_hands, find_rig, load_inputs, side_markers

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


@pytest.fixture(scope="module")
def pair():
    return read_bvh(MOTIONS / "sample_body.bvh"), read_bvh(MOTIONS / "sample_hands.bvh")


def test_the_checks_and_the_markers_keep_no_joint_rotations(pair):
    body, hands = pair
    opts = resolve_options(None, {})
    inputs = load_inputs(body, hands, None, Log())
    rig = find_rig(inputs, opts, Log())
    checked = condition_hands(inputs, rig, opts, Log())
    for m in (body, hands, checked.inputs.body, checked.inputs.hands):
        assert m._per_joint == {}
    for s in rig.sides:
        side_markers(checked.inputs, rig, s, Log())
    assert checked.inputs.body._per_joint == {} and checked.inputs.hands._per_joint == {}


def test_read_bvh_takes_over_the_parsed_array(monkeypatch):
    """The motion keeps the parser's (T, C) array, frozen, not a copy of it."""
    import splicer.io.bvh_read as bvh_read

    made = []
    real = bvh_read._parse_motion

    def spy(*args):
        made.append(real(*args))
        return made[-1]

    monkeypatch.setattr(bvh_read, "_parse_motion", spy)
    m = read_bvh(MOTIONS / "sample_body.bvh")
    assert m.channels is made[0] and not m.channels.flags.writeable


@pytest.mark.parametrize("chunk", [97, 1000])
def test_finger_angles_in_chunks_equal_all_frames_at_once(pair, monkeypatch, chunk):
    """Every angle depends on its own frame only: chunks of 97 (not dividing T) and 1000 frames give
    the same numbers bit for bit as one pass (the quaternions' signs may differ per chunk, the
    rotations they apply do not)."""
    import splicer.transfer.sanity as sanity
    from splicer.rig.roles import find_roles

    _, hands = pair
    roles = find_roles(hands.skeleton, source="hands")
    for side, arm in roles.sides.items():
        whole = sanity._finger_angles(hands, arm, +1)
        monkeypatch.setattr(sanity, "CHUNK_FRAMES", chunk)
        parts = sanity.finger_angles(hands, arm, +1)
        monkeypatch.undo()
        assert hands.n_frames > chunk and parts.angles.keys() == whole.angles.keys()
        for f, ang in whole.angles.items():
            assert parts.angles[f].keys() == ang.keys()
            for name, a in ang.items():
                np.testing.assert_array_equal(parts.angles[f][name], a)
