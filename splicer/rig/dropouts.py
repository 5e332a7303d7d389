"""Dropouts and gaps in a hand capture: find them (the repair is :mod:`splicer.rig.repair`).

Optical and depth-sensor hand trackers lose fingers (occlusion, a hand leaving the view);
their files then carry broken frames that a splice would otherwise copy onto the body.
:func:`detect_problems` finds, per joint:

* ``zero_row``: frames whose every channel is 0 (within :data:`ZERO_ROW_ATOL`) while other
  frames are not (the Leap exports start with one; a tracker that lost the hand writes them;
  Blender's BVH import and export turn the Leap's all-zero first row into values of 1.5e-6);
* ``nan``: frames where one of the joint's channels is NaN or infinite;
* ``frozen``: a stretch where the joint's channels repeat exactly for at least
  :data:`FROZEN_MIN_S` seconds (and :data:`FROZEN_MIN_FRAMES` frames) while the other joints
  of the hand move, ending in a jump (the step out of it is more than :data:`FROZEN_EXIT_RATIO`
  times the larger of the joint's median step and its median step over the 5 frames before
  and after the stretch) or at the end of the take; the joint must change value in at least
  :data:`FROZEN_MIN_MOVING` of the frame steps (an unanimated joint is not frozen).  The first frame of the stretch
  is the last real sample and is kept; the repeats after it are the dropout.  Repeats that
  end smoothly are holds (quantised or keyframed data) and are left alone;
* ``jump``: one to :data:`SPIKE_MAX_FRAMES` frames into which and out of which the joint
  turns faster than :data:`MAX_FINGER_SPEED_DEG_S` while the frames around them agree with
  each other (a spike), or a first/last frame that leaves a consistent neighbour that fast.

The speed limit, :data:`MAX_FINGER_SPEED_DEG_S` = 3000 deg/s, sits above the fastest step
in the real 120 fps optical hand captures of ``../shared/motions`` (ManipNet: 2024 deg/s,
wrist included) with a margin; the finger snap reaches 7800 deg/s (Acharya et al., J. R. Soc.
Interface 2021) but as a one-way flick, while a spike must go there and come back within
:data:`SPIKE_MAX_FRAMES` frames.  At 120 fps the limit is 25 degrees per frame, at 37 fps 81.
"""

from __future__ import annotations

import numpy as np

from ..model.motion import Motion
from ..model.rotations import quat_angle, quat_from_euler, quat_hemisphere
from ..runs import true_runs

__all__ = ["detect_problems", "hand_joints", "MAX_FINGER_SPEED_DEG_S", "FROZEN_MIN_S", "FROZEN_MIN_FRAMES",
           "FROZEN_EXIT_RATIO", "FROZEN_MIN_MOVING", "SPIKE_MAX_FRAMES", "KINDS", "ZERO_ROW_ATOL"]

MAX_FINGER_SPEED_DEG_S = 3000.0  # degrees per second (see the module docstring)
FROZEN_MIN_S = 0.1  # seconds
FROZEN_MIN_FRAMES = 4  # frames (identical samples, the first one included)
FROZEN_EXIT_RATIO = 3.0  # step out of a frozen stretch, in multiples of the joint's usual step
FROZEN_MIN_MOVING = 0.1  # share of frame steps in which a joint must change to be called frozen anywhere
SPIKE_MAX_FRAMES = 3  # frames
#: a row is a zero row when every channel is within this of 0 (degrees and file units): far above
#: the 1.5e-6 a round trip through Blender leaves of an all-zero row, far below any captured pose
ZERO_ROW_ATOL = 1e-4

KINDS = ("zero_row", "nan", "frozen", "jump")

_ROWS = 65536  # frames per block of the zero-row test


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive ``(first, last)`` of each run of True in a 1-D boolean array."""
    starts, stops = true_runs(mask)
    return list(zip(starts.tolist(), (stops - 1).tolist()))


def _joint_columns(motion: Motion, j: int) -> list[int]:
    o = int(motion.skeleton.channel_offsets[j])
    return list(range(o, o + len(motion.skeleton.channels[j])))


def _steps_below(ch: np.ndarray, cols, lim_deg: float) -> bool:
    """True when no frame-to-frame turn of the joint whose Euler channels are ``cols`` can reach
    ``lim_deg``: the turn between two frames is at most the sum of its Euler angles' changes
    (each factor of the product turns about one axis; the angle between rotations is a metric
    that composition leaves unchanged), so a sum below the limit, with a margin far above the
    rounding of the angle itself, settles the jump test without any quaternion (most finger
    joints of a clean take: the 70-minute hands take's scan 9.7 -> 8.1 s, the rest being joints
    whose repeats the frozen test must measure)."""
    if len(cols) != 3 or ch.shape[0] < 2:
        return False
    bound = np.zeros(ch.shape[0] - 1)
    for c in cols:
        bound += np.abs(np.diff(ch[:, c]))
    return bool(np.all(bound < lim_deg * (1.0 - 1e-6)))  # False with NaN: the full test decides


def _quats(motion: Motion, channels: np.ndarray, j: int) -> np.ndarray | None:
    """Local rotation of joint ``j`` from ``channels`` (T, 4), hemisphere-continuous; None without 3 rotation channels."""
    sk = motion.skeleton
    cols = sk.rotation_columns(j)
    if len(cols) != 3:
        return None
    return quat_hemisphere(quat_from_euler(channels[:, cols], sk.rotation_order(j)), axis=0)


def detect_problems(motion: Motion, joints=None, *, max_speed_deg_s: float = MAX_FINGER_SPEED_DEG_S,
                    progress=None) -> dict[int, dict[str, np.ndarray]]:
    """Broken frames per joint and kind (see the module docstring), without repairing.

    Parameters
    ----------
    motion : Motion
    joints : sequence of int, optional
        Joints to check for NaN, frozen stretches and jumps (all by default); zero rows are
        rows of the whole file.  "The other joints of the hand" of the frozen test are these.
    max_speed_deg_s : float
        Angular speed limit of the jump test, degrees per second.
    progress : callable, optional
        ``progress(fraction)`` after each joint of each test (a 70-minute hand take takes
        seconds).

    Returns
    -------
    dict
        ``{joint: {kind: bool mask (T,)}}`` for joints with a problem; zero rows under joint -1.
    """
    sk = motion.skeleton
    joints = list(range(sk.n_joints)) if joints is None else [int(j) for j in joints]
    ch = np.asarray(motion.channels)
    T = ch.shape[0]
    out: dict[int, dict[str, np.ndarray]] = {}
    if T < 2:
        return out
    finite = np.isfinite(ch)
    zero = np.empty(T, dtype=bool)
    for a in range(0, T, _ROWS):  # in row blocks: no (T, C) float64 temporary of |channels|
        zero[a:a + _ROWS] = np.all(np.abs(ch[a:a + _ROWS]) <= ZERO_ROW_ATOL, axis=1)
    if zero.any() and not zero.all():
        out[-1] = {"zero_row": zero}
    # NaN / inf
    span = {j: slice(int(sk.channel_offsets[j]), int(sk.channel_offsets[j + 1])) for j in joints}  # contiguous
    all_finite = bool(finite.all())
    for j in joints:
        if not all_finite and sk.channels[j]:
            bad = ~np.all(finite[:, span[j]], axis=1)
            if bad.any():
                out.setdefault(j, {})["nan"] = bad
    any_unusable = bool(zero.any()) or not all_finite
    unusable = zero[:, None] | ~finite if any_unusable else np.zeros((T, 1), dtype=bool)  # (T, C) or (T, 1)
    clean = np.where(unusable, 0.0, ch) if any_unusable else ch
    quats: dict[int, np.ndarray | None] = {}

    def joint_quats(j: int) -> np.ndarray | None:
        if j not in quats:
            if any_unusable or len(sk.rotation_columns(j)) != 3:
                quats[j] = _quats(motion, clean, j)
            else:  # converted for this check only (a long take's rotations are not kept)
                quats[j] = motion.joint_rotations([j], keep=False)[:, 0]
        return quats[j]

    # frozen: exact repeats, the rest of the hand moving, ending in a jump or at the end
    changes = np.zeros((T - 1, len(joints)), dtype=bool)
    for k, j in enumerate(joints):
        if sk.channels[j]:
            changes[:, k] = np.any(ch[1:, span[j]] != ch[:-1, span[j]], axis=1)
    n_changing = changes.sum(axis=1)
    min_len = max(FROZEN_MIN_FRAMES, int(np.ceil(FROZEN_MIN_S * motion.fps - 1e-9)))
    tick = (lambda f: None) if progress is None else progress
    for k, j in enumerate(joints):
        tick(0.5 * k / len(joints))
        cols = sk.rotation_columns(j)
        if not cols:
            continue
        ok_rows = ~np.any(unusable[:, span[j]], axis=1) if any_unusable else np.ones(T, dtype=bool)
        same = ~changes[:, k] & ok_rows[1:] & ok_rows[:-1]  # same[t]: frame t+1 repeats frame t
        if same.all() or not same.any():
            continue
        long_runs = [(a, b) for a, b in _runs(same) if b - a + 2 >= min_len]  # frames a .. b + 1 identical
        if not long_runs:  # repeats too short to be a dropout: the joint's steps are not needed
            continue
        q = joint_quats(j)
        steps = quat_angle(q[1:], q[:-1]) if q is not None else np.abs(np.diff(ch[:, cols], axis=0)).max(axis=1)
        moving = steps[~same & ok_rows[1:] & ok_rows[:-1]]
        moving = moving[moving > 0]
        if moving.size < FROZEN_MIN_MOVING * (T - 1):  # a joint that (nearly) never moves is not frozen
            continue
        med = float(np.median(moving))
        others = (n_changing - changes[:, k]) > 0  # another checked joint changes at that step
        mask = np.zeros(T, dtype=bool)
        for a, b in long_runs:
            if b + 1 == T - 1:
                exit_jump = True
            else:  # the step out is a jump next to the joint's usual steps and to its steps around the stretch
                around = np.concatenate([steps[max(a - 5, 0):a], steps[b + 2:b + 7]])
                ref = max(med, float(np.median(around)) if around.size else 0.0)
                exit_jump = bool(ok_rows[b + 2] and steps[b + 1] > FROZEN_EXIT_RATIO * ref)
            rest_moves = others[a:b + 1].mean() >= 0.5
            if exit_jump and rest_moves:
                mask[a + 1:b + 2] = True
        if mask.any():
            out.setdefault(j, {})["frozen"] = mask
    # jumps: spikes of up to SPIKE_MAX_FRAMES frames, measured on the frames not already broken
    lim = max_speed_deg_s / motion.fps  # degrees per frame
    for k, j in enumerate(joints):
        tick(0.5 + 0.5 * k / len(joints))
        flagged = np.zeros(T, dtype=bool)
        for m in out.get(j, {}).values():
            flagged |= m
        if -1 in out:
            flagged |= out[-1]["zero_row"]
        good = np.flatnonzero(~flagged)
        if good.size < 3:
            continue
        # no step can reach the limit, so no spike: the rotations are not needed
        q = None if good.size == T and _steps_below(ch, sk.rotation_columns(j), lim) else joint_quats(j)
        quats.pop(j, None)  # the last use of this joint's rotations: one joint's at a time
        if q is None:
            continue
        qg = q if good.size == T else quat_hemisphere(q[good], axis=0)
        step = quat_angle(qg[1:], qg[:-1]) / np.maximum(np.diff(good), 1)  # degrees per frame
        spike = np.zeros(good.size, dtype=bool)
        next_free = 1
        for i in (np.flatnonzero(step > lim) + 1).tolist():  # frame i is entered too fast
            if i < next_free or i >= good.size - 1:
                continue
            for e in range(i, min(i + SPIKE_MAX_FRAMES, good.size - 1)):
                if step[e] > lim:  # ... and frame e left too fast: a spike if e + 1 agrees with i - 1
                    if quat_angle(qg[i - 1], qg[e + 1]) <= lim * (good[e + 1] - good[i - 1]):
                        spike[i:e + 1] = True
                        next_free = e + 2  # frame e + 1 is good again; the next spike starts after it
                    break
        # an end frame leaving consistent neighbours too fast
        if step[0] > lim and step[1] <= lim:
            spike[0] = True
        if step[-1] > lim and step[-2] <= lim:
            spike[-1] = True
        if spike.any():
            mask = np.zeros(T, dtype=bool)
            mask[good[spike]] = True
            out.setdefault(j, {})["jump"] = mask
    return out


def hand_joints(skeleton, arms) -> list[int]:
    """The joints :func:`~splicer.rig.repair.repair_motion` checks for the given sides: wrist, fingers and the
    forearm, and in a hand-only file every joint from the root down to the wrist.

    Parameters
    ----------
    skeleton : Skeleton
    arms : iterable of ArmRoles
    """
    out: set[int] = set()
    for arm in arms:
        out.update(arm.finger_joints)
        out.add(arm.wrist)
        if arm.upper_arm is None:
            out.update(skeleton.chain(arm.wrist))
        elif arm.elbow is not None:
            out.add(arm.elbow)
    return sorted(out)
