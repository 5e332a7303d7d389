"""Finger sanity: do the fingers bend the way fingers can?

For each finger of one hand, the signed flexion angle at each of its joints (MCP, PIP, DIP;
for the thumb CMC, MCP, IP) in every frame, measured between the world-space bone segments
(the goniometer's angle: metacarpal -> proximal phalanx at the MCP, and so on), positive
toward the palm.  The palm side comes from the hand's handedness: with the rest hand frame
``u`` (wrist -> middle knuckle) and ``r`` (pinky -> index side, orthogonal to ``u``), the palm
of a right hand faces ``-(u x r)`` and that of a left hand ``+(u x r)``; a finger of a right
hand flexes by a positive rotation about ``r`` (about ``-r`` for a left hand).  The axis rides
with the wrist (not with each finger joint, whose frame rigs may twist about the bone); both
bones are projected onto the plane perpendicular to it.  The thumb bends "toward the palm":
about ``proximal bone x palm``.

:func:`finger_sanity` summarises the angles per finger:

* ``backward``: share of frames in which a PIP or DIP joint (the thumb's IP joint) bends
  backwards by more than :data:`HYPEREXTENSION_DEG` (a small, normal hyperextension: 15
  degrees for fingers, 30 for the thumb);
* ``out_of_range``: share of frames with any joint outside its anatomical range
  (:data:`RANGES_DEG`, widened by :data:`RANGE_SLACK_DEG` for measurement and rig error);
* ``dip_pip``: mean absolute departure of the DIP angle from 2/3 of the PIP angle, degrees,
  over frames where the PIP is flexed by 10 degrees or more (the DIP-PIP coupling of
  Rijpkema & Girard, "Computer animation of knowledge-based human grasping", SIGGRAPH 1991).

Ranges (active motion, degrees; negative = extension beyond straight) are the American
Academy of Orthopaedic Surgeons' averages (AAOS, "Joint Motion: Method of Measuring and
Recording", 1965; also Greene & Heckman, "The Clinical Measurement of Joint Motion", AAOS
1994): finger MCP -45..90, PIP 0..100, DIP -10..90; thumb MCP 0..50, IP -20..80.  The thumb's
CMC joint has no single flexion axis and is not range-checked; the thumb's flexion axis is
taken as "toward the palm", which is approximate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rig.handgeom import hand_frame, same_anatomical_joint
from ..model.kinematics import global_transforms, rest_positions
from ..model.motion import Motion
from ..rig.roles import FINGERS, ArmRoles
from ..model.rotations import cross3, quat_rotate

__all__ = ["RANGES_DEG", "HYPEREXTENSION_DEG", "RANGE_SLACK_DEG", "CHUNK_FRAMES", "FingerAngles", "finger_angles",
           "finger_sanity", "sanity_warnings"]

#: anatomical ranges, degrees (extension negative), AAOS 1965 (see the module docstring)
RANGES_DEG = {
    "finger": {"MCP": (-45.0, 90.0), "PIP": (0.0, 100.0), "DIP": (-10.0, 90.0)},
    "thumb": {"CMC": None, "MCP": (0.0, 50.0), "IP": (-20.0, 80.0)},
}
#: hyperextension still counted as normal (not "bending backwards"), degrees: finger PIP/DIP
#: joints about 0-10 (AAOS), the thumb's IP joint about 20 (AAOS), each with a little slack
HYPEREXTENSION_DEG = {"finger": 15.0, "thumb": 30.0}
#: slack added to both ends of every range, degrees
RANGE_SLACK_DEG = 10.0
#: warning thresholds: share of frames
WARN_BACKWARD = 0.10
WARN_OUT_OF_RANGE = 0.25

#: :func:`finger_angles` works on this many frames at a time (about 60 MB of world transforms
#: for a 25-joint hand)
CHUNK_FRAMES = 16384

_FINGER_JOINTS = ("MCP", "PIP", "DIP")
_THUMB_JOINTS = ("CMC", "MCP", "IP")


@dataclass(frozen=True, eq=False)
class FingerAngles:
    """Signed flexion angles of one hand.

    Attributes
    ----------
    angles : dict of str to dict of str to np.ndarray [shape=(T,)]
        ``angles["index"]["PIP"]``: degrees, positive toward the palm.
    chirality : int
        +1: read as a right hand, -1: as a left hand.
    """

    angles: dict
    chirality: int


def _chain_points(motion: Motion, arm: ArmRoles, finger: str, rest: np.ndarray, grot, gpos, index):
    """World points wrist, joint1, joint2, ... tip of a finger (coincident joints merged) and,
    for each point but the last, the joint whose rotation carries the segment leaving it."""
    sk = motion.skeleton
    chain = arm.fingers[finger]
    eps = 1e-6 * max(float(np.ptp(rest, axis=0).max()), 1e-9)
    pts = [gpos[:, index[arm.wrist]]]
    carriers = [arm.wrist]
    prev_rest = rest[arm.wrist]
    for j in chain:
        if np.linalg.norm(rest[j] - prev_rest) > eps and not same_anatomical_joint(sk.names[carriers[-1]], sk.names[j]):
            pts.append(gpos[:, index[j]])
            carriers.append(j)
            prev_rest = rest[j]
        else:
            carriers[-1] = j  # a joint at the same place: the later one carries the segment
    last = carriers[-1]
    es = sk.end_sites[last]
    if not np.any(np.isnan(es)) and np.linalg.norm(es) > eps:
        tip_off = np.array(es, dtype=np.float64)
    elif len(pts) >= 2:
        # no tip: the last bone continues its parent bone's rest direction (ManipNet's End
        # Sites are 0 0 0), 0.8 of its length
        k = len(pts) - 1
        prev = carriers[k - 1]
        tip_off = 0.8 * (rest[last] - rest[prev])
    else:
        return pts, carriers
    pts.append(pts[-1] + quat_rotate(grot[:, index[last]], tip_off))
    return pts, carriers


def _signed(d0: np.ndarray, d1: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Angle from d0 to d1 about ``axis`` (all (T, 3)), degrees, after projecting both onto
    the plane perpendicular to the axis."""
    a = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-300)
    p0 = d0 - a * np.sum(d0 * a, axis=-1, keepdims=True)
    p1 = d1 - a * np.sum(d1 * a, axis=-1, keepdims=True)
    return np.degrees(np.arctan2(np.sum(cross3(p0, p1) * a, axis=-1), np.sum(p0 * p1, axis=-1)))


def finger_angles(motion: Motion, arm: ArmRoles, chirality: int) -> FingerAngles:
    """Signed flexion of every finger joint of one hand (see the module docstring).

    Parameters
    ----------
    motion : Motion
    arm : ArmRoles
        The hand's joints.
    chirality : {+1, -1}
        Read the hand as a right (+1) or left (-1) hand: decides which side is the palm.

    Returns
    -------
    FingerAngles
        Joints named ``MCP, PIP, DIP`` (thumb ``CMC, MCP, IP``), as many as the chain has.

    Notes
    -----
    Computed over :data:`CHUNK_FRAMES` frames at a time (every angle depends on its own frame
    only), so the world transforms of the hand's joints never exist for a whole long take:
    memory O(chunk x joints) plus the (T,) angles.
    """
    T = motion.n_frames
    if T <= CHUNK_FRAMES:
        return _finger_angles(motion, arm, chirality)
    parts = [_finger_angles(motion.slice(a, min(a + CHUNK_FRAMES, T)), arm, chirality).angles
             for a in range(0, T, CHUNK_FRAMES)]
    return FingerAngles({f: {name: np.concatenate([p[f][name] for p in parts]) for name in ang}
                         for f, ang in parts[0].items()}, int(chirality))


def _finger_angles(motion: Motion, arm: ArmRoles, chirality: int) -> FingerAngles:
    """:func:`finger_angles` of all frames at once."""
    sk = motion.skeleton
    rest = rest_positions(sk)
    frame = hand_frame(sk, arm)
    r = frame[:, 1] * chirality           # flexion axis of the fingers at rest (world = every joint's frame)
    palm = -frame[:, 2] * chirality       # palm direction at rest
    joints = sorted({arm.wrist, *arm.finger_joints})
    grot, gpos = global_transforms(motion, joints)
    index = {j: k for k, j in enumerate(joints)}
    # the axes ride with the wrist, not with each finger joint: rigs twist finger joint frames
    # by constant rotations (ManipNet: -88 deg about the bone), which must not tilt the axis
    wrot = grot[:, index[arm.wrist]]
    r_w = quat_rotate(wrot, np.broadcast_to(r, (motion.n_frames, 3)))
    palm_w = quat_rotate(wrot, np.broadcast_to(palm, (motion.n_frames, 3)))
    out: dict[str, dict[str, np.ndarray]] = {}
    for finger in FINGERS:
        if finger not in arm.fingers:
            continue
        pts, carriers = _chain_points(motion, arm, finger, rest, grot, gpos, index)
        names = _THUMB_JOINTS if finger == "thumb" else _FINGER_JOINTS
        res: dict[str, np.ndarray] = {}
        for k in range(1, min(len(pts) - 1, 4)):
            d0 = pts[k] - pts[k - 1]
            d1 = pts[k + 1] - pts[k]
            if finger == "thumb":
                # toward the palm: axis = proximal bone x palm (per frame)
                axis = cross3(d0, palm_w)
                weak = np.linalg.norm(axis, axis=-1) < 1e-6 * np.linalg.norm(d0, axis=-1)
                axis[weak] = r_w[weak]
            else:
                axis = r_w
            res[names[k - 1]] = _signed(d0, d1, axis)
        out[finger] = res
    return FingerAngles(out, int(chirality))


def _share(mask: np.ndarray) -> float:
    return float(np.mean(mask)) if mask.size else 0.0


def finger_sanity(motion: Motion, arm: ArmRoles, chirality: int) -> dict:
    """Per-finger summary of :func:`finger_angles` (JSON-ready).

    Returns
    -------
    dict
        ``{finger: {"backward": share, "backward_max_deg": deg, "out_of_range": share,
        "dip_pip_deg": deg or None, "joints": {joint: {"min_deg", "max_deg"}}}, ...}`` plus
        ``"_reading": "right" | "left"`` and ``"_frame"`` (how the hand frame was found).  Shares
        are fractions of frames (0..1).
    """
    fa = finger_angles(motion, arm, chirality)
    T = motion.n_frames
    _, how = hand_frame(motion.skeleton, arm, explain=True)
    out: dict = {"_reading": "right" if chirality > 0 else "left", "_frame": how}
    for finger, ang in fa.angles.items():
        kind = "thumb" if finger == "thumb" else "finger"
        hinge = ("IP",) if kind == "thumb" else ("PIP", "DIP")
        back = np.zeros(T, dtype=bool)
        back_max = 0.0
        for j in hinge:
            if j in ang:
                back |= ang[j] < -HYPEREXTENSION_DEG[kind]
                back_max = max(back_max, float(-ang[j].min()))
        outside = np.zeros(T, dtype=bool)
        for j, a in ang.items():
            rng = RANGES_DEG[kind].get(j)
            if rng is not None:
                outside |= (a < rng[0] - RANGE_SLACK_DEG) | (a > rng[1] + RANGE_SLACK_DEG)
        dip_pip = None
        if "PIP" in ang and "DIP" in ang:
            m = ang["PIP"] >= 10.0
            if np.any(m):
                dip_pip = round(float(np.mean(np.abs(ang["DIP"][m] - 2.0 / 3.0 * ang["PIP"][m]))), 2)
        out[finger] = {
            "backward": round(_share(back), 4),
            "backward_max_deg": round(max(back_max, 0.0), 1),
            "out_of_range": round(_share(outside), 4),
            "dip_pip_deg": dip_pip,
            "joints": {j: {"min_deg": round(float(a.min()), 1), "max_deg": round(float(a.max()), 1)}
                       for j, a in ang.items()},
        }
    return out


def sanity_warnings(report: dict, where: str, source: dict | None = None) -> list[str]:
    """Warning lines for the fingers of ``report`` (from :func:`finger_sanity`) above the thresholds.

    ``source``, the same summary of the hands capture (over the hands frames the output shows),
    is quoted beside each figure so that a reader sees whether the splice or the capture bends
    the finger so.
    """
    out = []
    if "assumed" in report.get("_frame", ""):
        return out  # angles about a guessed axis: no verdict (the splice warns about the guess)
    for finger, r in report.items():
        if finger.startswith("_"):
            continue
        src = (source or {}).get(finger)
        kind = "thumb" if finger == "thumb" else "finger"
        if r["backward"] > WARN_BACKWARD:
            also = f" (the hands capture, same frames: {100 * src['backward']:.0f}%)" if src else ""
            out.append(f"{where}: the {finger} finger bends backwards (beyond {HYPEREXTENSION_DEG[kind]:g} deg of "
                       f"hyperextension, up to {r['backward_max_deg']:g} deg) in {100 * r['backward']:.0f}% of frames{also}")
        elif r["out_of_range"] > WARN_OUT_OF_RANGE:
            also = f" (the hands capture, same frames: {100 * src['out_of_range']:.0f}%)" if src else ""
            out.append(f"{where}: the {finger} finger leaves the anatomical joint ranges in "
                       f"{100 * r['out_of_range']:.0f}% of frames{also}")
    return out
