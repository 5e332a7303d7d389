"""The world's up axis, from the motion itself.

The rest skeleton does not always tell: SMPL-X-style exports have a Z-up rest skeleton whose
root joint carries a constant -90 degree rotation about X, so the animated body stands along
Y.  :func:`detect_up` therefore looks at the animated world positions over the take:

1. the head above the hips and the hips above the feet (joints found by name): the vertical
   is the axis along which ``head - hips`` and ``hips - feet`` point in most frames;
2. without head and feet names, the root's own orientation: the root turns about the
   vertical but hardly tilts, so the root-fixed direction that stays most constant in the
   world over the take is the vertical (used only when the root turns by 30 degrees or more);
3. hand-only files (and bodies that neither stand nor turn) fall back to the rest skeleton
   (:func:`splicer.roles.detect_up_axis`; Y, the BVH convention, for hand-only skeletons).

An ``up:`` entry of the config overrides all of this.  :func:`restate_rest_axes` makes such
files: it re-expresses a motion's rest skeleton in turned axes while keeping every joint's
animated world position.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.kinematics import global_transforms
from ..model.motion import Motion, Skeleton
from .roles import _stem, detect_up_axis
from ..model.rotations import quat_conj, quat_mul, quat_rotate

__all__ = ["UpAxis", "detect_up", "restate_rest_axes"]

_AXES = "xyz"
_MAX_FRAMES = 400      # frames sampled over the take
_DECIDE_SHARE = 0.6    # share of frames that must agree
_MIN_TURN_DEG = 30.0   # the root must turn this much for its rotation to tell the vertical


@dataclass(frozen=True)
class UpAxis:
    """The vertical axis of one file and why.

    Attributes
    ----------
    axis : int
        0 (X), 1 (Y) or 2 (Z).
    source : str
        ``"config"``, ``"motion"`` or ``"rest skeleton"``.
    why : str
        The evidence, e.g. ``"head above hips in 100% of frames"``.
    rest_axis : int
        What the rest skeleton alone says.
    """

    axis: int
    source: str
    why: str
    rest_axis: int

    def as_dict(self) -> dict:
        return {"axis": _AXES[self.axis], "from": f"{self.source}: {self.why}", "rest_skeleton": _AXES[self.rest_axis]}


def _named(sk: Skeleton):
    stems = [_stem(n) for n in sk.names]
    head = [j for j, s in enumerate(stems) if s in ("head", "headend", "skull") or s.startswith("head")]
    if not head:
        head = [j for j, s in enumerate(stems) if s in ("neck", "neck1")]
    feet = [j for j, s in enumerate(stems) if any(w in s for w in ("foot", "ankle", "toe"))]
    return head[:1], feet


def _sampled(motion: Motion) -> Motion:
    T = motion.n_frames
    if T <= _MAX_FRAMES:
        return motion
    idx = np.unique(np.linspace(0, T - 1, _MAX_FRAMES).round().astype(np.int64))
    return motion.frames(idx)


def _vote(v: np.ndarray) -> tuple[int, int, float]:
    """Axis, sign and share of frames where ``v`` (T, 3) points mostly along that signed axis."""
    dom = np.argmax(np.abs(v), axis=1)
    sign = np.sign(v[np.arange(len(v)), dom])
    best = (0, 1, -1.0)
    for a in range(3):
        for s in (1, -1):
            share = float(np.mean((dom == a) & (sign == s)))
            if share > best[2]:
                best = (a, s, share)
    return best


def detect_up(motion: Motion, *, override: str | int | None = None) -> UpAxis:
    """Vertical axis of ``motion`` (see the module docstring).

    Parameters
    ----------
    motion : Motion
    override : {"x", "y", "z"} or int, optional
        The config's ``up:``; returned as is (source ``"config"``).

    Returns
    -------
    UpAxis
    """
    sk = motion.skeleton
    rest_axis = detect_up_axis(sk)
    if override is not None:
        axis = override if isinstance(override, int) else _AXES.index(str(override).lower())
        return UpAxis(int(axis), "config", "up: in the config file", rest_axis)
    if motion.n_frames == 0:  # nothing moves: the rest skeleton (the splice refuses such a take later, by name)
        return UpAxis(rest_axis, "rest skeleton", "the take has no frames", rest_axis)
    head, feet = _named(sk)
    m = _sampled(motion)
    if head or feet:
        joints = [0] + head + feet
        _, pos = global_transforms(m, joints)
        root = pos[:, 0]
        parts = []
        if head:
            parts.append(("head above hips", pos[:, 1] - root))
        if feet:
            parts.append(("feet below hips", root - pos[:, 1 + len(head):].mean(axis=1)))
        v = sum(p / np.maximum(np.linalg.norm(p, axis=1, keepdims=True), 1e-300) for _, p in parts)
        if np.all(np.linalg.norm(v, axis=1) > 0):
            a, s, share = _vote(v)
            if share >= _DECIDE_SHARE:
                what = " and ".join(name for name, _ in parts)
                why = f"{what} along {'+' if s > 0 else '-'}{_AXES[a]} in {100 * share:.0f}% of frames"
                return UpAxis(a, "motion", why, rest_axis)
    else:
        rot, _ = global_transforms(m, [0])
        q = rot[:, 0]
        turn = np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(q * q[:1], axis=-1)), 0, 1))).max()
        if turn >= _MIN_TURN_DEG and not _hand_only(sk):
            # the root-fixed direction that is world axis k at frame 0, over the take
            spread = []
            for k in range(3):
                e = np.zeros(3)
                e[k] = 1.0
                local = quat_rotate(quat_conj(q[0]), e)
                d = quat_rotate(q, np.broadcast_to(local, (len(q), 3)))
                spread.append(float(np.mean(np.degrees(np.arccos(np.clip(d @ e, -1, 1))))))
            order = np.argsort(spread)
            if spread[order[0]] < 0.5 * spread[order[1]]:
                a = int(order[0])
                return UpAxis(a, "motion", f"the root turns about {_AXES[a]} (by up to {turn:.0f} deg) and tilts "
                                           f"{spread[a]:.0f} deg on average", rest_axis)
    if _hand_only(sk):
        why = "hand-only file: the rest skeleton's axis"
    else:
        why = "the motion does not tell (no head/feet names or no clear vertical); the rest skeleton's axis"
    return UpAxis(rest_axis, "rest skeleton", why, rest_axis)


def _hand_only(sk: Skeleton) -> bool:
    """No joint named like a body part, and few joints (a hand with a forearm has about 20)."""
    stems = [_stem(n) for n in sk.names]
    return sk.n_joints <= 25 and not any(any(w in s for w in ("hip", "pelvis", "spine", "chest", "neck", "head", "leg", "foot", "shoulder",
                                        "clavicle", "collar", "upperarm"))
                   or s == "arm" for s in stems)


def restate_rest_axes(motion: Motion, q: np.ndarray) -> Motion:
    """The same animated world positions with the rest skeleton turned by ``q``.

    Offsets (but the root's, a world place) and End Sites become ``q * offset``; every non-root local rotation ``R`` becomes
    ``q R q^-1``; the root's rotation becomes ``R q^-1``, its translation is kept.  With ``q``
    a +90 degree turn about X, a Y-up take becomes a Z-up rest skeleton whose root carries a
    -90 degree turn about X (the SMPL-X export convention).

    Parameters
    ----------
    motion : Motion
        Every joint with rotation channels needs three of them.
    q : np.ndarray [shape=(4,)]
        ``(w, x, y, z)`` unit quaternion.
    """
    sk = motion.skeleton
    q = np.asarray(q, dtype=np.float64)
    qi = quat_conj(q)
    offs = quat_rotate(q[None], sk.offsets)
    roots = np.asarray(sk.parents) < 0
    offs[roots] = sk.offsets[roots]  # a root's offset is a world place (kept)
    es = np.where(np.isnan(sk.end_sites), np.nan, quat_rotate(q[None], np.nan_to_num(sk.end_sites)))
    new_sk = Skeleton(sk.names, sk.parents, offs, sk.channels, es)
    out = Motion(new_sk, motion.channels, motion.frame_time, motion.source)
    joints = [j for j in range(sk.n_joints) if sk.rotation_columns(j)]
    rot = motion.joint_rotations(joints)
    new = np.empty_like(rot)
    for k, j in enumerate(joints):
        if sk.parents[j] < 0:
            new[:, k] = quat_mul(rot[:, k], qi[None])
        else:
            new[:, k] = quat_mul(quat_mul(q[None], rot[:, k]), qi[None])
    return out.with_rotations(joints, new)
