"""Hand-only capture files: what stands in for the arm they do not record.

A hand-only file (Leap-like: a forearm root at the wrist; ManipNet-like: a wrist root) has
no shoulder, so its virtual markers (:mod:`splicer.markers`) are measured from the capture
volume's origin.  Such a capture is made with the performer's body still (seated, or
standing at a sensor): its hand positions include the sway of the torso around the hips,
which shoulder-relative markers would remove; and its forearm marker lies on a virtual
forearm turned with the hand (wrist-rooted) or the forearm joint (Leap-like).
:func:`hand_only_view` therefore makes the *body's* markers the same way: measured from the
body's root (hips) position instead of its shoulder and, against a wrist-rooted file, with
the forearm marker on the same virtual forearm.  Measured on the evaluation protocol (ALGORITHM.md 8, zeggs take, held-out seeds
100..104, full method): forearm-rooted hands 1.42 -> 1.12 frames, wrist-rooted 1.54 -> 1.05,
against 1.03 for the full skeleton (README, *Accuracy*).

:func:`coincident_forearm` finds the forearm joint of a Leap-like file, which sits at the
wrist's position (a zero-length bone that role detection skips as the elbow), so that the
wrist's rotation relative to it can be carried over (``--wrist hands``).
"""

from __future__ import annotations

import re

import numpy as np

from ..model.kinematics import global_transforms, rest_positions
from .markers import FOREARM_PER_HAND, Markers
from ..model.motion import Motion, Skeleton
from .roles import ArmRoles
from ..model.rotations import quat_rotate

__all__ = ["is_hand_only", "reference_joint", "root_referenced", "hand_only_view", "coincident_forearm", "wrist_source_notes"]

_FOREARM_WORDS = re.compile(r"fore|elbow|lowerarm|radius|ulna", re.IGNORECASE)


def is_hand_only(arm: ArmRoles) -> bool:
    """True when the side has no upper-arm joint (a hand-only file: no shoulder to measure from)."""
    return arm.upper_arm is None


def reference_joint(skeleton: Skeleton, arm: ArmRoles) -> int:
    """The body's moving root: the deepest joint with position channels above the arm.

    Usually the hips (the root); a rig with a static ``Reference`` root above 6-channel hips
    gives the hips.  Joint 0 when no joint above the wrist has position channels.
    """
    chain = skeleton.chain(arm.upper_arm if arm.upper_arm is not None else arm.wrist)
    with_pos = [j for j in chain if skeleton.position_columns(j)]
    return with_pos[-1] if with_pos else 0


def root_referenced(motion: Motion, markers: Markers, joint: int = 0) -> Markers:
    """The same markers measured from a root joint's world position instead of the shoulder.

    Parameters
    ----------
    motion : Motion
        The motion ``markers`` were made from.
    markers : Markers
    joint : int
        The reference joint (see :func:`reference_joint`); the root by default.

    Returns
    -------
    Markers
        ``points``, ``heading``, ``up``, ``fps`` and ``side`` unchanged; ``shoulder`` (the
        reference :meth:`Markers.relative` subtracts) is the joint's world position per frame,
        file units.
    """
    if motion.n_frames != markers.n_frames:
        raise ValueError(f"motion has {motion.n_frames} frames but the markers {markers.n_frames}")
    _, pos = global_transforms(motion, [joint])
    return Markers(markers.points, pos[:, 0], markers.heading, markers.up, markers.fps, markers.side)


def hand_only_view(motion: Motion, arm: ArmRoles, markers: Markers, *, forearm_joint: bool) -> Markers:
    """The body's markers made the way a hand-only file's must be made.

    A hand-only file lacks the shoulder and the elbow, so :func:`splicer.markers.arm_markers`
    measures its markers from the capture's origin and puts its forearm marker ``p3`` on a
    virtual forearm: straight back from the rest-pose hand, 2.5 hand lengths long, turned with
    the forearm joint (Leap-like files, ``forearm_joint=True``) or with the wrist
    (wrist-rooted files).  Here the body's markers get the same definitions, so that both
    sequences carry the same kind of motion: measured from the body's moving root
    (:func:`reference_joint`, :func:`root_referenced`); with a wrist-rooted hands file, ``p3``
    on the same virtual forearm turned with the body's wrist.  With a forearm joint the
    hands' virtual forearm already points along the real one and the body keeps its real
    ``p3`` (measured: the virtual one on the body too is neutral on the protocol take, 1.12 vs
    1.12 frames on held-out seeds, and worse on the synthetic take of the tests).  ``p1``,
    ``p2``, ``p4`` are unchanged; a body without finger joints keeps its real ``p3`` (no
    rest-pose hand to extend).

    Parameters
    ----------
    motion : Motion
        The body.
    arm : ArmRoles
        The body's side.
    markers : Markers
        From :func:`splicer.markers.arm_markers` on ``motion`` and ``arm``.
    forearm_joint : bool
        Whether the hands file has a forearm joint (at the wrist) turning its virtual forearm.

    Returns
    -------
    Markers
    """
    out = root_referenced(motion, markers, reference_joint(motion.skeleton, arm))
    middle = arm.fingers.get("middle") or next((c for c in arm.fingers.values() if c), None)
    if forearm_joint or middle is None:
        return out
    turn_joint = arm.wrist
    rest = rest_positions(motion.skeleton)
    back = -FOREARM_PER_HAND * (rest[middle[0]] - rest[arm.wrist])
    rot, pos = global_transforms(motion, [turn_joint, arm.wrist])
    points = np.array(out.points)
    points[:, 2] = pos[:, 1] + 0.5 * quat_rotate(rot[:, 0], back)
    return Markers(points, out.shoulder, out.heading, out.up, out.fps, out.side)


def coincident_forearm(skeleton: Skeleton, arm: ArmRoles) -> int | None:
    """The forearm joint above the wrist, including one at the wrist's own position.

    Role detection skips joints at the same place as their child, so a Leap-like file
    (``rForeArm`` root at the wrist, then ``rHand`` at offset zero) has no elbow.  Its
    forearm joint still has a frame: the wrist's rotation relative to it is the wrist's
    flexion.  Returns ``arm.elbow`` when there is one; else the wrist's parent when it has three
    rotation channels and a forearm name (``fore``, ``elbow``, ``lowerarm``); else None
    (wrist-rooted files).
    """
    if arm.elbow is not None:
        return arm.elbow
    p = int(skeleton.parents[arm.wrist])
    if p < 0 or len(skeleton.rotation_columns(p)) != 3:
        return None
    name = re.split(r"[:|]", skeleton.names[p])[-1]
    return p if _FOREARM_WORDS.search(name) else None



def wrist_source_notes(motion: Motion, arm: ArmRoles, forearm: int) -> list[str]:
    """Warnings for ``--wrist hands`` when the forearm joint is at the wrist or the wrist never turns.

    Parameters
    ----------
    motion : Motion
        The hands capture.
    arm : ArmRoles
        Its side's roles.
    forearm : int
        From :func:`coincident_forearm`.

    Returns
    -------
    list of str
        Empty for an ordinary forearm; else one or two sentences for the report.
    """
    sk = motion.skeleton
    src = motion.source or "hands"
    out = []
    if forearm != arm.elbow:
        out.append(f"{src}: --wrist hands: the {arm.side} wrist's rotation is taken relative to "
                   f"{sk.names[forearm]}, a forearm joint at the wrist's position (zero-length bone)")
    q = motion.joint_rotations([arm.wrist])[:, 0]
    if np.all(np.abs(q - q[:1]) < 1e-12):
        out.append(f"{src}: --wrist hands: {sk.names[arm.wrist]} never turns relative to {sk.names[forearm]} "
                   f"in the hands file (its orientation is carried by {sk.names[forearm]}); the {arm.side} wrist "
                   "keeps that constant rotation")
    return out
