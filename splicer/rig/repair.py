"""Dropouts and gaps in a hand capture: find them, repair them, say so.

Optical and depth-sensor hand trackers lose fingers (occlusion, a hand leaving the view);
their files then carry broken frames that a splice would otherwise copy onto the body.
:func:`repair_motion` finds, per joint:

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

and repairs them in the joint's own rotation space: slerp between the good frames around an
interior gap (positions: linear), constant angular velocity (positions: constant velocity)
at the ends, measured between the nearest good frame and the good frame
:data:`VELOCITY_BASELINE_S` seconds further in (the two previous frames of seed 000's
missing-data method, widened against capture noise), for at most :data:`EXTRAPOLATE_MAX_S` seconds,
then held.  Only the broken frames' channels change; every repair is returned as a
:class:`Repair` so the caller reports it (never silently).

The speed limit, :data:`MAX_FINGER_SPEED_DEG_S` = 3000 deg/s, sits above the fastest step
in the real 120 fps optical hand captures of ``../shared/motions`` (ManipNet: 2024 deg/s,
wrist included) with a margin; the finger snap reaches 7800 deg/s (Acharya et al., J. R. Soc.
Interface 2021) but as a one-way flick, while a spike must go there and come back within
:data:`SPIKE_MAX_FRAMES` frames.  At 120 fps the limit is 25 degrees per frame, at 37 fps 81.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion
from ..model.rotations import euler_from_quat, quat_angle, quat_conj, quat_from_euler, quat_hemisphere, quat_mul, quat_slerp

__all__ = ["Repair", "repair_motion", "detect_problems", "MAX_FINGER_SPEED_DEG_S", "FROZEN_MIN_S",
           "FROZEN_MIN_FRAMES", "FROZEN_EXIT_RATIO", "SPIKE_MAX_FRAMES", "EXTRAPOLATE_MAX_S", "repairs_summary",
           "hand_joints", "VELOCITY_BASELINE_S", "ZERO_ROW_ATOL"]

MAX_FINGER_SPEED_DEG_S = 3000.0  # degrees per second (see the module docstring)
FROZEN_MIN_S = 0.1  # seconds
FROZEN_MIN_FRAMES = 4  # frames (identical samples, the first one included)
FROZEN_EXIT_RATIO = 3.0  # step out of a frozen stretch, in multiples of the joint's usual step
FROZEN_MIN_MOVING = 0.1  # share of frame steps in which a joint must change to be called frozen anywhere
SPIKE_MAX_FRAMES = 3  # frames
EXTRAPOLATE_MAX_S = 0.1  # seconds of constant-velocity extrapolation at an end, then held
VELOCITY_BASELINE_S = 0.05  # seconds between the two good frames the end velocity is measured over
#: a row is a zero row when every channel is within this of 0 (degrees and file units): far above
#: the 1.5e-6 a round trip through Blender leaves of an all-zero row, far below any captured pose
ZERO_ROW_ATOL = 1e-4

KINDS = ("zero_row", "nan", "frozen", "jump")


@dataclass(frozen=True)
class Repair:
    """One repaired stretch.

    Attributes
    ----------
    joint : str
        Joint name, or ``"*"`` for a whole row (``zero_row``).
    first, last : int
        0-based frames of the file, inclusive.
    kind : str
        ``"zero_row"``, ``"nan"``, ``"frozen"`` or ``"jump"``.
    method : str
        ``"slerp"`` (interior: between the good frames around it) or ``"extrapolated"`` (an end).
    """

    joint: str
    first: int
    last: int
    kind: str
    method: str

    def as_dict(self) -> dict:
        return {"joint": self.joint, "frames": [self.first, self.last], "kind": self.kind, "method": self.method}


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive ``(first, last)`` of each run of True in a 1-D boolean array."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist()))


def _joint_columns(motion: Motion, j: int) -> list[int]:
    o = int(motion.skeleton.channel_offsets[j])
    return list(range(o, o + len(motion.skeleton.channels[j])))


def _quats(motion: Motion, channels: np.ndarray, j: int) -> np.ndarray | None:
    """Local rotation of joint ``j`` from ``channels`` (T, 4), hemisphere-continuous; None without 3 rotation channels."""
    sk = motion.skeleton
    cols = sk.rotation_columns(j)
    if len(cols) != 3:
        return None
    return quat_hemisphere(quat_from_euler(channels[:, cols], sk.rotation_order(j)), axis=0)


def detect_problems(motion: Motion, joints=None, *, max_speed_deg_s: float = MAX_FINGER_SPEED_DEG_S
                    ) -> dict[int, dict[str, np.ndarray]]:
    """Broken frames per joint and kind (see the module docstring), without repairing.

    Parameters
    ----------
    motion : Motion
    joints : sequence of int, optional
        Joints to check for NaN, frozen stretches and jumps (all by default); zero rows are
        rows of the whole file.  "The other joints of the hand" of the frozen test are these.
    max_speed_deg_s : float
        Angular speed limit of the jump test, degrees per second.

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
    zero = np.all(np.abs(ch) <= ZERO_ROW_ATOL, axis=1)
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
            else:  # the motion's own (cached) rotations, which the splice reuses afterwards
                quats[j] = motion.joint_rotations([j])[:, 0]
        return quats[j]

    # frozen: exact repeats, the rest of the hand moving, ending in a jump or at the end
    changes = np.zeros((T - 1, len(joints)), dtype=bool)
    for k, j in enumerate(joints):
        if sk.channels[j]:
            changes[:, k] = np.any(ch[1:, span[j]] != ch[:-1, span[j]], axis=1)
    n_changing = changes.sum(axis=1)
    min_len = max(FROZEN_MIN_FRAMES, int(np.ceil(FROZEN_MIN_S * motion.fps - 1e-9)))
    for k, j in enumerate(joints):
        cols = sk.rotation_columns(j)
        if not cols:
            continue
        ok_rows = ~np.any(unusable[:, span[j]], axis=1) if any_unusable else np.ones(T, dtype=bool)
        same = ~changes[:, k] & ok_rows[1:] & ok_rows[:-1]  # same[t]: frame t+1 repeats frame t
        if same.all() or not same.any():
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
        for a, b in _runs(same):  # frames a .. b + 1 are identical
            n_identical = b - a + 2
            if n_identical < min_len:
                continue
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
    for j in joints:
        flagged = np.zeros(T, dtype=bool)
        for m in out.get(j, {}).values():
            flagged |= m
        if -1 in out:
            flagged |= out[-1]["zero_row"]
        good = np.flatnonzero(~flagged)
        if good.size < 3:
            continue
        q = joint_quats(j)
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


def _euler_near(e: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Angles ``e`` (K, 3) moved by whole turns so that each row continues from the previous (``ref`` before the first)."""
    out = np.array(e)
    prev = ref
    for t in range(out.shape[0]):
        out[t] = out[t] + 360.0 * np.round((prev - out[t]) / 360.0)
        prev = out[t]
    return out


def _fill_joint(motion: Motion, ch: np.ndarray, j: int, bad: np.ndarray, max_extra: int,
                group: str) -> list[tuple[int, int, str]]:
    """Rewrite joint ``j``'s rotation (``group="rot"``) or position (``"pos"``) channels in the
    ``bad`` frames of ``ch`` (in place); returns (first, last, method) per gap."""
    sk = motion.skeleton
    T = ch.shape[0]
    good = np.flatnonzero(~bad)
    if good.size == 0:
        raise SplicerError(f"{motion.source or 'hands'}: joint {sk.names[j]!r} has no usable frame (every frame is "
                           "missing or broken); it cannot be repaired")
    rcols = sk.rotation_columns(j) if group == "rot" else []
    pcols = [c for c in _joint_columns(motion, j) if c not in sk.rotation_columns(j)] if group == "pos" else []
    use_quat = len(rcols) == 3
    q = _quats(motion, np.where(np.isfinite(ch), ch, 0.0), j) if use_quat else None
    done = []
    for a, b in _runs(bad):
        frames = np.arange(a, b + 1)
        if a > 0 and b < T - 1:  # interior: slerp / linear between frames a-1 and b+1
            method = "slerp"
            t = (frames - (a - 1)) / (b + 2 - a)
            lin_cols = pcols if use_quat else pcols + rcols
            if lin_cols:
                ch[np.ix_(frames, lin_cols)] = ch[a - 1, lin_cols] + t[:, None] * (ch[b + 1, lin_cols] - ch[a - 1, lin_cols])
            if use_quat:
                qa = np.broadcast_to(q[a - 1], (frames.size, 4))
                qb = np.broadcast_to(q[b + 1], (frames.size, 4))
                qr = quat_slerp(qa, qb, t)
                e = euler_from_quat(qr, sk.rotation_order(j))
                ch[np.ix_(frames, rcols)] = _euler_near(e, ch[a - 1, rcols])
        else:  # an end: constant velocity from the two nearest good frames, held after max_extra frames
            method = "extrapolated"
            # velocity over a baseline of VELOCITY_BASELINE_S (at least one frame step): capture noise
            # on a single step would otherwise be extrapolated too
            back = int(min(max(1, round(VELOCITY_BASELINE_S * motion.fps)), good.size - 1))
            if a == 0:
                k0, k1 = good[0], good[back]
                direction = -1
            else:
                k0, k1 = good[-1], good[-1 - back]
                direction = 1
            gap = max(abs(k0 - k1), 1)
            dist = np.minimum(np.abs(frames - k0), max_extra)  # frames of extrapolation, capped
            lin_cols = pcols if use_quat else pcols + rcols
            if lin_cols:
                vel = (ch[k0, lin_cols] - ch[k1, lin_cols]) / gap  # per frame, away from the good part
                ch[np.ix_(frames, lin_cols)] = ch[k0, lin_cols] + dist[:, None] * vel
            if use_quat:
                # angular velocity per frame (as a rotation applied on the left, in the parent frame)
                dq = quat_mul(q[k0], quat_conj(q[k1]))
                dq = dq if dq[0] >= 0 else -dq
                ang = 2.0 * np.arccos(np.clip(dq[0], -1.0, 1.0)) / gap
                axis = dq[1:] / max(np.linalg.norm(dq[1:]), 1e-300)
                half = 0.5 * ang * dist
                step = np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axis[None]], axis=1)
                qr = quat_mul(step, np.broadcast_to(q[k0], (frames.size, 4)))
                e = euler_from_quat(qr, sk.rotation_order(j))
                order = frames if direction > 0 else frames[::-1]
                e_ord = e if direction > 0 else e[::-1]
                filled = _euler_near(e_ord, ch[k0, rcols])
                ch[np.ix_(order, rcols)] = filled
        done.append((a, b, method))
    return done


def repair_motion(motion: Motion, joints=None, *, max_speed_deg_s: float = MAX_FINGER_SPEED_DEG_S
                  ) -> tuple[Motion, list[Repair]]:
    """Find and repair dropouts and gaps in a (hand) capture.

    Parameters
    ----------
    motion : Motion
        The capture; NaN and infinite channel values are allowed here (they are what is repaired).
    joints : sequence of int, optional
        Joints to check and repair (all by default; the splice passes the hand's joints).
        A zero row is repaired for every joint.
    max_speed_deg_s : float
        Angular speed above which a there-and-back move is a spike, degrees per second.

    Returns
    -------
    motion : Motion
        A new motion with only the broken frames' channels rewritten (the input when nothing
        was found).
    repairs : list of Repair
        One entry per detected stretch (joint, first and last frame inclusive, kind, method),
        ordered by frame then joint.

    Raises
    ------
    SplicerError
        When a joint has no usable frame at all.
    """
    if not (max_speed_deg_s > 0 and np.isfinite(max_speed_deg_s)):
        raise SplicerError(f"max_speed_deg_s must be a positive number, not {max_speed_deg_s!r}")
    sk = motion.skeleton
    found = detect_problems(motion, joints, max_speed_deg_s=max_speed_deg_s)
    if not found:
        return motion, []
    ch = np.array(motion.channels)
    T = ch.shape[0]
    zero = found.get(-1, {}).get("zero_row", np.zeros(T, dtype=bool))
    max_extra = max(1, int(round(EXTRAPOLATE_MAX_S * motion.fps)))
    todo = set(j for j in found if j >= 0)
    if zero.any():
        todo |= {j for j in range(sk.n_joints) if sk.channels[j]}
    methods: dict[int, dict[tuple[int, int], str]] = {}
    finite = np.isfinite(np.asarray(motion.channels))
    for j in sorted(todo):
        kinds = found.get(j, {})
        both = zero.copy()
        for kind, m in kinds.items():
            if kind != "nan":
                both |= m
        rcols = sk.rotation_columns(j)
        pcols = [c for c in _joint_columns(motion, j) if c not in rcols]
        methods[j] = {}
        for group, cols in (("rot", rcols), ("pos", pcols)):
            if not cols:
                continue
            # NaN repairs only the channel group that has it (a NaN position leaves the rotation as read)
            bad = both | (~np.all(finite[:, cols], axis=1) if "nan" in kinds else False)
            if bad.any():
                gaps = _fill_joint(motion, ch, j, bad, max_extra, group)
                methods[j].update({(a, b): meth for a, b, meth in gaps})

    def method_of(j: int, a: int, b: int) -> str:
        for (ga, gb), meth in methods.get(j, {}).items():
            if ga <= a and b <= gb:
                return meth
        return "slerp"

    repairs = []
    for a, b in _runs(zero):
        repairs.append(Repair("*", a, b, "zero_row", "extrapolated" if a == 0 or b == T - 1 else "slerp"))
    for j, kinds in found.items():
        if j < 0:
            continue
        for kind in KINDS:
            if kind in kinds:
                for a, b in _runs(kinds[kind]):
                    repairs.append(Repair(sk.names[j], a, b, kind, method_of(j, a, b)))
    repairs.sort(key=lambda r: (r.first, r.last, r.joint != "*", sk.names.index(r.joint) if r.joint != "*" else -1))
    return motion.with_channels(ch), repairs


def repairs_summary(repairs: list[Repair], source: str, *, limit: int = 6) -> str:
    """One warning sentence listing the repaired stretches (the first ``limit`` of them)."""
    kinds = {}
    for r in repairs:
        kinds[r.kind] = kinds.get(r.kind, 0) + 1
    what = ", ".join(f"{n} {k.replace('_', ' ')}" for k, n in kinds.items())
    shown = "; ".join(f"{r.joint} frames {r.first}..{r.last} ({r.kind}, {r.method})" for r in repairs[:limit])
    more = f"; and {len(repairs) - limit} more" if len(repairs) > limit else ""
    return (f"{source}: repaired {len(repairs)} broken stretch(es) of the hand capture before aligning ({what}): "
            f"{shown}{more} (all listed in the report under hands_repairs)")


def hand_joints(skeleton, arms) -> list[int]:
    """The joints :func:`repair_motion` checks for the given sides: wrist, fingers and the
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
