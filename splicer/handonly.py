"""Hand-only capture files: what stands in for the arm they do not record.

A hand-only file (Leap-like: a forearm root at the wrist; ManipNet-like: a wrist root) has
no shoulder, so its virtual markers (:mod:`splicer.markers`) are measured from the capture
volume's origin.  Such a capture is made with the performer's body still (seated, or
standing at a sensor): its hand positions include the sway of the torso around the hips,
which shoulder-relative markers would remove.  :func:`root_referenced` therefore measures the
*body's* markers from the body's root (hips) position instead of its shoulder, so that both
sequences carry the same kind of motion.  Measured on the evaluation protocol (ALGORITHM.md 8,
zeggs take, held-out seeds 100..104, full method): forearm-rooted hands 1.42 -> 1.12 frames,
wrist-rooted 1.54 -> 1.18, against 1.03 for the full skeleton (see ``notes/c-handonly.md``).

:func:`coincident_forearm` finds the forearm joint of a Leap-like file, which sits at the
wrist's position (a zero-length bone that role detection skips as the elbow), so that the
wrist's rotation relative to it can be carried over (``--wrist hands``).
"""

from __future__ import annotations

import re

import numpy as np

from .kinematics import global_transforms
from .markers import Markers
from .model import Motion, Skeleton
from .roles import ArmRoles

__all__ = ["is_hand_only", "reference_joint", "root_referenced", "coincident_forearm", "wrist_source_notes"]

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
