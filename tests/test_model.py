"""Worked answers for splicer.model.motion: the skeleton's structure and channel layout, a motion's
units (degrees in channels, seconds per frame) and the Euler write-back of rotations."""

import numpy as np
import pytest

from splicer.model.motion import Motion, Skeleton, preorder
from splicer.model.rotations import quat_from_euler

POS = ("Xposition", "Yposition", "Zposition")
ZXY = ("Zrotation", "Xrotation", "Yrotation")


def _skeleton():
    """root (6 ch, positions stored Z X Y) -> spine (ZXY) -> head (no channels);
    root -> arm (Z X rotations only); 9 channels: root 0-5, spine 6-8, arm 9-10."""
    return Skeleton(
        names=("root", "spine", "head", "arm"),
        parents=np.array([-1, 0, 1, 0]),
        offsets=np.array([[0, 90.0, 0], [0, 10.0, 0], [0, 20.0, 0], [15.0, 0, 0]]),
        channels=(("Zposition", "Xposition", "Yposition") + ZXY, ZXY, (), ("Zrotation", "Xrotation")),
        end_sites=None,
    )


def test_structure():
    sk = _skeleton()
    assert sk.n_joints == 4 and sk.index("arm") == 3
    with pytest.raises(KeyError):
        sk.index("Arm")
    assert sk.children == ((1, 3), (2,), (), ())
    assert sk.descendants(0) == [1, 2, 3] and sk.descendants(1) == [2] and sk.descendants(2) == []
    assert sk.chain(2) == [0, 1, 2] and sk.chain(0) == [0]
    assert np.isnan(sk.end_sites).all() and sk.end_sites.shape == (4, 3)


def test_channel_layout():
    sk = _skeleton()
    assert sk.channel_offsets.tolist() == [0, 6, 9, 9, 11] and sk.n_channels == 11
    assert sk.rotation_order(0) == "ZXY" and sk.rotation_order(2) == "" and sk.rotation_order(3) == "ZX"
    assert sk.rotation_columns(0) == [3, 4, 5] and sk.rotation_columns(1) == [6, 7, 8]
    assert sk.rotation_columns(3) == [9, 10] and sk.rotation_columns(2) == []
    # X, Y, Z order whatever the file's order (Z X Y here: X is column 1, Y 2, Z 0)
    assert sk.position_columns(0) == [1, 2, 0] and sk.position_columns(1) == []


@pytest.mark.parametrize("kw,match", [
    (dict(parents=np.array([-1, 2, 1, 0])), r"joint 'spine': parent index 2 must precede it"),
    (dict(channels=(("Xposition",), ("Wrotation",), (), ())), r"joint 'spine': unknown channel 'Wrotation'"),
    (dict(channels=((), ())), "one channel list per joint"),
])
def test_skeleton_validation(kw, match):
    sk = _skeleton()
    args = dict(names=sk.names, parents=sk.parents, offsets=sk.offsets, channels=sk.channels, end_sites=None)
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        Skeleton(**args)


def test_skeleton_arrays_are_read_only_copies():
    parents = np.array([-1, 0, 1, 0])
    sk = Skeleton(("a", "b", "c", "d"), parents, np.zeros((4, 3)), ((),) * 4, None)
    parents[1] = -1
    assert sk.parents.tolist() == [-1, 0, 1, 0]
    with pytest.raises(ValueError):
        sk.offsets[0, 0] = 1.0


def test_preorder():
    # 0 -> (1 -> (2 -> 5), 3 -> 4): depth first, siblings in index order
    assert preorder([-1, 0, 1, 0, 3, 2]) == [0, 1, 2, 5, 3, 4]
    assert preorder([-1, 0, 1, 0, 3, 2], start=3) == [3, 4]
    # children listed before their parents (a graft appends joints at the end)
    assert preorder([2, 2, -1, 0]) == [2, 0, 3, 1]
    assert preorder([]) == []


def test_motion_units_and_validation():
    sk = _skeleton()
    m = Motion(sk, np.zeros((5, 11)), 1 / 120)
    assert m.n_frames == 5 and m.fps == pytest.approx(120.0)
    assert m.duration == pytest.approx(4 / 120)  # first to last frame: (T - 1) x frame time
    assert Motion(sk, np.zeros((0, 11)), 0.5).duration == 0.0
    with pytest.raises(ValueError, match=r"channels must have shape \(frames, 11\), got \(5, 10\)"):
        Motion(sk, np.zeros((5, 10)), 1 / 120)
    for bad in (0.0, -1.0, np.nan, np.inf):
        with pytest.raises(ValueError, match="frame_time must be a positive number of seconds"):
            Motion(sk, np.zeros((5, 11)), bad)


def test_rotations_from_degrees_and_identity_for_joints_without_channels():
    sk = _skeleton()
    ch = np.zeros((2, 11))
    ch[:, 3:6] = [90.0, 0, 0]      # root: 90 deg about Z (ZXY columns)
    ch[:, 7] = 90.0                # spine X rotation
    ch[:, 9:11] = [0.0, 60.0]      # arm: Z 0, X 60 (two rotation channels, missing Y is zero)
    m = Motion(sk, ch, 1 / 30)
    s = np.sqrt(0.5)
    np.testing.assert_allclose(m.rotations[0, 0], [s, 0, 0, s], atol=1e-15)
    np.testing.assert_allclose(m.rotations[0, 1], [s, s, 0, 0], atol=1e-15)
    np.testing.assert_allclose(m.rotations[0, 2], [1, 0, 0, 0])
    np.testing.assert_allclose(m.rotations[0, 3], [np.sqrt(3) / 2, 0.5, 0, 0], atol=1e-15)
    assert m.rotations.shape == (2, 4, 4) and not m.rotations.flags.writeable
    np.testing.assert_array_equal(m.joint_rotations([3, 1]), m.rotations[:, [3, 1]])


def test_rotations_are_hemisphere_continuous_in_time():
    sk = _skeleton()
    ch = np.zeros((3, 11))
    ch[:, 7] = [170.0, 190.0, 210.0]  # X: the quaternion's w changes sign at 180
    q = Motion(sk, ch, 1 / 30).rotations[:, 1]
    assert np.all(np.sum(q[1:] * q[:-1], axis=-1) > 0)


def test_translations_use_positions_or_the_rest_offset():
    sk = _skeleton()
    ch = np.zeros((2, 11))
    ch[:, 0:3] = [[3.0, 1.0, 2.0], [6.0, 4.0, 5.0]]  # Z X Y in the file
    m = Motion(sk, ch, 1 / 30)
    np.testing.assert_array_equal(m.translations[:, 0], [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(m.translations[:, 3], [[15, 0, 0], [15, 0, 0]])


def test_with_rotations_writes_degrees_in_the_joint_order_and_unwraps():
    sk = _skeleton()
    ch = np.arange(22.0).reshape(2, 11)
    m = Motion(sk, ch, 1 / 30)
    # spine (Z X Y channels): 30 deg about X, then Z 170 and X 20
    q = quat_from_euler(np.array([[0.0, 30.0, 0.0], [170.0, 20.0, 0.0]]), "ZXY")[:, None]
    out = m.with_rotations([1], q)
    np.testing.assert_allclose(out.channels[:, 6:9], [[0, 30, 0], [170, 20, 0]], atol=1e-9)
    # Z from 170 to -170 is a 20-degree step across the wrap: written 170 -> 190
    q2 = quat_from_euler(np.array([[170.0, 0.0, 0.0], [-170.0, 0.0, 0.0]]), "ZXY")[:, None]
    np.testing.assert_allclose(m.with_rotations([1], q2).channels[:, 6], [170, 190], atol=1e-9)
    # every other channel is copied; the input is not modified
    keep = [c for c in range(11) if c not in (6, 7, 8)]
    np.testing.assert_array_equal(out.channels[:, keep], ch[:, keep])
    np.testing.assert_array_equal(m.channels, np.arange(22.0).reshape(2, 11))
    # a round trip through the rotations reproduces them
    np.testing.assert_allclose(np.abs(np.sum(out.rotations[:, 1] * q[:, 0], axis=-1)), 1.0, atol=1e-12)
    # non-unit quaternions are normalised first
    np.testing.assert_allclose(m.with_rotations([1], 2.0 * q).channels, out.channels, atol=1e-9)


def test_with_rotations_refuses_bad_shapes_and_joints_without_three_axes():
    m = Motion(_skeleton(), np.zeros((2, 11)), 1 / 30)
    with pytest.raises(ValueError, match=r"rotations must have shape \(2, 1, 4\), got \(2, 4\)"):
        m.with_rotations([1], np.zeros((2, 4)))
    with pytest.raises(ValueError, match="joint 'arm' has 2 rotation channels; 3 are needed"):
        m.with_rotations([3], np.tile([1.0, 0, 0, 0], (2, 1, 1)))


def test_with_translations_and_slice():
    m = Motion(_skeleton(), np.zeros((4, 11)), 1 / 30, source="x.bvh")
    out = m.with_translations(0, np.array([[1.0, 2, 3]] * 4))
    np.testing.assert_array_equal(out.channels[0, :3], [3, 1, 2])  # written back Z X Y
    with pytest.raises(ValueError, match="joint 'spine' has no position channels"):
        m.with_translations(1, np.zeros((4, 3)))
    s = out.slice(1, 3)
    assert s.n_frames == 2 and s.frame_time == m.frame_time and s.source == "x.bvh"


def test_joint_rotations_keep_and_forget():
    """keep=True (default) stores one (T, 4) array per joint; keep=False and forget_rotations store none;
    the values are the same either way (spine: 90 deg about X -> (sqrt(1/2), sqrt(1/2), 0, 0))."""
    ch = np.zeros((3, 11))
    ch[:, 7] = 90.0
    m = Motion(_skeleton(), ch, 1 / 30)
    s = np.sqrt(0.5)
    q = m.joint_rotations([1], keep=False)
    np.testing.assert_allclose(q[:, 0], [[s, s, 0, 0]] * 3, atol=1e-15)
    assert m._per_joint == {}
    np.testing.assert_array_equal(m.joint_rotations([1, 2]), np.stack([q[:, 0], [[1.0, 0, 0, 0]] * 3], axis=1))
    assert sorted(m._per_joint) == [("r", 1), ("r", 2)]
    m.forget_rotations()
    assert m._per_joint == {}
    np.testing.assert_array_equal(m.joint_rotations([1], keep=False), q)


def test_operations_take_over_their_fresh_arrays_and_freeze_them():
    """with_rotations / with_translations / frames hand their new channel arrays to the constructor,
    which keeps them (no second copy) read-only; a caller's own array is still copied and left writable."""
    from splicer.model import motion as motion_mod

    made = []
    real = motion_mod._readonly

    def spy(a, dtype=np.float64):
        out = real(a, dtype)
        if isinstance(a, motion_mod._Owned):
            made.append((a.array, out))
        return out

    m = Motion(_skeleton(), np.arange(44.0).reshape(4, 11), 1 / 30)
    mine = np.zeros((4, 11))
    other = Motion(_skeleton(), mine, 1 / 30)
    assert not np.shares_memory(other.channels, mine) and mine.flags.writeable
    try:
        motion_mod._readonly = spy
        a = m.with_rotations([1], np.tile([1.0, 0, 0, 0], (4, 1, 1)))
        b = m.with_translations(0, np.ones((4, 3)))
        c = m.frames([3, 0, 3])
    finally:
        motion_mod._readonly = real
    assert len(made) == 3
    for (given, kept), res in zip(made, (a, b, c)):
        assert kept is given and res.channels is given and not res.channels.flags.writeable
        assert not np.shares_memory(res.channels, m.channels)
    np.testing.assert_array_equal(c.channels, m.channels[[3, 0, 3]])
    np.testing.assert_array_equal(a.channels[:, 6:9], 0.0)          # spine's angles, identity
    np.testing.assert_array_equal(a.channels[:, :6], m.channels[:, :6])


def test_owned_arrays_of_another_dtype_or_layout_are_copied():
    from splicer.model.motion import _Owned, _readonly

    f32 = np.ones((3, 2), np.float32)
    view = np.ones((4, 6))[:, ::2]
    for a in (f32, view):
        out = _readonly(_Owned(a))
        assert out.dtype == np.float64 and not np.shares_memory(out, a) and a.flags.writeable
        assert not out.flags.writeable
    own = np.ones((3, 2))
    out = _readonly(_Owned(own))
    assert out is own and not own.flags.writeable
