"""The hands capture in the forms real hand trackers write (issue 9, c-handonly).

A hand-only skeleton rooted at the wrist (ManipNet-like, :func:`wrist_rooted`) or at the
forearm with its root at the wrist (Leap-like, :func:`forearm_rooted`), one file per side
(:func:`hand_only_files`), and a capture reflected through a plane with its joint names
kept (:func:`mirror_motion`).  Used by :func:`splicer.evaluation.separate.separate` and the
``--hands-form`` / ``--mirror`` options of ``splicer-evaluate``.
"""

from __future__ import annotations

import numpy as np

from ..model.kinematics import global_transforms
from ..model.motion import Motion, Skeleton
from ..model.rotations import quat_conj, quat_hemisphere, quat_mul
from ..rig.roles import Roles

__all__ = ["wrist_rooted", "forearm_rooted", "hand_only_files", "mirror_motion"]


def wrist_rooted(motion: Motion, wrist: int, *, source: str | None = None) -> Motion:
    """The subtree of ``wrist`` as its own motion: the wrist becomes the root, with six
    channels (``Xposition Yposition Zposition`` then its rotation channels) holding its world
    position and rotation; the joints below keep their offsets and channels.

    Parameters
    ----------
    motion : Motion
    wrist : int
        Joint index in ``motion.skeleton``; it must have three rotation channels.
    source : str, optional
        Source of the result (e.g. ``"hands_left.bvh"``, which names the side).

    Returns
    -------
    Motion
        Same frames and frame time.
    """
    sk = motion.skeleton
    if len(sk.rotation_columns(wrist)) != 3:
        raise ValueError(f"joint {sk.names[wrist]!r} needs three rotation channels to become a root")
    joints = [wrist] + sk.descendants(wrist)
    new_index = {j: k for k, j in enumerate(joints)}
    rot_ch = tuple(c for c in sk.channels[wrist] if c.endswith("rotation"))
    channels = [("Xposition", "Yposition", "Zposition") + rot_ch] + [sk.channels[j] for j in joints[1:]]
    parents = [-1] + [new_index[int(sk.parents[j])] for j in joints[1:]]
    offsets = np.array(sk.offsets[joints])
    offsets[0] = 0.0
    sub = Skeleton(tuple(sk.names[j] for j in joints), np.array(parents), offsets, tuple(channels), sk.end_sites[joints])
    gq, gp = global_transforms(motion, [wrist])
    cols = np.concatenate([sk.channel_offsets[j] + np.arange(len(sk.channels[j])) for j in joints[1:]]).astype(np.int64) \
        if len(joints) > 1 else np.zeros(0, np.int64)
    ch = np.zeros((motion.n_frames, sub.n_channels))
    ch[:, 3 + len(rot_ch):] = motion.channels[:, cols]
    ch[:, :3] = gp[:, 0]
    out = Motion(sub, ch, motion.frame_time, source)
    return out.with_rotations([0], quat_hemisphere(gq, axis=0))


def forearm_rooted(motion: Motion, forearm: int, wrist: int, *, source: str | None = None) -> Motion:
    """The subtree of ``wrist`` under a forearm root placed AT the wrist, as Leap hand files are.

    The root (named as ``forearm``) has six channels: position = the wrist's world position,
    rotation = the forearm joint's world rotation; the wrist follows at offset zero with its
    rotation relative to the forearm joint (``conj(G_forearm) G_wrist``, the local rotation when
    the forearm is the wrist's parent); the joints below keep their offsets and channels.  The
    forearm's length and the shoulder are lost, as in a Leap capture.

    Parameters
    ----------
    motion : Motion
    forearm, wrist : int
        Joint indices in ``motion.skeleton`` (``forearm`` an ancestor of ``wrist``); both need
        three rotation channels.
    source : str, optional
        Source of the result (e.g. ``"hands_right.bvh"``).

    Returns
    -------
    Motion
        Same frames and frame time.
    """
    sk = motion.skeleton
    for j in (forearm, wrist):
        if len(sk.rotation_columns(j)) != 3:
            raise ValueError(f"joint {sk.names[j]!r} needs three rotation channels")
    if forearm not in sk.chain(wrist)[:-1]:
        raise ValueError(f"joint {sk.names[forearm]!r} is not above {sk.names[wrist]!r}")
    below = sk.descendants(wrist)
    joints = [wrist] + below
    new_index = {j: k + 1 for k, j in enumerate(joints)}
    rot_f = tuple(c for c in sk.channels[forearm] if c.endswith("rotation"))
    rot_w = tuple(c for c in sk.channels[wrist] if c.endswith("rotation"))
    channels = [("Xposition", "Yposition", "Zposition") + rot_f, rot_w] + [sk.channels[j] for j in below]
    parents = [-1, 0] + [new_index[int(sk.parents[j])] for j in below]
    offsets = np.concatenate([np.zeros((2, 3)), sk.offsets[below]])
    ends = np.concatenate([np.full((1, 3), np.nan), sk.end_sites[joints]])
    sub = Skeleton((sk.names[forearm],) + tuple(sk.names[j] for j in joints), np.array(parents), offsets,
                   tuple(channels), ends)
    gq, gp = global_transforms(motion, [forearm, wrist])
    ch = np.zeros((motion.n_frames, sub.n_channels))
    if below:
        cols = np.concatenate([sk.channel_offsets[j] + np.arange(len(sk.channels[j])) for j in below]).astype(np.int64)
        ch[:, 6 + len(rot_w):] = motion.channels[:, cols]
    ch[:, :3] = gp[:, 1]
    out = Motion(sub, ch, motion.frame_time, source)
    rel = quat_mul(quat_conj(gq[:, 0]), gq[:, 1])
    return out.with_rotations([0, 1], quat_hemisphere(np.stack([gq[:, 0], rel], axis=1), axis=0))


def hand_only_files(hands: Motion, roles: Roles, form: str) -> dict:
    """Per side, the hands take as the hand-only file a real capture would give.

    Parameters
    ----------
    hands : Motion
        A full-skeleton hands take (e.g. :attr:`Separation.hands`).
    roles : Roles
        Roles of ``hands.skeleton``.
    form : {"wrist", "forearm"}
        ``"wrist"``: wrist-rooted (ManipNet-like, :func:`wrist_rooted`); ``"forearm"``: forearm
        root at the wrist (Leap-like, :func:`forearm_rooted`).

    Returns
    -------
    dict of str to Motion
        ``{"left": ..., "right": ...}`` with sources ``hands_left.bvh`` / ``hands_right.bvh``.
    """
    if form not in ("wrist", "forearm"):
        raise ValueError(f"form must be 'wrist' or 'forearm', got {form!r}")
    out = {}
    for side, arm in roles.sides.items():
        src = f"hands_{side}.bvh"
        if form == "wrist":
            out[side] = wrist_rooted(hands, arm.wrist, source=src)
        else:
            if arm.elbow is None:
                raise ValueError(f"the {side} arm has no forearm joint to root a Leap-like file at")
            out[side] = forearm_rooted(hands, arm.elbow, arm.wrist, source=src)
    return out


def mirror_motion(motion: Motion, axis: int = 0) -> Motion:
    """The motion reflected through the plane normal to coordinate axis ``axis`` (0=X, 1=Y, 2=Z).

    The convention of left-handed-engine exports (the ManipNet files): every position and
    offset has its ``axis`` component negated, and a rotation ``R`` becomes ``M R M`` with
    ``M`` the reflection, which for BVH Euler channels means negating the angles about the two
    other axes (``M R_a(t) M = R_a(t)`` for ``a == axis``, ``R_a(-t)`` otherwise).  Joint names
    are kept: a right hand reflected this way is shaped like a left hand but still named right.
    Applying it twice gives back the input exactly.

    Parameters
    ----------
    motion : Motion
    axis : int
        The coordinate axis the reflection negates.

    Returns
    -------
    Motion
        Same skeleton topology, names, channels and frames.
    """
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
    sk = motion.skeleton
    letter = "XYZ"[axis]
    offsets = np.array(sk.offsets)
    offsets[:, axis] *= -1.0
    ends = np.array(sk.end_sites)
    ends[:, axis] *= -1.0
    flip = np.ones(sk.n_channels)
    for j in range(sk.n_joints):
        o = int(sk.channel_offsets[j])
        for k, c in enumerate(sk.channels[j]):
            if c.endswith("position") and c[0] == letter:
                flip[o + k] = -1.0
            elif c.endswith("rotation") and c[0] != letter:
                flip[o + k] = -1.0
    new_sk = Skeleton(sk.names, sk.parents, offsets, sk.channels, ends)
    return Motion(new_sk, motion.channels * flip, motion.frame_time, motion.source)
