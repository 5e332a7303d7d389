"""Dropouts and gaps of a hand capture: known answers on data the project makes."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from splicer.io.bvh import read_bvh
from splicer.errors import SplicerError
from splicer.model.motion import Motion, Skeleton
from splicer.rig.repair import (EXTRAPOLATE_MAX_S, MAX_FINGER_SPEED_DEG_S, VELOCITY_BASELINE_S, Repair, hand_joints,
                            repair_motion, repairs_summary)
from splicer.rig.roles import find_roles
from splicer.model.rotations import quat_angle, quat_from_euler
from splicer import splice

SAMPLE = Path(__file__).resolve().parents[1] / "motions"


@pytest.fixture(scope="module")
def hands() -> Motion:
    return read_bvh(SAMPLE / "sample_hands.bvh")


@pytest.fixture(scope="module")
def joints(hands) -> list[int]:
    return hand_joints(hands.skeleton, find_roles(hands.skeleton, source=hands.source).sides.values())


def _set(m: Motion, j: int, frames, values) -> Motion:
    ch = np.array(m.channels)
    cols = m.skeleton.rotation_columns(j)
    ch[np.ix_(np.atleast_1d(frames), cols)] = values
    return m.with_channels(ch)


def _rot_err(a: Motion, b: Motion, j: int, frames) -> float:
    """Largest geodesic angle (degrees) between the joint's rotations of ``a`` and ``b`` over ``frames``."""
    return float(quat_angle(a.joint_rotations([j])[frames, 0], b.joint_rotations([j])[frames, 0]).max())


def _unchanged_outside(fixed: Motion, broken: Motion, rows: np.ndarray, cols: list[int] | None = None) -> None:
    keep = np.ones(fixed.n_frames, dtype=bool)
    keep[rows] = False
    np.testing.assert_array_equal(fixed.channels[keep], broken.channels[keep])
    if cols is not None:  # columns of other joints are untouched in the broken rows too
        other = [c for c in range(fixed.channels.shape[1]) if c not in cols]
        np.testing.assert_array_equal(fixed.channels[np.ix_(rows, other)], broken.channels[np.ix_(rows, other)])


def test_clean_capture_is_left_alone(hands, joints):
    out, reps = repair_motion(hands, joints)
    assert reps == [] and out is hands


def test_zero_rows_at_the_start_and_inside(hands, joints):
    ch = np.array(hands.channels)
    ch[0] = 0.0  # as the Leap exports begin
    ch[500:503] = 0.0
    broken = hands.with_channels(ch)
    fixed, reps = repair_motion(broken, joints)
    assert reps == [Repair("*", 0, 0, "zero_row", "extrapolated"), Repair("*", 500, 502, "zero_row", "slerp")]
    _unchanged_outside(fixed, broken, np.r_[0, 500:503])
    sk = hands.skeleton
    for name in ("RightHand", "RightHandIndex2", "LeftHandThumb1"):
        j = sk.index(name)
        # across 3 frames of 60 fps motion with 0.5 deg capture noise on every frame
        assert _rot_err(fixed, hands, j, np.arange(500, 503)) < 1.5
        assert _rot_err(fixed, hands, j, [0]) < 1.5
    # the root's position (the only position channels) is interpolated linearly
    pc = sk.position_columns(0)
    np.testing.assert_allclose(fixed.channels[501, pc], 0.5 * (hands.channels[499, pc] + hands.channels[503, pc]))


def test_nan_stretch_of_one_joint(hands, joints):
    j = hands.skeleton.index("RightHandIndex2")
    broken = _set(hands, j, np.arange(100, 105), np.nan)
    fixed, reps = repair_motion(broken, joints)
    assert reps == [Repair("RightHandIndex2", 100, 104, "nan", "slerp")]
    assert np.all(np.isfinite(fixed.channels))
    _unchanged_outside(fixed, broken, np.arange(100, 105), hands.skeleton.rotation_columns(j))
    assert _rot_err(fixed, hands, j, np.arange(100, 105)) < 1.5


def test_nan_at_the_end_is_extrapolated(hands, joints):
    j = hands.skeleton.index("LeftHandMiddle1")
    T = hands.n_frames
    broken = _set(hands, j, np.arange(T - 3, T), np.inf)
    fixed, reps = repair_motion(broken, joints)
    assert reps == [Repair("LeftHandMiddle1", T - 3, T - 1, "nan", "extrapolated")]
    # constant velocity over 3 frames of noisy (0.5 deg) capture: within 2 degrees
    assert _rot_err(fixed, hands, j, np.arange(T - 3, T)) < 2.0


def test_frozen_joint_while_the_hand_moves(hands, joints):
    sk = hands.skeleton
    j = sk.index("RightHandIndex2")  # turns 74 degrees over frames 150..181 of the sample
    held = hands.channels[150, sk.rotation_columns(j)]
    broken = _set(hands, j, np.arange(151, 181), held)
    fixed, reps = repair_motion(broken, joints)
    # frame 150 is the last real sample; its 30 repeats are the dropout
    assert reps == [Repair("RightHandIndex2", 151, 180, "frozen", "slerp")]
    _unchanged_outside(fixed, broken, np.arange(151, 181), sk.rotation_columns(j))
    # slerp over half a second of a 74-degree move: the repaired pose is far nearer the truth
    # than the frozen one
    frames = np.arange(151, 181)
    assert _rot_err(fixed, hands, j, frames) < 0.4 * _rot_err(broken, hands, j, frames)


def test_hold_that_ends_smoothly_is_not_a_dropout(hands, joints):
    """Repeats that end without a jump (keyframed or quantised data) are kept."""
    sk = hands.skeleton
    j = sk.index("RightHandIndex2")
    ch = np.array(hands.channels)
    cols = sk.rotation_columns(j)
    # the joint holds still over frames 150..180 and then continues from there: the motion
    # after the hold is the original shifted 31 frames later
    ch[151:181, cols] = ch[150, cols]
    ch[181:, cols] = hands.channels[151:hands.n_frames - 30, cols]
    out, reps = repair_motion(hands.with_channels(ch), joints)
    assert reps == []


def test_spikes_beyond_a_finger_speed(hands, joints):
    sk = hands.skeleton
    j = sk.index("LeftHandRing1")
    q = hands.joint_rotations([j])[:, 0]
    ch = np.array(hands.channels)
    cols = sk.rotation_columns(j)
    # 60 degrees in one frame at 60 fps is 3600 deg/s, above the 3000 deg/s limit; 40 is not
    ch[300, cols] += [60.0, 0.0, 0.0]
    ch[400:402, cols] += [0.0, 70.0, 0.0]
    ch[700, cols] += [40.0, 0.0, 0.0]  # 2400 deg/s: a fast finger, kept
    broken = hands.with_channels(ch)
    fixed, reps = repair_motion(broken, joints)
    assert reps == [Repair("LeftHandRing1", 300, 300, "jump", "slerp"), Repair("LeftHandRing1", 400, 401, "jump", "slerp")]
    assert _rot_err(fixed, hands, j, [300, 400, 401]) < 1.0
    np.testing.assert_array_equal(fixed.channels[700], broken.channels[700])
    assert q.shape[0] == hands.n_frames
    # a lower limit catches the 40-degree spike too
    _, reps2 = repair_motion(broken, joints, max_speed_deg_s=2000.0)
    assert Repair("LeftHandRing1", 700, 700, "jump", "slerp") in reps2
    assert MAX_FINGER_SPEED_DEG_S == 3000.0


def _spinning(n: int, fps: float, deg_per_frame: float) -> Motion:
    """A root and one joint turning at a constant angular velocity about a fixed oblique axis."""
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    ang = np.radians(deg_per_frame) * np.arange(n)
    q = np.concatenate([np.cos(ang / 2)[:, None], np.sin(ang / 2)[:, None] * axis], axis=1)
    sk = Skeleton(("Root", "Spin"), np.array([-1, 0]), np.array([[0, 0, 0], [0, 1.0, 0]]),
                  (("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                   ("Zrotation", "Xrotation", "Yrotation")), None)
    ch = np.zeros((n, 9))
    ch[:, 0] = np.arange(n) * 0.5  # the root walks at constant speed
    ch[:, 3:6] = 5.0 + np.arange(n)[:, None] * [0.3, -0.2, 0.1]
    m = Motion(sk, ch, 1.0 / fps, "spin.bvh")
    return m.with_rotations([1], q[:, None])


def test_constant_angular_velocity_is_recovered_exactly():
    """Known answer: slerp inside and constant-velocity extrapolation at the ends are exact on
    a constant-velocity turn (up to EXTRAPOLATE_MAX_S at the ends)."""
    fps = 60.0
    m = _spinning(120, fps, 2.0)
    ch = np.array(m.channels)
    ch[0:3, 6:9] = np.nan  # start of the spinning joint
    ch[50:60, 6:9] = np.nan  # inside
    ch[117:120, 0:3] = np.nan  # the root's position at the end
    fixed, reps = repair_motion(m.with_channels(ch))
    assert reps == [Repair("Spin", 0, 2, "nan", "extrapolated"), Repair("Spin", 50, 59, "nan", "slerp"),
                    Repair("Root", 117, 119, "nan", "extrapolated")]
    assert 3 <= EXTRAPOLATE_MAX_S * fps
    assert quat_angle(fixed.joint_rotations([1]), m.joint_rotations([1])).max() < 1e-4
    np.testing.assert_allclose(fixed.channels, m.channels, atol=1e-6)


def test_extrapolation_is_held_after_its_limit():
    fps = 60.0
    m = _spinning(60, fps, 1.0)
    ch = np.array(m.channels)
    ch[40:, 6:9] = np.nan  # a third of a second missing at the end
    fixed, reps = repair_motion(m.with_channels(ch))
    assert reps == [Repair("Spin", 40, 59, "nan", "extrapolated")]
    k = int(round(EXTRAPOLATE_MAX_S * fps))
    q = fixed.joint_rotations([1])[:, 0]
    # constant velocity for k frames, then the last extrapolated pose is held
    assert quat_angle(q[39 + k], m.joint_rotations([1])[39 + k, 0]) < 1e-4
    assert quat_angle(q[59], q[39 + k]) < 1e-4


def test_a_joint_without_any_good_frame_is_refused():
    m = _spinning(20, 30.0, 1.0)
    ch = np.array(m.channels)
    ch[:, 6:9] = np.nan
    with pytest.raises(SplicerError, match="joint 'Spin' has no usable frame"):
        repair_motion(m.with_channels(ch))


def test_inputs_not_modified(hands, joints):
    broken = _set(hands, hands.skeleton.index("RightHand"), np.arange(10, 12), np.nan)
    before = broken.channels.copy()
    repair_motion(broken, joints)
    np.testing.assert_array_equal(broken.channels, before)


def test_splice_reports_the_repairs(hands):
    body = read_bvh(SAMPLE / "sample_body.bvh")
    sk = hands.skeleton
    ch = np.array(hands.channels)
    ch[0] = 0.0
    j = sk.index("RightHandIndex2")
    ch[151:181, sk.rotation_columns(j)] = ch[150, sk.rotation_columns(j)]
    broken = hands.with_channels(ch)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = splice(body, broken)
        clean = splice(body, hands)
    assert r.report["hands_repairs"] == [
        {"joint": "*", "frames": [0, 0], "kind": "zero_row", "method": "extrapolated"},
        {"joint": "RightHandIndex2", "frames": [151, 180], "kind": "frozen", "method": "slerp"}]
    assert any("repaired 2 broken stretch(es)" in w and "RightHandIndex2 frames 151..180 (frozen, slerp)" in w
               for w in r.report["warnings"])
    assert clean.report["hands_repairs"] == []
    # the repaired splice stays near the clean one (same alignment give or take a frame)
    for s in ("left", "right"):
        a, b = r.sides[s].hands_frame, clean.sides[s].hands_frame
        assert np.array_equal(np.isfinite(a), np.isfinite(b))  # the same frames covered
        assert np.nanmean(np.abs(a - b)) < 1.0
    off = splice(body, broken, repair="off")
    assert off.report["hands_repairs"] == [] and not any("repaired" in w for w in off.report["warnings"])


def test_summary_lists_and_counts():
    reps = [Repair("*", 0, 0, "zero_row", "extrapolated")] + [Repair(f"J{k}", k, k + 2, "frozen", "slerp") for k in range(8)]
    s = repairs_summary(reps, "h.bvh", limit=3)
    assert s.startswith("h.bvh: repaired 9 broken stretch(es) of the hand capture before aligning (1 zero row, 8 frozen)")
    assert "* frames 0..0 (zero_row, extrapolated); J0 frames 0..2 (frozen, slerp); J1 frames 1..3" in s
    assert "; and 6 more" in s


def test_leap_files_first_row(shared_motions):
    """The Leap exports' all-zero first data row is found and extrapolated from the next frames."""
    for f in sorted((shared_motions / "leap-hands").glob("*.bvh")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = read_bvh(f)
        r = find_roles(m.skeleton, source=str(f))
        fixed, reps = repair_motion(m, hand_joints(m.skeleton, r.sides.values()))
        assert reps[0] == Repair("*", 0, 0, "zero_row", "extrapolated"), f.name
        assert not np.all(fixed.channels[0] == 0.0)
        # the root continues the first frames' velocity, measured over VELOCITY_BASELINE_S (frames 1 and 3)
        assert round(VELOCITY_BASELINE_S * m.fps) == 2
        pc = m.skeleton.position_columns(0)
        np.testing.assert_allclose(fixed.channels[0, pc], m.channels[1, pc] + 0.5 * (m.channels[1, pc] - m.channels[3, pc]))


def test_quaternion_helper_matches_euler():
    # guards the test helper's assumption: one Euler increment of 60 deg about X is a 60-degree turn
    a = quat_from_euler(np.array([[10.0, 20.0, 30.0]]), "ZXY")
    b = quat_from_euler(np.array([[70.0, 20.0, 30.0]]), "ZXY")
    assert abs(quat_angle(a, b)[0] - 60.0) < 1e-9


def test_cli_reports_repairs_and_no_repair_turns_them_off(hands, tmp_path, capsys):
    import json

    from splicer.io.bvh import write_bvh
    from splicer.cli import main

    ch = np.array(hands.channels)
    ch[0] = 0.0
    src = tmp_path / "hands_zero.bvh"
    write_bvh(hands.with_channels(ch), src)
    body = SAMPLE / "sample_body.bvh"
    assert main([str(body), str(src), "-o", str(tmp_path / "a.bvh"), "--report", str(tmp_path / "a.json"), "-q"]) == 0
    assert json.loads((tmp_path / "a.json").read_text())["hands_repairs"] == [
        {"joint": "*", "frames": [0, 0], "kind": "zero_row", "method": "extrapolated"}]
    assert main([str(body), str(src), "-o", str(tmp_path / "b.bvh"), "--report", str(tmp_path / "b.json"), "-q",
                 "--no-repair"]) == 0
    rep = json.loads((tmp_path / "b.json").read_text())
    assert rep["hands_repairs"] == [] and rep["options"]["repair"] == "off"


def test_the_search_reports_its_progress_joint_by_joint(hands, joints):
    """Two passes over the joints (frozen stretches, then spikes): one call per joint each, rising
    from 0 to below 1; the result is the same with or without the callback."""
    seen = []
    _, reps = repair_motion(hands, joints, progress=seen.append)
    assert len(seen) == 2 * len(joints) and seen == sorted(seen) and seen[0] == 0.0 and seen[-1] < 1.0
    assert seen[len(joints)] == 0.5
    assert reps == repair_motion(hands, joints)[1]


def test_a_turn_is_at_most_the_sum_of_its_euler_changes():
    # the jump test skips the rotations of a joint whose Euler channels never change by the limit
    # in sum between two frames (dropouts._steps_below); that relies on this bound, for every order
    rng = np.random.default_rng(7)
    for order in ("ZXY", "XYZ", "YZX", "ZYX", "XZY", "YXZ"):
        a = rng.uniform(-180, 180, size=(2000, 3))
        b = a + rng.normal(scale=rng.choice([0.1, 5.0, 40.0]), size=(2000, 3))
        ang = quat_angle(quat_from_euler(a, order), quat_from_euler(b, order))
        assert np.all(ang <= np.abs(b - a).sum(axis=1) + 1e-9)


def test_steps_below_the_limit_worked_answers():
    from splicer.rig.dropouts import _steps_below
    ch = np.zeros((5, 4))
    ch[:, 1] = [0, 10, 20, 30, 40]   # 10 degrees a frame about the first axis
    ch[:, 2] = [0, 5, 0, 5, 0]       # and 5 about the second: at most 15 a frame
    assert _steps_below(ch, [1, 2, 3], 15.1)
    assert not _steps_below(ch, [1, 2, 3], 15.0)  # the sum reaches the limit: the full test decides
    ch[2, 3] = np.nan
    assert not _steps_below(ch, [1, 2, 3], 100.0)  # NaN: the full test decides
    assert not _steps_below(ch, [1, 2], 100.0)    # not three rotation channels


def test_the_jump_test_finds_the_same_spikes_with_and_without_the_shortcut(hands, joints, monkeypatch):
    import splicer.rig.dropouts as D
    ch = np.array(hands.channels)
    sk = hands.skeleton
    j = joints[len(joints) // 2]
    cols = sk.rotation_columns(j)
    ch[100:102, cols[0]] += 60.0   # a two-frame spike in one finger joint
    spiky = Motion(sk, ch, hands.frame_time, hands.source)
    with_shortcut = D.detect_problems(spiky, joints)
    monkeypatch.setattr(D, "_steps_below", lambda *a: False)
    without = D.detect_problems(spiky, joints)
    assert with_shortcut.keys() == without.keys() and j in with_shortcut
    for k in with_shortcut:
        assert with_shortcut[k].keys() == without[k].keys()
        for kind in with_shortcut[k]:
            assert np.array_equal(with_shortcut[k][kind], without[k][kind])
