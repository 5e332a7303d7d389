"""Drive the body's finger joints with the hands capture (ALGORITHM.md section 7).

Finger joints are paired by role (finger and segment from the base) across naming
conventions.  Hands joints that sit at the same place as their parent (two-axis knuckles
such as ``THUMB_CMC_FE`` + ``THUMB_CMC_AA``) are merged into one segment by composing
their rotations.  When the two skeletons' rest hands point along different axes (a Leap
hand along -Z, a Mixamo hand along +X), rotations are carried over through the rotation
``C`` that takes the hands' rest hand frame onto the body's: ``q_body = C q_hands C^-1``
(BVH rest poses have every joint frame aligned with the world axes, so one ``C`` per hand
serves every finger joint).  When the body has no finger joints, the hands' finger
subtree is grafted under the body's wrist.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rig.handgeom import finger_anchors, forearm_length, same_anatomical_joint
from ..rig.handgeom import hand_frame as _robust_hand_frame
from ..model.kinematics import rest_positions
from ..model.motion import Motion, Skeleton, _Owned, preorder
from ..rig.roles import FINGERS, ArmRoles
from ..model.rotations import quat_angle_deg, quat_between, quat_conj, quat_from_matrix, quat_mul, quat_rotate, quat_to_matrix

__all__ = ["FingerMap", "finger_map", "hand_frame", "graft_fingers"]


@dataclass(frozen=True)
class FingerMap:
    """Which hands joints drive which body joints, for one side.

    Attributes
    ----------
    body : tuple of int
        Body joints that receive a rotation.
    hands : tuple of tuple of int
        For each body joint, the hands joints whose local rotations are composed (parent first).
    conj : np.ndarray [shape=(4,)]
        ``C``: rotation taking the hands' rest hand frame onto the body's.
    bones : dict of int to (np.ndarray, np.ndarray), optional
        Per body joint, ``(A_parent, A)``: the rest rotations taking the body's bones onto the
        hands' bones (see :func:`finger_map`); missing joints use the identity.
    """

    body: tuple[int, ...]
    hands: tuple[tuple[int, ...], ...]
    conj: np.ndarray
    bones: dict | None = None  # b-handgeom


def _segments(sk: Skeleton, chain: tuple[int, ...], rest: np.ndarray) -> list[tuple[int, ...]]:
    """Group a finger chain into segments, merging joints placed at their parent's position and
    joints named as two axes of one anatomical joint (``THUMB_CMC_FE`` + ``THUMB_CMC_AA``)."""
    scale = max(float(np.ptp(rest, axis=0).max()), 1e-9)
    segs: list[list[int]] = []
    for j in chain:
        if segs and (np.linalg.norm(sk.offsets[j]) < 1e-6 * scale
                     or same_anatomical_joint(sk.names[segs[-1][-1]], sk.names[j])):
            segs[-1].append(j)
        else:
            segs.append([j])
    return [tuple(s) for s in segs]


def hand_frame(sk: Skeleton, arm: ArmRoles) -> np.ndarray:
    """Rest-pose hand frame (3x3, columns: long axis, radial axis, ``long x radial``) in world
    axes; finite for coarse rigs too (see :func:`splicer.handgeom.hand_frame`)."""
    return _robust_hand_frame(sk, arm)


def finger_map(body_sk: Skeleton, body_arm: ArmRoles, hands_sk: Skeleton, hands_arm: ArmRoles) -> FingerMap:
    """Pair the body's finger joints with the hands' by finger and segment."""
    rb, rh = rest_positions(body_sk), rest_positions(hands_sk)
    body_joints: list[int] = []
    hands_groups: list[tuple[int, ...]] = []
    runs: list[list[int]] = []  # per finger, the indices of its pairs (base first)
    for finger in FINGERS:
        if finger not in body_arm.fingers or finger not in hands_arm.fingers:
            continue
        bsegs = [s[0] for s in _segments(body_sk, body_arm.fingers[finger], rb)]
        hsegs = _segments(hands_sk, hands_arm.fingers[finger], rh)
        runs.append([])
        for bj, hg in zip(bsegs, hsegs):
            if len(body_sk.rotation_columns(bj)) == 3:
                runs[-1].append(len(body_joints))
                body_joints.append(bj)
                hands_groups.append(hg)
    # a coarse body hand (CMU: LeftFingerBase -> LFingers, one generic finger) follows the hands'
    # middle finger from its knuckle: the generic chain's first joint away from the wrist (or
    # the one whose End Site is the finger) takes the MCP, and so on outward
    if "hand" in body_arm.fingers and not any(f in body_arm.fingers for f in FINGERS[1:]):
        src = next((f for f in ("middle", "index", "ring") if f in hands_arm.fingers), None)
        anchor = finger_anchors(body_sk, body_arm, rb).get("hand")
        if src is not None and anchor is not None:
            chain = body_arm.fingers["hand"]
            sub = chain[chain.index(anchor[0]):]
            bsegs = [sub[0]] + [s[0] for s in _segments(body_sk, sub, rb)[1:]]
            runs.append([])
            for bj, hg in zip(bsegs, _segments(hands_sk, hands_arm.fingers[src], rh)):
                if len(body_sk.rotation_columns(bj)) == 3:
                    runs[-1].append(len(body_joints))
                    body_joints.append(bj)
                    hands_groups.append(hg)
    C = hand_frame(body_sk, body_arm) @ hand_frame(hands_sk, hands_arm).T
    Cq = quat_from_matrix(C)
    bones = _bone_alignment(body_sk, rb, hands_sk, rh, body_joints, hands_groups, runs, Cq)
    return FingerMap(tuple(body_joints), tuple(hands_groups), Cq, bones)


def _bone_alignment(body_sk, rb, hands_sk, rh, body_joints, hands_groups, runs, Cq) -> dict:
    """Rest rotations ``A`` taking each body finger bone onto the paired hands bone (in body axes).

    Copying local rotations (``C q C^-1``) puts the body's bones where the hands' bones are only
    when both rigs' rest bones are parallel.  Rigs whose rest pose is not anatomical (ManipNet's
    zig-zag thumb, straightened by constant joint rotations) need ``q_body = A_parent^-1 (C q C^-1) A``
    with ``A`` the smallest rotation from the body's rest bone to the hands' rest bone, so that each
    body bone takes the hands bone's direction (``A`` is the identity for parallel bones).  A bone
    with no length (no child, no End Site) continues the previous bone of its finger.
    """
    if not body_joints:
        return {}
    ident = np.array([1.0, 0.0, 0.0, 0.0])
    eps_b = 1e-6 * max(float(np.ptp(rb, axis=0).max()), 1e-9)
    eps_h = 1e-6 * max(float(np.ptp(rh, axis=0).max()), 1e-9)

    def bone(sk, rest, j, nxt, eps):
        if nxt is not None:
            v = rest[nxt] - rest[j]
        else:
            es = sk.end_sites[j]
            kids = list(sk.children[j])
            v = np.zeros(3) if np.any(np.isnan(es)) else np.array(es, dtype=np.float64)
            if not np.linalg.norm(v) > eps and kids:
                v = rest[kids[0]] - rest[j]
        return v if np.linalg.norm(v) > eps else None

    out: dict = {}
    for run in runs:
        prev_b = prev_h = None
        a_prev = ident
        for i, r in enumerate(run):
            bj, hg = body_joints[r], hands_groups[r]
            nb = body_joints[run[i + 1]] if i + 1 < len(run) else None
            nh = hands_groups[run[i + 1]][0] if i + 1 < len(run) else None
            ob = bone(body_sk, rb, bj, nb, eps_b)
            oh = bone(hands_sk, rh, hg[-1], nh, eps_h)
            ob = prev_b if ob is None else ob
            oh = prev_h if oh is None else oh
            a = ident if ob is None or oh is None else quat_between(ob, quat_rotate(Cq, oh))
            out[bj] = (a_prev, a)
            prev_b, prev_h, a_prev = ob, oh, a
    return out


def carried_rotations(hands_q: np.ndarray, fmap: FingerMap) -> np.ndarray:
    """Hands local rotations (T, J, 4) -> body finger rotations (T, K, 4) via ``fmap``."""
    out = []
    C = fmap.conj
    identity = quat_angle_deg(C, np.array([1.0, 0, 0, 0])) < 1e-6
    bones = fmap.bones or {}
    for bj, group in zip(fmap.body, fmap.hands):
        q = hands_q[:, group[0]]
        for j in group[1:]:
            q = quat_mul(q, hands_q[:, j])
        if not identity:
            q = quat_mul(quat_mul(C[None], q), quat_conj(C)[None])
        if bj in bones:  # b-handgeom: rest bones of the two rigs not parallel
            a_parent, a = bones[bj]
            q = quat_mul(quat_mul(quat_conj(a_parent)[None], q), a[None])
        out.append(q)
    return np.stack(out, axis=1) if out else np.zeros((hands_q.shape[0], 0, 4))


def graft_fingers(body: Motion, body_arm: ArmRoles, hands_sk: Skeleton, hands_arm: ArmRoles,
                  scale: float) -> tuple[Motion, ArmRoles]:
    """Copy the hands' finger subtrees under the body's wrist.

    Offsets are turned by ``C`` (hands rest hand frame -> body rest hand frame) and scaled by
    ``scale`` (body length units per hands length unit).  New joints get the hands' rotation
    channels (no positions) and start at identity.  Returns the new motion and the side's
    roles on the new skeleton.
    """
    sk = body.skeleton
    # C: the smallest rotation taking the hands' forearm direction at rest onto the body's
    # (identity when both files follow the same axis convention); a wrist-rooted hands file
    # has no forearm, and its hand's long axis stands in for it
    rb = rest_positions(sk)
    rh = rest_positions(hands_sk)
    # (a forearm joint at the wrist's place, as Leap's rForeArm, has no direction: the hand's
    # long axis stands in for it too)
    u_h = rh[hands_arm.wrist] - rh[hands_arm.elbow] if forearm_length(hands_sk, hands_arm, rh) else None
    if u_h is None:
        u_h = hand_frame(hands_sk, hands_arm)[:, 0]
    if forearm_length(sk, body_arm, rb):
        C = quat_to_matrix(quat_between(u_h, rb[body_arm.wrist] - rb[body_arm.elbow]))
    else:
        C = np.eye(3)
    sub: list[int] = []
    for chain in hands_arm.fingers.values():
        for j in (chain[0], *hands_sk.descendants(chain[0])):
            if j not in sub:
                sub.append(j)
    sub.sort()
    names = list(sk.names)
    parents = list(int(p) for p in sk.parents)
    offsets = list(sk.offsets)
    channels = list(sk.channels)
    ends = list(sk.end_sites)
    new_index = {}
    used = set(names)
    for hj in sub:
        name = hands_sk.names[hj]
        base = name
        k = 2
        while name in used:
            name = f"{base}_{k}"
            k += 1
        used.add(name)
        hp = int(hands_sk.parents[hj])
        new_index[hj] = len(names)
        names.append(name)
        parents.append(new_index.get(hp, body_arm.wrist))
        off = hands_sk.offsets[hj]
        if hp not in new_index:  # a finger base: its offset from the hands wrist
            off = rh[hj] - rh[hands_arm.wrist]
        offsets.append(scale * (C @ off))
        rot_ch = tuple(c for c in hands_sk.channels[hj] if c.endswith("rotation")) or ("Zrotation", "Xrotation", "Yrotation")
        channels.append(rot_ch)
        es = hands_sk.end_sites[hj]
        ends.append(es if np.any(np.isnan(es)) else scale * (C @ es))
    order = preorder(parents)
    pos = {old: k for k, old in enumerate(order)}
    new_sk = Skeleton(
        tuple(names[o] for o in order),
        np.array([pos[parents[o]] if parents[o] >= 0 else -1 for o in order]),
        np.array([offsets[o] for o in order]),
        tuple(channels[o] for o in order),
        np.array([ends[o] for o in order]),
    )
    T = body.n_frames
    old_off = sk.channel_offsets
    cols = []
    for o in order:
        if o < sk.n_joints:
            cols.append(body.channels[:, old_off[o]:old_off[o + 1]])
        else:
            cols.append(np.zeros((T, len(channels[o]))))
    motion = Motion(new_sk, _Owned(np.concatenate(cols, axis=1)), body.frame_time, body.source)
    remap = {hj: pos[new_index[hj]] for hj in sub}
    fingers = {f: tuple(remap[j] for j in chain) for f, chain in hands_arm.fingers.items()}
    arm = ArmRoles(body_arm.side, pos[body_arm.wrist],
                   None if body_arm.elbow is None else pos[body_arm.elbow],
                   None if body_arm.upper_arm is None else pos[body_arm.upper_arm], fingers)
    return motion, arm
