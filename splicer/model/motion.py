"""The motion data model: a frozen skeleton and a frozen motion.

Time is the first axis of every per-frame array.  A :class:`Motion` keeps the BVH
channel values exactly as read (``channels``) and the same data as local rotations
(quaternions) and translations; operations return new objects and never modify
their inputs.  Lengths are in the file's own units (BVH does not state them), angles in
degrees at the file boundary, quaternions are ``(w, x, y, z)`` (see
:mod:`splicer.rotations`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .rotations import euler_channels_deg, quat_from_euler, quat_hemisphere

__all__ = ["Skeleton", "Motion", "preorder"]  # _Owned: for the package's own constructors

_POS = ("Xposition", "Yposition", "Zposition")
_ROT = ("Xrotation", "Yrotation", "Zrotation")


class _Owned:
    """An array handed to a constructor by the code that just made it and keeps no reference:
    the constructor takes it over (frozen in place) instead of copying it."""

    __slots__ = ("array",)

    def __init__(self, array: np.ndarray):
        self.array = array


def _readonly(a, dtype=np.float64) -> np.ndarray:
    """A frozen (read-only) array of ``a``: a copy, except for an :class:`_Owned` array of
    ``dtype`` that owns its C-contiguous data, which is frozen in place (no copy)."""
    if isinstance(a, _Owned):
        a = a.array
        if isinstance(a, np.ndarray) and a.dtype == dtype and a.flags.owndata and a.flags.c_contiguous:
            a.setflags(write=False)
            return a
    a = np.array(a, dtype=dtype, copy=True)
    a.setflags(write=False)
    return a


def preorder(parents, start: int | None = None) -> list[int]:
    """Joints in depth-first pre-order, siblings in index order: the one joint traversal.

    Parameters
    ----------
    parents : sequence of int [length J]
        Parent index of each joint, -1 for a root (any order: children may come first).
    start : int, optional
        Visit only ``start`` and the joints below it; None: every tree, roots in index order.

    Returns
    -------
    list of int
        A BVH file lists its joints in this order (a skeleton read from one has
        ``preorder(parents) == list(range(J))``).

    >>> preorder([-1, 0, 1, 0, 3, 2])
    [0, 1, 2, 5, 3, 4]
    >>> preorder([-1, 0, 1, 0, 3, 2], start=1)
    [1, 2, 5]
    """
    kids: dict[int, list[int]] = {}
    for j, p in enumerate(parents):
        kids.setdefault(int(p), []).append(j)
    order: list[int] = []
    stack = list(reversed(kids.get(-1, []) if start is None else [int(start)]))
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(kids.get(j, [])))
    return order


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy in rest pose.

    Parameters
    ----------
    names : tuple of str [length J]
        Joint names, parents before children (BVH order).
    parents : np.ndarray [shape=(J,), dtype=int64]
        Parent index of each joint, -1 for the root.
    offsets : np.ndarray [shape=(J, 3), dtype=float64]
        Rest offset of each joint from its parent, file units.
    channels : tuple of tuple of str [length J]
        Each joint's channel names in file order, e.g. ``("Zrotation", "Xrotation", "Yrotation")``.
    end_sites : np.ndarray [shape=(J, 3), dtype=float64]
        Offset of the joint's End Site, NaN where the joint has none.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_sites: np.ndarray

    def __post_init__(self):
        names = tuple(str(n) for n in self.names)
        J = len(names)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", _readonly(self.parents, np.int64).reshape(J))
        object.__setattr__(self, "offsets", _readonly(self.offsets).reshape(J, 3))
        object.__setattr__(self, "channels", tuple(tuple(c) for c in self.channels))
        es = self.end_sites
        if es is None:
            es = np.full((J, 3), np.nan)
        object.__setattr__(self, "end_sites", _readonly(es).reshape(J, 3))
        if len(self.channels) != J:
            raise ValueError("one channel list per joint is required")
        for j, p in enumerate(self.parents):
            if not (-1 <= p < j):
                raise ValueError(f"joint {names[j]!r}: parent index {p} must precede it")
        for j, ch in enumerate(self.channels):
            for c in ch:
                if c not in _POS + _ROT:
                    raise ValueError(f"joint {names[j]!r}: unknown channel {c!r}")

    # -- structure -------------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of the joint called ``name`` (exact match)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(name) from None

    @cached_property
    def children(self) -> tuple[tuple[int, ...], ...]:
        kids: list[list[int]] = [[] for _ in self.names]
        for j, p in enumerate(self.parents):
            if p >= 0:
                kids[p].append(j)
        return tuple(tuple(k) for k in kids)

    def descendants(self, j: int) -> list[int]:
        """Indices of all joints below ``j`` (not including ``j``), in file order."""
        return sorted(preorder(self.parents, start=j)[1:])

    def chain(self, j: int) -> list[int]:
        """Joint indices from the root down to ``j`` inclusive."""
        out = []
        while j >= 0:
            out.append(j)
            j = int(self.parents[j])
        return out[::-1]

    # -- channel layout ----------------------------------------------------------------------
    @cached_property
    def channel_offsets(self) -> np.ndarray:
        """Index of each joint's first channel in a frame row, shape (J + 1,)."""
        return np.concatenate([[0], np.cumsum([len(c) for c in self.channels])]).astype(np.int64)

    @property
    def n_channels(self) -> int:
        return int(self.channel_offsets[-1])

    def rotation_order(self, j: int) -> str:
        """Rotation axis letters of joint ``j`` in file order (``""`` without rotation channels)."""
        return "".join(c[0] for c in self.channels[j] if c in _ROT)

    def rotation_columns(self, j: int) -> list[int]:
        o = int(self.channel_offsets[j])
        return [o + k for k, c in enumerate(self.channels[j]) if c in _ROT]

    def position_columns(self, j: int) -> list[int]:
        """Column of X, Y, Z position (in that order) for joint ``j``; empty without positions."""
        o = int(self.channel_offsets[j])
        cols = {c: o + k for k, c in enumerate(self.channels[j]) if c in _POS}
        return [cols[c] for c in _POS] if len(cols) == 3 else []


@dataclass(frozen=True, eq=False)
class Motion:
    """A skeleton animated over frames.

    Parameters
    ----------
    skeleton : Skeleton
    channels : np.ndarray [shape=(T, C), dtype=float64]
        Channel values exactly as in the file (degrees, file units), one row per frame.
    frame_time : float
        Seconds per frame (BVH ``Frame Time``).
    source : str, optional
        Where the motion came from (a path), used in messages.

    Notes
    -----
    ``rotations`` (T, J, 4) and ``translations`` (T, J, 3) are derived from ``channels``
    and the skeleton.  A joint without rotation channels has the identity rotation; a
    joint without position channels has its rest offset as translation.  Frame ``t``
    is at time ``t * frame_time`` seconds; a motion of T frames lasts
    ``(T - 1) * frame_time`` seconds from first to last frame.
    """

    skeleton: Skeleton
    channels: np.ndarray
    frame_time: float
    source: str | None = field(default=None)

    def __post_init__(self):
        ch = _readonly(self.channels)
        if ch.ndim != 2 or ch.shape[1] != self.skeleton.n_channels:
            raise ValueError(
                f"channels must have shape (frames, {self.skeleton.n_channels}), got {ch.shape}"
            )
        object.__setattr__(self, "channels", ch)
        ft = float(self.frame_time)
        if not (ft > 0 and np.isfinite(ft)):
            raise ValueError(f"frame_time must be a positive number of seconds, got {self.frame_time!r}")
        object.__setattr__(self, "frame_time", ft)

    @property
    def n_frames(self) -> int:
        return int(self.channels.shape[0])

    @property
    def fps(self) -> float:
        """Frames per second."""
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame."""
        return max(self.n_frames - 1, 0) * self.frame_time

    @cached_property
    def _per_joint(self) -> dict:
        return {}

    def joint_rotations(self, joints, *, keep: bool = True) -> np.ndarray:
        """Local rotations of some joints, shape (T, K, 4), ``(w, x, y, z)``, hemisphere-continuous in time.

        Converted from the channels on first use and, with ``keep`` (the default), kept for
        the next call (32 bytes per frame and joint, until :meth:`forget_rotations`); with
        ``keep=False`` a joint not kept yet is converted for this call only.  A joint without
        rotation channels has the identity (missing axes of a joint with fewer than three
        count as zero).
        """
        sk = self.skeleton
        out = np.empty((self.n_frames, len(joints), 4))
        for k, j in enumerate(joints):
            key = ("r", int(j))
            q = self._per_joint.get(key)
            if q is None:
                cols = sk.rotation_columns(j)
                if cols:
                    q = quat_hemisphere(quat_from_euler(self.channels[:, cols], sk.rotation_order(j)), axis=0)
                else:
                    q = np.zeros((self.n_frames, 4))
                    q[:, 0] = 1.0
                if keep:
                    q.setflags(write=False)
                    self._per_joint[key] = q
            out[:, k] = q
        return out

    def forget_rotations(self) -> None:
        """Drop the per-joint rotations :meth:`joint_rotations` kept (memory only: the values are
        converted again when asked for; the motion itself does not change)."""
        self._per_joint.clear()

    def joint_translations(self, joints) -> np.ndarray:
        """Local translations of some joints, shape (T, K, 3), file units (the rest offset where
        a joint has no position channels)."""
        sk = self.skeleton
        out = np.empty((self.n_frames, len(joints), 3))
        for k, j in enumerate(joints):
            cols = sk.position_columns(j)
            out[:, k] = self.channels[:, cols] if cols else sk.offsets[j]
        return out

    @cached_property
    def rotations(self) -> np.ndarray:
        """Local joint rotations of every joint, shape (T, J, 4) (see :meth:`joint_rotations`)."""
        q = self.joint_rotations(range(self.skeleton.n_joints))
        q.setflags(write=False)
        return q

    @cached_property
    def translations(self) -> np.ndarray:
        """Local joint translations of every joint, shape (T, J, 3), file units."""
        t = self.joint_translations(range(self.skeleton.n_joints))
        t.setflags(write=False)
        return t

    # -- operations (return new objects) ----------------------------------------------------
    def with_channels(self, channels: np.ndarray) -> "Motion":
        """A new motion with these channel values (copied), same skeleton, rate and source."""
        return Motion(self.skeleton, channels, self.frame_time, self.source)

    def frames(self, index) -> "Motion":
        """The frames ``index`` (an integer array, any order, repeats allowed), as a new motion;
        the gathered channels are taken over, not copied a second time."""
        ch = self.channels[np.asarray(index, dtype=np.int64)]
        return Motion(self.skeleton, _Owned(ch), self.frame_time, self.source)

    def with_rotations(self, joints, rotations: np.ndarray) -> "Motion":
        """A new motion whose joints ``joints`` have local rotations ``rotations``.

        Parameters
        ----------
        joints : sequence of int [length K]
        rotations : np.ndarray [shape=(T, K, 4)]

        The affected joints' rotation channels are rewritten as Euler angles in each
        joint's own channel order, unwrapped over time (no 360-degree jumps); all other
        channels are copied unchanged.
        """
        joints = list(joints)
        rotations = np.asarray(rotations, dtype=np.float64)
        if rotations.shape != (self.n_frames, len(joints), 4):
            raise ValueError(f"rotations must have shape {(self.n_frames, len(joints), 4)}, got {rotations.shape}")
        ch = np.array(self.channels)
        sk = self.skeleton
        for k, j in enumerate(joints):
            cols = sk.rotation_columns(j)
            if len(cols) != 3:
                raise ValueError(f"joint {sk.names[j]!r} has {len(cols)} rotation channels; 3 are needed to set a rotation")
            ch[:, cols] = euler_channels_deg(rotations[:, k], sk.rotation_order(j))
        return Motion(sk, _Owned(ch), self.frame_time, self.source)

    def with_translations(self, joint: int, xyz: np.ndarray) -> "Motion":
        """A new motion whose joint ``joint`` (which has position channels) is at ``xyz`` (T, 3)."""
        cols = self.skeleton.position_columns(joint)
        if not cols:
            raise ValueError(f"joint {self.skeleton.names[joint]!r} has no position channels")
        ch = np.array(self.channels)
        ch[:, cols] = xyz
        return Motion(self.skeleton, _Owned(ch), self.frame_time, self.source)

    def slice(self, start: int, stop: int) -> "Motion":
        """Frames ``start`` (inclusive) to ``stop`` (exclusive)."""
        return self.with_channels(self.channels[start:stop])
