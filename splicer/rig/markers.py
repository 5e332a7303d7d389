"""Virtual markers (ALGORITHM.md section 1): four per side and frame, in world coordinates.

* ``p1``, ``p2``: the wrist joint offset by plus/minus half the wrist width along the
  radial-ulnar axis (pinky base -> index base; thumb base when the index is missing);
  the width is the distance between those bases.  ``wrist="styloid"`` places them as real
  wrist markers sit, on the styloids: the rest pose's radial-ulnar axis turned with the
  forearm and with the hand's twist about it (pronation, which the radius carries and a rig
  without twist bones keeps in the wrist joint), not with the hand's bending.
* ``p3``: the midpoint of elbow and wrist.  A wrist-rooted hand file has no elbow: its
  forearm is taken as continuing straight back from the hand (the rest-pose direction
  middle base -> wrist, turned with the wrist), 2.5 hand lengths long.
* ``p4``: the base of the middle finger, else the centroid of the finger bases.
* the shoulder ``s``: the upper-arm joint; the origin in hand-only files (a hand capture
  volume keeps the arm nearly still).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RoleError
from ..model.kinematics import global_transforms, rest_positions
from ..model.motion import Motion
from .handgeom import HAND_PER_FOREARM, finger_anchors
from .roles import ArmRoles
from ..model.rotations import atan2_stable, quat_conj, quat_mul, quat_rotate, quat_twist

__all__ = ["Markers", "WRIST_PLACEMENTS", "arm_markers", "marker_placement", "root_heading"]

FOREARM_PER_HAND = 2.5  # forearm length in hand lengths (wrist -> middle base), for hand-only files


@dataclass(frozen=True, eq=False)
class Markers:
    """Virtual markers of one side.

    Attributes
    ----------
    points : np.ndarray [shape=(T, 4, 3)]
        ``p1, p2`` (wrist, radial and ulnar), ``p3`` (forearm), ``p4`` (hand), world, file units.
    shoulder : np.ndarray [shape=(T, 3)]
        Upper-arm joint position (zeros for hand-only files), world, file units.
    heading : np.ndarray [shape=(T,)]
        Heading of the root about the up axis, radians (for the trunk-heading alignment).
    up : int
        Vertical axis, 0/1/2.
    fps : float
        Frames per second.
    side : str
    blur : np.ndarray [shape=(T,)] or None
        Extra smoothing of the phase metric's markers at each frame, in multiples of that
        metric's own smoothing (unitless, >= 0), applied before it
        (:func:`splicer.align.costs.phase_features`): the tempo-matched smoothing of
        :mod:`splicer.align.tempo`.  None (the default): none.  Nothing else reads it, and
        resampling the markers drops it.
    """

    points: np.ndarray
    shoulder: np.ndarray
    heading: np.ndarray
    up: int
    fps: float
    side: str
    blur: np.ndarray | None = None

    def __post_init__(self):
        for name in ("points", "shoulder", "heading"):
            a = np.array(getattr(self, name), dtype=np.float64)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if self.blur is not None:
            b = np.array(self.blur, dtype=np.float64)
            if b.shape != (self.points.shape[0],) or not (np.all(np.isfinite(b)) and (b.size == 0 or b.min() >= 0)):
                raise ValueError(f"blur must hold one finite width >= 0 per frame ({self.points.shape[0]}), "
                                 f"got shape {b.shape}")
            b.setflags(write=False)
            object.__setattr__(self, "blur", b)

    @property
    def n_frames(self) -> int:
        return self.points.shape[0]

    def relative(self) -> np.ndarray:
        """Markers relative to the shoulder, shape (T, 4, 3)."""
        return self.points - self.shoulder[:, None, :]


def root_heading(motion: Motion, up: int) -> np.ndarray:
    """Heading of the root joint about axis ``up``, radians, unwrapped, shape (T,).

    Measured like :func:`splicer.metrics.horizontal_axes`' turns: from horizontal axis
    ``a = (up + 1) % 3`` toward ``b = (up + 2) % 3``, so a right-handed turn of the motion by
    ``+phi`` about ``up`` adds ``phi`` to the heading.
    """
    rot, _ = global_transforms(motion, [0])
    a, b = (up + 1) % 3, (up + 2) % 3
    # the root's own axes: the one that stands along the world's up axis over the take is its
    # "up" (the rest skeleton's, e.g. z in a Z-up rest exported with Y-up motion); the heading is
    # measured on the next one, cyclically, as a = up + 1 is for world axes.  A skeleton whose
    # root axes are the world's (the usual case) measures on axis a, as always.
    axes = np.stack([quat_rotate(rot[:, 0], e) for e in np.eye(3)], axis=1)  # (T, 3 root axes, 3 world)
    local_up = int(np.argmax(np.abs(axes[:, :, up].mean(axis=0))))
    v = axes[:, (local_up + 1) % 3]
    return np.unwrap(atan2_stable(v[:, b], v[:, a]))


def _sources(keys) -> tuple[str, str | None, str | None]:
    """Which finger bases ``arm_markers`` takes for ``p4``, the radial and the ulnar side, given
    the bases found (``keys``; ``"hand"`` for a body without finger joints): ``"mean"`` for ``p4``
    is the centroid of the bases, ``None`` a side across the palm (coarse rigs)."""
    p4 = "middle" if "middle" in keys else ("hand" if "hand" in keys else "mean")
    radial = "index" if "index" in keys else ("thumb" if "thumb" in keys else None)
    ulnar = "pinky" if "pinky" in keys else ("ring" if "ring" in keys else None)
    if radial is not None and ulnar is None:
        ulnar = p4  # index or thumb against the hand's middle: still the radial side
    return p4, radial, ulnar


#: Where :func:`arm_markers` puts the wrist markers: across the palm (``"palm"``, the default) or
#: on the styloids (``"styloid"``), as optical markers sit.
WRIST_PLACEMENTS = ("palm", "styloid")


def _styloid_ready(arm: ArmRoles, sided: bool) -> bool:
    """The styloid placement needs a forearm joint and both sides of the hand (``sided``)."""
    return arm.elbow is not None and sided


def marker_placement(sk, arm: ArmRoles, *, p3: str | None = None, wrist: str = "palm") -> str:
    """How :func:`arm_markers` places one side's markers on this skeleton, in words.

    Two takes whose placements are equal have markers made the same way from the same kind of
    joints (each finger base a joint, or an End Site's offset: ``*``), so the hand's direction in
    the forearm's frame compares between them (:mod:`splicer.align.wrist`).  ``p3`` says what
    the forearm marker follows: ``elbow`` (the real forearm), ``forearm joint`` (a hand-only
    file's virtual forearm turned with its forearm joint) or ``hand`` (turned with the wrist:
    a wrist-rooted file); ``p3=`` overrides it for markers remade another way
    (:func:`splicer.rig.handonly.hand_only_view`).

    Examples
    --------
    ``"p1-p2 index-pinky, p3 elbow, p4 middle"``; a body without finger joints:
    ``"p1-p2 across-across, p3 elbow, p4 hand"``; ``wrist="styloid"`` (where the rig allows it):
    ``"p1-p2 index-pinky styloid, p3 elbow, p4 middle"``.
    """
    if wrist not in WRIST_PLACEMENTS:
        raise ValueError(f"wrist must be one of {WRIST_PLACEMENTS}, got {wrist!r}")
    anchors = finger_anchors(sk, arm, rest_positions(sk))
    keys = {f: ("*" if np.any(off) else "") for f, (_, off) in anchors.items()} or {"hand": ""}
    p4, radial, ulnar = _sources(keys)
    sided = radial is not None and ulnar is not None
    if not sided:
        radial = ulnar = "across"
    name = {k: k + keys.get(k, "") for k in (p4, radial, ulnar)}
    if p3 is None:  # as arm_markers turns it
        p3 = "elbow" if arm.elbow is not None else ("hand" if sk.parents[arm.wrist] < 0 else "forearm joint")
    on = " styloid" if wrist == "styloid" and _styloid_ready(arm, sided) else ""
    return f"p1-p2 {name[radial]}-{name[ulnar]}{on}, p3 {p3}, p4 {name[p4]}"


def arm_markers(motion: Motion, arm: ArmRoles, up: int, *, wrist: str = "palm") -> Markers:
    """Virtual markers of one side of ``motion``.

    Parameters
    ----------
    motion : Motion
    arm : ArmRoles
        The side's joints (see :func:`splicer.roles.find_roles`).
    up : int
        Vertical axis of the motion.
    wrist : {"palm", "styloid"}
        Where ``p1, p2`` sit: across the palm (turned with the hand), or on the styloids
        (turned with the forearm and its pronation: where optical wrist markers sit, for a take
        aligned against one that has them); ``"styloid"`` falls back to the palm on a rig without
        a forearm joint or without both sides of the hand.

    Returns
    -------
    Markers

    Raises
    ------
    RoleError
        When the hand has no finger joints to place the hand and wrist markers.
    """
    if wrist not in WRIST_PLACEMENTS:
        raise ValueError(f"wrist must be one of {WRIST_PLACEMENTS}, got {wrist!r}")
    sk = motion.skeleton
    rest = rest_positions(sk)
    # each finger's base: its first joint away from the wrist, or its End Site (coarse rigs
    # such as CMU put LeftFingerBase and LThumb at the wrist's place)
    anchors = finger_anchors(sk, arm, rest)
    bases = {f: j for f, (j, _) in anchors.items()}
    if not bases and arm.elbow is None:
        raise RoleError(
            f"{motion.source or 'motion'}: the {arm.side} hand ({sk.names[arm.wrist]}) has neither finger joints "
            "away from the wrist nor a forearm joint; the hand markers need one of them"
        )
    extra = [j for j in (arm.elbow, arm.upper_arm) if j is not None]
    base_list = list(bases.values())
    joints = [arm.wrist] + extra + base_list
    grot, gpos = global_transforms(motion, joints)
    w = gpos[:, 0]
    bpos = {}
    for k, (f, (j, off)) in enumerate(anchors.items()):
        g = 1 + len(extra) + k
        bpos[f] = gpos[:, g] if not np.any(off) else gpos[:, g] + quat_rotate(grot[:, g], off)
    if not bpos:
        # a body without finger joints: the hand continues the forearm at rest (or reaches the
        # wrist's End Site), turned with the wrist
        tip = sk.end_sites[arm.wrist]
        if np.any(np.isnan(tip)):
            tip = HAND_PER_FOREARM * (rest[arm.wrist] - rest[arm.elbow])
        bpos["hand"] = w + quat_rotate(grot[:, 0], tip)

    # hand marker and radial-ulnar axis (marker_placement says the same in words)
    p4_key, radial_key, ulnar_key = _sources(bpos)
    p4 = np.mean(np.stack(list(bpos.values()), axis=1), axis=1) if p4_key == "mean" else bpos[p4_key]
    radial = bpos.get(radial_key) if radial_key is not None else None
    ulnar = (p4 if ulnar_key == p4_key else bpos[ulnar_key]) if ulnar_key is not None else None
    if radial is None or ulnar is None:
        # coarse rig: across the palm, perpendicular to the hand's long axis and the up axis of the wrist
        long_axis = p4 - w
        side_axis = quat_rotate(grot[:, 0], np.eye(3)[(up + 2) % 3])
        across = np.cross(long_axis, side_axis)
        n = np.linalg.norm(across, axis=-1, keepdims=True)
        across = across / np.maximum(n, 1e-12) * 0.5 * np.linalg.norm(long_axis, axis=-1, keepdims=True)
    elif wrist == "styloid" and _styloid_ready(arm, sided=True):
        # the rest pose's radial-ulnar axis, carried by the forearm and the hand's twist about it
        rest_base = {f: rest[j] + off for f, (j, off) in anchors.items()}
        rest_p4 = np.mean(np.stack(list(rest_base.values())), axis=0) if p4_key == "mean" else rest_base[p4_key]
        rest_across = rest_base[radial_key] - (rest_p4 if ulnar_key == p4_key else rest_base[ulnar_key])
        axis = rest[arm.wrist] - rest[arm.elbow]
        axis = axis / max(float(np.linalg.norm(axis)), 1e-12)  # in the forearm's frame: joint frames are world at rest
        pronation = quat_twist(quat_mul(quat_conj(grot[:, 1]), grot[:, 0]), axis)  # the wrist joint's, relative to the forearm
        across = quat_rotate(quat_mul(grot[:, 1], pronation), rest_across)
    else:
        across = radial - ulnar
    p1 = w + 0.5 * across
    p2 = w - 0.5 * across

    if arm.elbow is not None:
        p3 = 0.5 * (w + gpos[:, 1])
    else:
        # no elbow position: the forearm continues straight back from the rest-pose hand,
        # turned with the forearm joint when there is one (Leap: rForeArm at the wrist) or
        # with the wrist (wrist-rooted files).  At rest every joint frame is the world frame.
        f0 = "middle" if "middle" in anchors else next(iter(anchors), None)
        hand_vec = (rest[anchors[f0][0]] + anchors[f0][1] - rest[arm.wrist]) if f0 else np.zeros(3)
        back = -FOREARM_PER_HAND * hand_vec
        parent = int(sk.parents[arm.wrist])
        turn = grot[:, 0] if parent < 0 else global_transforms(motion, [parent])[0][:, 0]
        p3 = w + 0.5 * quat_rotate(turn, back)

    if arm.upper_arm is not None:
        shoulder = gpos[:, 1 + (1 if arm.elbow is not None else 0)]
    else:
        shoulder = np.zeros_like(w)
    heading = root_heading(motion, up)
    return Markers(np.stack([p1, p2, p3, p4], axis=1), shoulder, heading, up, motion.fps, arm.side)
