"""Rest-pose hand geometry that survives coarse and odd skeletons.

Real rigs place joints at the same point (CMU: ``RightFingerBase`` and ``RThumb`` sit at
offset 0 0 0 under ``RightHand``; Leap: ``rForeArm`` at the wrist), have fingers without
bases, or no fingers at all.  Everything here returns finite answers for those, falling
back step by step, and says which fallback it took.

* :func:`finger_anchors` — for each finger, the first point of its chain that is away from
  the wrist: a joint, or the End Site of the chain's last joint (``(joint, local offset)``).
* :func:`hand_frame` — the rest hand frame (long axis, radial axis, ``long x radial``).
* :func:`graft_scale` — body length units per hands length unit for grafted fingers, from the
  hand size (wrist to knuckles), else the forearm length, else the body's forearm and the
  typical hand/forearm proportion.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..model.kinematics import rest_positions
from ..model.motion import Skeleton
from .roles import ArmRoles

__all__ = ["same_anatomical_joint", "finger_anchors", "hand_points", "hand_frame", "hand_frame_warnings", "hand_length",
           "forearm_length", "GraftScale", "graft_scale", "HAND_PER_FOREARM"]

#: wrist -> middle-finger knuckle in forearm (elbow -> wrist) lengths: about 10 cm for 26 cm
#: (adult averages, e.g. NASA-STD-3000 anthropometry); used only when nothing else compares
HAND_PER_FOREARM = 0.4
_TINY = 1e-6  # relative to the skeleton's extent


_AXIS_SUFFIX = re.compile(r"[_.\- ]?(fe|aa|flex|flexion|abd|abduction|add|adduction|twist|pronation)$")
_JOINT_TOKEN = re.compile(r"(cmc|mcp|pip|dip|ip)")


def same_anatomical_joint(a: str, b: str) -> bool:
    """Whether two joint names are two axes of one anatomical joint (``THUMB_CMC_FE`` and
    ``THUMB_CMC_AA``): equal once an axis suffix (FE, AA, flex, abd, twist...) is removed, and
    naming a finger joint (CMC, MCP, PIP, DIP, IP)."""
    ka = _AXIS_SUFFIX.sub("", a.lower())
    kb = _AXIS_SUFFIX.sub("", b.lower())
    return ka == kb and ka != a.lower() and bool(_JOINT_TOKEN.search(ka))


def _extent(rest: np.ndarray) -> float:
    return max(float(np.ptp(rest, axis=0).max()) if len(rest) else 0.0, 1e-9)


def finger_anchors(sk: Skeleton, arm: ArmRoles, rest: np.ndarray | None = None) -> dict[str, tuple[int, np.ndarray]]:
    """For each finger, where its base effectively is: ``(joint, offset in that joint's frame)``.

    The first joint of the chain that is not at the wrist's rest position (offset zero), else
    the End Site of the chain's last joint when it has one away from the wrist.  Fingers
    whose whole chain (and End Site) sits at the wrist are left out.
    """
    rest = rest_positions(sk) if rest is None else rest
    eps = _TINY * _extent(rest)
    w = rest[arm.wrist]
    out: dict[str, tuple[int, np.ndarray]] = {}
    for finger, chain in arm.fingers.items():
        for j in chain:
            if np.linalg.norm(rest[j] - w) > eps:
                out[finger] = (j, np.zeros(3))
                break
        else:
            if chain:
                last = chain[-1]
                es = sk.end_sites[last]
                if not np.any(np.isnan(es)) and np.linalg.norm(rest[last] + es - w) > eps:
                    out[finger] = (last, np.array(es, dtype=np.float64))
    return out


def hand_points(sk: Skeleton, arm: ArmRoles, rest: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Rest world position of each finger's anchor (see :func:`finger_anchors`), file units."""
    rest = rest_positions(sk) if rest is None else rest
    return {f: rest[j] + off for f, (j, off) in finger_anchors(sk, arm, rest).items()}


def _centre(pts: dict[str, np.ndarray]) -> np.ndarray | None:
    if "middle" in pts:
        return pts["middle"]
    if "hand" in pts:
        return pts["hand"]
    return np.mean(list(pts.values()), axis=0) if pts else None


def hand_length(sk: Skeleton, arm: ArmRoles, rest: np.ndarray | None = None) -> float | None:
    """Rest distance wrist -> middle knuckle (else the generic finger base, else the mean
    of the finger anchors, thumb excluded when others exist), file units; None without fingers."""
    rest = rest_positions(sk) if rest is None else rest
    pts = hand_points(sk, arm, rest)
    if len(pts) > 1:
        pts.pop("thumb", None)
    c = _centre(pts)
    if c is None:
        return None
    d = float(np.linalg.norm(c - rest[arm.wrist]))
    return d if d > _TINY * _extent(rest) else None


def forearm_length(sk: Skeleton, arm: ArmRoles, rest: np.ndarray | None = None) -> float | None:
    """Rest distance elbow -> wrist, file units; None without an elbow or when they coincide."""
    if arm.elbow is None:
        return None
    rest = rest_positions(sk) if rest is None else rest
    d = float(np.linalg.norm(rest[arm.wrist] - rest[arm.elbow]))
    return d if d > _TINY * _extent(rest) else None


def _long_axis(sk: Skeleton, arm: ArmRoles, rest: np.ndarray, pts: dict[str, np.ndarray]) -> tuple[np.ndarray, str]:
    eps = _TINY * _extent(rest)
    w = rest[arm.wrist]
    core = {f: p for f, p in pts.items() if f != "thumb"} or pts
    c = _centre(core)
    if c is not None and np.linalg.norm(c - w) > eps:
        return c - w, "finger bases"
    es = sk.end_sites[arm.wrist]
    if not np.any(np.isnan(es)) and np.linalg.norm(es) > eps:
        return np.array(es, dtype=np.float64), "wrist End Site"
    j = arm.wrist
    while j >= 0:  # the forearm (or any bone above) continued
        p = int(sk.parents[j])
        if p < 0:
            break
        if np.linalg.norm(w - rest[p]) > eps:
            return w - rest[p], "forearm direction"
        j = p
    return np.array([1.0, 0.0, 0.0]), "none (X axis assumed)"


def hand_frame(sk: Skeleton, arm: ArmRoles, *, explain: bool = False):
    """Rest-pose hand frame in world axes.

    Returns
    -------
    np.ndarray [shape=(3, 3)]
        Orthonormal columns: long axis (wrist -> middle knuckle), radial axis (pinky -> index
        side, orthogonal to the long axis) and their cross product ``long x radial`` (the back
        of a right hand, the palm of a left one).  Always finite and proper (det +1).
    str
        Only with ``explain=True``: how the axes were found (fallbacks named).
    """
    rest = rest_positions(sk)
    pts = hand_points(sk, arm, rest)
    u, how_u = _long_axis(sk, arm, rest, pts)
    u = u / np.linalg.norm(u)
    radial = pts.get("index", pts.get("thumb"))
    ulnar = pts.get("pinky", pts.get("ring"))
    if radial is not None and ulnar is None:
        c = _centre({f: p for f, p in pts.items() if f not in ("thumb", "index")})
        ulnar = c if c is not None else rest[arm.wrist]
    how_v = "finger bases"
    v = None if radial is None else radial - ulnar
    if v is None or np.linalg.norm(np.cross(u, v)) < 1e-6 * max(np.linalg.norm(v), 1e-300):
        # no across-the-palm axis: any axis perpendicular to u
        v = np.cross(u, [0.0, 1.0, 0.0] if abs(u[1]) < 0.9 else [1.0, 0.0, 0.0])
        how_v = "none (an axis perpendicular to the hand assumed)"
    v = v - u * np.dot(u, v)
    v = v / np.linalg.norm(v)
    frame = np.stack([u, v, np.cross(u, v)], axis=1)
    if explain:
        return frame, f"long axis from {how_u}, radial axis from {how_v}"
    return frame


def hand_frame_warnings(sk: Skeleton, arm: ArmRoles, where: str) -> list[str]:
    """A warning line when :func:`hand_frame` had to assume an axis (the finger rotations are then
    carried over about a guessed axis), else nothing."""
    _, how = hand_frame(sk, arm, explain=True)
    if "assumed" not in how:
        return []
    return [f"{where}: the {arm.side} hand's rest frame is a guess ({how}); its finger rotations may be turned"]


@dataclass(frozen=True)
class GraftScale:
    """Body length units per hands length unit for grafted fingers, and how it was found."""

    scale: float
    method: str


def graft_scale(body_sk: Skeleton, body_arm: ArmRoles, hands_sk: Skeleton, hands_arm: ArmRoles) -> GraftScale:
    """Scale for hands fingers grafted onto a body.

    In order: the ratio of hand lengths (wrist -> knuckles) when both skeletons have finger
    anchors; the ratio of forearm lengths when both have a forearm of non-zero length; the
    body's forearm times :data:`HAND_PER_FOREARM` over the hands' hand length; else 1.
    """
    hb, hh = hand_length(body_sk, body_arm), hand_length(hands_sk, hands_arm)
    fb, fh = forearm_length(body_sk, body_arm), forearm_length(hands_sk, hands_arm)
    if hb and hh:
        return GraftScale(hb / hh, f"hand length (wrist to knuckles) {hb:.4g} / {hh:.4g}")
    if fb and fh:
        return GraftScale(fb / fh, f"forearm length {fb:.4g} / {fh:.4g}")
    if fb and hh:
        return GraftScale(HAND_PER_FOREARM * fb / hh,
                          f"body forearm {fb:.4g} x {HAND_PER_FOREARM} (typical hand/forearm) / hands hand length {hh:.4g}")
    return GraftScale(1.0, "none: nothing to compare (no hand or forearm length on both); own size kept")
