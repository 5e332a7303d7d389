"""The changes a scenario makes to a take (:mod:`splicer.evaluation.scenarios`).

Easing the junctions of extra material into the genuine span, the imitation of a second
performance (per-gesture arm amplitude, wrist drift, arm noise), and the choice of where a
pause or an unrelated clip goes (a slow moment of the take; a clip away from a given instant).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import find_peaks

from ..model.kinematics import global_transforms
from ..model.motion import Motion
from ..model.rotations import quat_hemisphere, quat_mul, quat_normalize, quat_slerp
from ..rig.roles import Roles
from .scenario_types import Scenario
from .separate import _mean_rotation
from .warps import smooth_noise


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _rotvec_quat(v: np.ndarray) -> np.ndarray:
    ang = np.linalg.norm(v, axis=-1, keepdims=True)
    axis = np.where(ang > 0, v / np.where(ang > 0, ang, 1.0), 0.0)
    return np.concatenate([np.cos(ang / 2), np.sin(ang / 2) * axis], axis=-1)


def _ease_junctions(hands: Motion, junctions: list[tuple[int, int, int]]) -> Motion:
    """Ease the poses of frames ``[a, b)`` toward the pose of frame ``anchor`` (weight 1 next
    to the anchor, 0 at the far end), for each ``(a, b, anchor)``; rotations by slerp, the
    root position linearly."""
    if not junctions:
        return hands
    sk = hands.skeleton
    rot3 = [j for j in range(sk.n_joints) if len(sk.rotation_columns(j)) == 3]
    q0 = hands.joint_rotations(rot3)
    q = np.array(q0)
    ch = np.array(hands.channels)
    pos_cols = sk.position_columns(0)
    for a, b, anchor in junctions:
        if b <= a:
            continue
        k = np.arange(a, b)
        dist = np.where(anchor >= b, anchor - k, k - anchor)  # 1 next to the anchor
        w = _smoothstep(1.0 - (dist - 1) / (b - a))  # 1 at the anchor's neighbour, -> 0 far away
        q[k] = quat_slerp(q0[k], np.broadcast_to(q0[anchor], q0[k].shape), np.broadcast_to(w[:, None], q0[k].shape[:2]))
        if pos_cols:
            old = hands.channels[np.ix_(k, pos_cols)]
            ch[np.ix_(k, pos_cols)] = (1 - w[:, None]) * old + w[:, None] * hands.channels[anchor, pos_cols]
    out = hands.with_channels(ch)
    return out.with_rotations(rot3, quat_hemisphere(q, axis=0))


def _imitate(hands: Motion, r: Roles, rng: np.random.Generator, sc: Scenario) -> tuple[Motion, dict]:
    """A second performance: per-gesture arm amplitude, slow wrist drift, arm noise."""
    sk = hands.skeleton
    m, g = hands.n_frames, hands.fps
    q = np.array(hands.rotations)
    changed: set[int] = set()
    drawn: dict = {}
    for side, arm in sorted(r.sides.items()):
        # the shoulder (the upper arm's parent, unless it is the root), the upper arm, the forearm
        chain = [int(sk.parents[arm.upper_arm])] if arm.upper_arm is not None and sk.parents[arm.upper_arm] > 0 else []
        chain += [arm.upper_arm, arm.elbow]
        arm_joints = [j for j in chain if j is not None and len(sk.rotation_columns(j)) == 3]
        # gestures: between minima of the wrist speed at least 1 s apart
        _, p = global_transforms(hands, [arm.wrist])
        speed = np.linalg.norm(np.gradient(p[:, 0], axis=0), axis=-1)
        speed = gaussian_filter1d(speed, 0.1 * g, mode="nearest")
        cuts, _ = find_peaks(-speed, distance=max(int(g), 1))
        bounds = np.concatenate([[0], cuts, [m]])
        factors = rng.uniform(*sc.imitation_amplitude, size=len(bounds) - 1)
        fac = np.empty(m)
        for f, a, b in zip(factors, bounds[:-1], bounds[1:]):
            fac[a:b] = f
        # smooth changes of factor around the cuts (0.3 s)
        fac = gaussian_filter1d(fac, 0.15 * g, mode="nearest")
        if arm_joints:
            mean = _mean_rotation(q[:, arm_joints])
            q[:, arm_joints] = quat_slerp(np.broadcast_to(mean, q[:, arm_joints].shape), q[:, arm_joints],
                                          np.broadcast_to(fac[:, None], (m, len(arm_joints))))
            sd = rng.uniform(*sc.arm_noise_deg)
            nz = smooth_noise(m, rng, sigma=0.05 * g, dims=(len(arm_joints), 3)) * np.radians(sd) / np.sqrt(3.0)
            q[:, arm_joints] = quat_mul(q[:, arm_joints], _rotvec_quat(nz))
            changed.update(arm_joints)
            drawn[f"{side}_arm_noise_deg"] = float(sd)
        if len(sk.rotation_columns(arm.wrist)) == 3:
            dv = smooth_noise(m, rng, sigma=3.0 * g, dims=(3,)) * np.radians(sc.wrist_drift_deg) / np.sqrt(3.0)
            q[:, arm.wrist] = quat_mul(q[:, arm.wrist], _rotvec_quat(dv))
            changed.add(arm.wrist)
        drawn[f"{side}_gesture_factors"] = factors
        drawn[f"{side}_gesture_cuts"] = cuts
    changed_l = sorted(changed)
    out = hands.with_rotations(changed_l, quat_hemisphere(quat_normalize(q[:, changed_l]), axis=0))
    return Motion(sk, out.channels, hands.frame_time, hands.source), drawn


def _wrist_speed(take: Motion, r: Roles) -> np.ndarray:
    """Speed of the faster wrist at each take frame (file units per frame), smoothed over 0.2 s."""
    wrists = [arm.wrist for arm in r.sides.values()]
    _, p = global_transforms(take, wrists)
    v = np.linalg.norm(np.gradient(p, axis=0), axis=-1).max(axis=1)
    return gaussian_filter1d(v, 0.2 * take.fps, mode="nearest")


def _slow_moment(rng: np.random.Generator, speed: np.ndarray, times: np.ndarray, lo: int, hi: int) -> int:
    """A random index into ``times`` (take frames) in the middle 60 % of ``[lo, hi)`` where the
    take moves slowly: the wrist speed at ``times[k]`` is at most the median over that range."""
    a, b = lo + int(0.2 * (hi - lo)), lo + int(0.8 * (hi - lo))
    idx = np.arange(a, max(b, a + 1))
    sp = np.interp(times[idx], np.arange(len(speed), dtype=np.float64), speed)
    slow = idx[sp <= np.median(sp)]
    return int(slow[rng.integers(len(slow))])


def _far_clip_start(rng: np.random.Generator, n: int, length: float, avoid: float, min_gap: float) -> float:
    """Start (take frames) of a clip of ``length`` take frames inside ``[0, n - 1]`` whose
    span stays ``min_gap`` take frames away from the instant ``avoid`` where possible."""
    hi = max(n - 1 - length, 0.0)
    starts = rng.uniform(0.0, hi, size=64)
    far = starts[(starts + length < avoid - min_gap) | (starts > avoid + min_gap)]
    return float(far[0] if len(far) else starts[0])
