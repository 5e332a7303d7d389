"""Forward kinematics, vectorised over frames.

The loop runs over joints (parents before children); every step works on all frames at
once, so the cost is O(J) numpy calls whatever the number of frames.
"""

from __future__ import annotations

import numpy as np

from .motion import Motion, Skeleton
from .rotations import quat_mul, quat_rotate

__all__ = ["global_transforms", "rest_positions"]


def global_transforms(motion: Motion, joints=None) -> tuple[np.ndarray, np.ndarray]:
    """World rotations and positions of joints.

    Parameters
    ----------
    motion : Motion
    joints : sequence of int, optional
        Joints wanted; only they and their ancestors are computed.  All joints by default.

    Returns
    -------
    rotations : np.ndarray [shape=(T, K, 4)]
        World rotation of each requested joint, ``(w, x, y, z)``.
    positions : np.ndarray [shape=(T, K, 3)]
        World position of each requested joint, file units.
    """
    sk = motion.skeleton
    wanted = list(range(sk.n_joints)) if joints is None else [int(j) for j in joints]
    needed = sorted({a for j in wanted for a in sk.chain(j)})
    gq: dict[int, np.ndarray] = {}
    gp: dict[int, np.ndarray] = {}
    for j in needed:
        p = int(sk.parents[j])
        q = motion.joint_rotations([j])[:, 0]
        t = motion.joint_translations([j])[:, 0]
        if p < 0:
            gq[j], gp[j] = q, t
        else:
            gq[j] = quat_mul(gq[p], q)
            gp[j] = gp[p] + quat_rotate(gq[p], t)
    T = motion.n_frames
    if not wanted:
        return np.zeros((T, 0, 4)), np.zeros((T, 0, 3))
    return np.stack([gq[j] for j in wanted], axis=1), np.stack([gp[j] for j in wanted], axis=1)


def rest_positions(skeleton: Skeleton) -> np.ndarray:
    """World positions of the joints in the rest pose (all rotations identity, root at its offset).

    Returns
    -------
    np.ndarray [shape=(J, 3)], file units
    """
    pos = np.zeros((skeleton.n_joints, 3))
    for j, p in enumerate(skeleton.parents):
        pos[j] = skeleton.offsets[j] + (pos[p] if p >= 0 else 0.0)
    return pos
