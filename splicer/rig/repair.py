"""Dropouts and gaps in a hand capture: repair them, say so.

:func:`repair_motion` finds the broken frames of each joint with
:func:`splicer.rig.dropouts.detect_problems` (zero rows, NaN, frozen stretches, spikes; see
that module) and repairs them in the joint's own rotation space: slerp between the good frames around an
interior gap (positions: linear), constant angular velocity (positions: constant velocity)
at the ends, measured between the nearest good frame and the good frame
:data:`VELOCITY_BASELINE_S` seconds further in (the two previous frames of seed 000's
missing-data method, widened against capture noise), for at most :data:`EXTRAPOLATE_MAX_S` seconds,
then held.  Only the broken frames' channels change; every repair is returned as a
:class:`Repair` so the caller reports it (never silently).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SplicerError
from ..model.motion import Motion, _Owned
from ..model.rotations import euler_from_quat, quat_conj, quat_mul, quat_slerp
# the detection, re-exported: these names were defined here before the split
from .dropouts import (FROZEN_EXIT_RATIO, FROZEN_MIN_FRAMES, FROZEN_MIN_MOVING, FROZEN_MIN_S, KINDS,  # noqa: F401
                       MAX_FINGER_SPEED_DEG_S, SPIKE_MAX_FRAMES, ZERO_ROW_ATOL, _joint_columns, _quats, _runs,
                       detect_problems, hand_joints)

__all__ = ["Repair", "repair_motion", "detect_problems", "MAX_FINGER_SPEED_DEG_S", "FROZEN_MIN_S",
           "FROZEN_MIN_FRAMES", "FROZEN_EXIT_RATIO", "SPIKE_MAX_FRAMES", "EXTRAPOLATE_MAX_S", "repairs_summary",
           "hand_joints", "VELOCITY_BASELINE_S", "ZERO_ROW_ATOL"]

EXTRAPOLATE_MAX_S = 0.1  # seconds of constant-velocity extrapolation at an end, then held
VELOCITY_BASELINE_S = 0.05  # seconds between the two good frames the end velocity is measured over


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


def repair_motion(motion: Motion, joints=None, *, max_speed_deg_s: float = MAX_FINGER_SPEED_DEG_S,
                  progress=None) -> tuple[Motion, list[Repair]]:
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
    progress : callable, optional
        ``progress(fraction)`` during the search (:func:`splicer.rig.dropouts.detect_problems`).

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
    found = detect_problems(motion, joints, max_speed_deg_s=max_speed_deg_s, progress=progress)
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
    return Motion(sk, _Owned(ch), motion.frame_time, motion.source), repairs


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
