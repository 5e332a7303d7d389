"""Skeleton roles: which joints are each side's upper arm, elbow, wrist and fingers.

Joints are found by name AND topology, so that common conventions work without
configuration:

* Mixamo / ZEGGS: ``LeftArm``, ``LeftForeArm``, ``LeftHand``, ``LeftHandIndex1`` (also with
  ``mixamorig:``-style prefixes);
* SMPL / SMPL-X: ``left_shoulder`` (the upper arm), ``left_elbow``, ``left_wrist``, ``left_index1``;
* CMU: ``LeftArm``, ``LeftForeArm``, ``LeftHand``, ``LeftFingerBase``, ``LThumb``;
* Leap-style hand files: root ``rForeArm``, ``rHand``, ``rThumb1``, ``rMid1``;
* wrist-rooted hand files: ``WRIST``, ``THUMB_CMC_FE``, ``INDEX_MCP``, ``MIDDLE_MCP`` ...

The wrist is found by name (``hand`` or ``wrist`` once the side and any prefix are
removed); the elbow and upper arm are then its ancestors (twist/roll joints and
zero-length helpers skipped), whatever they are called — SMPL's ``left_shoulder`` is
the upper arm because it is the wrist's grandparent, not because of its name.  Fingers
are the wrist's descendants whose names contain a finger word; their segments are
numbered by depth from the base.  An explicit mapping overrides all of this.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RoleError
from ..model.kinematics import rest_positions
from ..model.motion import Skeleton

__all__ = ["FINGERS", "SIDES", "ArmRoles", "Roles", "find_roles", "detect_up_axis", "joint_side"]

SIDES = ("left", "right")
FINGERS = ("thumb", "index", "middle", "ring", "pinky")

_FINGER_WORDS = {
    "thumb": ("thumb", "thb", "pollex"),
    "index": ("index", "idx", "pointer"),
    "middle": ("middle", "mid"),
    "ring": ("ring",),
    "pinky": ("pinky", "pinkie", "little", "small"),
}
# generic finger joints of coarse rigs (CMU: LeftFingerBase -> LFingers)
_GENERIC_FINGER_WORDS = ("fingerbase", "fingers", "finger", "handtip", "palm")
_TWIST_WORDS = ("twist", "roll", "helper", "share", "bend")
_AXES = {"x": 0, "y": 1, "z": 2}


def _core(name: str) -> str:
    """Name without namespace prefix (``mixamorig:``, ``Character1_``... before a colon or pipe)."""
    return re.split(r"[:|]", name)[-1]


def joint_side(name: str) -> str | None:
    """``"left"``, ``"right"`` or None, from a joint name.

    >>> [joint_side(n) for n in ["LeftHand", "left_wrist", "rHand", "LThumb", "Hand_R", "WRIST", "RING_MCP"]]
    ['left', 'left', 'right', 'left', 'right', None, None]
    """
    core = _core(name)
    low = core.lower()
    if "left" in low:
        return "left"
    if "right" in low:
        return "right"
    # l/r prefix followed by an upper-case letter or separator: lHand, LThumb, L_Hand, l.hand
    m = re.match(r"^([LlRr])(?:[A-Z][a-z0-9]|[_.\- ])", core)
    if m:
        return "left" if m.group(1).lower() == "l" else "right"
    # suffix: Hand_L, hand.r, Hand L
    m = re.search(r"[_.\- ]([LlRr])$", core)
    if m:
        return "left" if m.group(1).lower() == "l" else "right"
    return None


def _stem(name: str) -> str:
    """Lower-case name without prefix, side marker and separators: ``mixamorig:LeftHand`` -> ``hand``."""
    core = _core(name)
    low = core.lower()
    low = re.sub(r"left|right", "", low)
    if re.match(r"^[LlRr](?:[A-Z][a-z0-9]|[_.\- ])", core):
        low = low[1:]
    low = re.sub(r"[_.\- ][lr]$", "", low)
    return re.sub(r"[^a-z0-9]", "", low)


def _finger_of(name: str) -> str | None:
    s = _stem(name)
    for finger, words in _FINGER_WORDS.items():
        for w in words:
            if w in s:
                # "mid" must not catch e.g. "middle" of a different finger (it does not) nor "pyramid"
                return finger
    return None


@dataclass(frozen=True)
class ArmRoles:
    """The joints of one side.

    Attributes
    ----------
    side : str
        ``"left"`` or ``"right"``.
    wrist : int
        The hand/wrist joint (its rotation turns the whole hand).
    elbow : int or None
        The forearm joint (rotates about the elbow); None in wrist-rooted hand files.
    upper_arm : int or None
        The joint the humerus turns about; None in hand-only files.
    fingers : dict of str to tuple of int
        For each of ``thumb, index, middle, ring, pinky`` present, the chain of joint
        indices from the base (segment 1) outward.  Coarse rigs without named fingers
        (CMU) list their generic finger chain under ``"hand"``.
    """

    side: str
    wrist: int
    elbow: int | None
    upper_arm: int | None
    fingers: dict[str, tuple[int, ...]] = field(default_factory=dict)

    @property
    def finger_joints(self) -> list[int]:
        """Every finger joint of this side, sorted."""
        return sorted(j for chain in self.fingers.values() for j in chain)


@dataclass(frozen=True)
class Roles:
    """Roles of a skeleton: the up axis (0=X, 1=Y, 2=Z) and each side found."""

    up: int
    sides: dict[str, ArmRoles]

    def __getitem__(self, side: str) -> ArmRoles:
        return self.sides[side]


def _descend_chain(sk: Skeleton, start: int, pred) -> tuple[int, ...]:
    """From ``start``, follow the first child satisfying ``pred`` while there is one."""
    chain = [start]
    j = start
    while True:
        kids = [k for k in sk.children[j] if pred(k)]
        if not kids:
            return tuple(chain)
        j = kids[0]
        chain.append(j)


def _fingers_under(sk: Skeleton, wrist: int) -> dict[str, tuple[int, ...]]:
    below = sk.descendants(wrist)
    fingers: dict[str, tuple[int, ...]] = {}
    for finger in FINGERS:
        members = [j for j in below if _finger_of(sk.names[j]) == finger]
        if not members:
            continue
        mset = set(members)
        # the base: a member whose parent is not a member of the same finger
        bases = [j for j in members if int(sk.parents[j]) not in mset]
        base = min(bases, key=lambda j: len(sk.chain(j)))
        fingers[finger] = _descend_chain(sk, base, lambda k, mset=mset: k in mset)
    if not any(f in fingers for f in ("index", "middle", "ring", "pinky")):
        generic = [j for j in below if any(w in _stem(sk.names[j]) for w in _GENERIC_FINGER_WORDS)]
        if generic:
            gset = set(generic)
            base = min(generic, key=lambda j: len(sk.chain(j)))
            fingers["hand"] = _descend_chain(sk, base, lambda k: k in gset)
    return fingers


def _is_helper(sk: Skeleton, j: int) -> bool:
    s = _stem(sk.names[j])
    return any(w in s for w in _TWIST_WORDS)


def _arm_above(sk: Skeleton, wrist: int, rest: np.ndarray) -> tuple[int | None, int | None]:
    """Elbow and upper-arm joints above ``wrist``: the next two ancestors that are real
    segments (not twist/roll helpers and not at the same place as their child)."""
    found: list[int] = []
    child = wrist
    j = int(sk.parents[wrist])
    while j >= 0 and len(found) < 2:
        same_place = np.linalg.norm(rest[child] - rest[j]) < 1e-9 * max(1.0, np.abs(rest).max())
        if _is_helper(sk, j) or same_place:
            j = int(sk.parents[j])
            continue
        found.append(j)
        child = j
        j = int(sk.parents[j])
    elbow = found[0] if found else None
    upper = found[1] if len(found) > 1 else None
    # a hand-only file rooted at the forearm (Leap: rForeArm -> rHand) has no upper arm;
    # its root is the forearm only if it is named so
    if elbow is not None and upper is None and not re.search(r"fore|elbow|lowerarm|arm", _stem(sk.names[elbow])):
        elbow = None
    if upper is not None:
        s = _stem(sk.names[upper])
        # the joint above the elbow must be on the arm (not the spine of a rig without clavicles)
        if re.search(r"spine|chest|neck|hips|pelvis|root|torso", s):
            upper = None
    return elbow, upper


def _side_from_path(path: str | None) -> str | None:
    if not path:
        return None
    stem = Path(path).stem.lower()
    has_l = bool(re.search(r"left|(^|[_\-. ])l($|[_\-. ])|lhand", stem))
    has_r = bool(re.search(r"right|(^|[_\-. ])r($|[_\-. ])|rhand", stem))
    if has_l != has_r:
        return "left" if has_l else "right"
    return None


def detect_up_axis(skeleton: Skeleton) -> int:
    """Vertical axis of the rest skeleton: 0 (X), 1 (Y) or 2 (Z).

    From the root to the head (or from the feet to the root) when the skeleton has them;
    Y, the BVH convention, for hand-only skeletons.
    """
    rest = rest_positions(skeleton)
    stems = [_stem(n) for n in skeleton.names]
    head = [j for j, s in enumerate(stems) if s in ("head", "headend", "neck", "neck1", "skull") or s.startswith("head")]
    feet = [j for j, s in enumerate(stems) if any(w in s for w in ("foot", "ankle", "toe"))]
    root = 0
    if head:
        v = rest[head[0]] - rest[root]
    elif feet:
        v = rest[root] - rest[feet[0]]
    else:
        return 1
    if np.linalg.norm(v) == 0:
        return 1
    return int(np.argmax(np.abs(v)))


def _mapping_index(sk: Skeleton, name: str, what: str, source: str) -> int:
    try:
        return sk.index(name)
    except KeyError:
        raise RoleError(f"{source}: the mapping names {what} joint {name!r}, which is not in the skeleton") from None


def _roles_from_mapping(sk: Skeleton, side: str, spec: dict, source: str) -> ArmRoles:
    wrist = _mapping_index(sk, spec["wrist"], f"{side} wrist", source)
    elbow = _mapping_index(sk, spec["elbow"], f"{side} elbow", source) if spec.get("elbow") else None
    upper = _mapping_index(sk, spec["upper_arm"], f"{side} upper_arm", source) if spec.get("upper_arm") else None
    fingers = {}
    if "fingers" in spec:
        for finger, names in spec["fingers"].items():
            if finger not in FINGERS:
                raise RoleError(f"{source}: unknown finger {finger!r} in the {side} mapping (use {', '.join(FINGERS)})")
            fingers[finger] = tuple(_mapping_index(sk, n, f"{side} {finger}", source) for n in names)
    else:
        fingers = _fingers_under(sk, wrist)
    return ArmRoles(side, wrist, elbow, upper, fingers)


def find_roles(skeleton: Skeleton, *, source: str | None = None, mapping: dict | None = None,
               up: str | int | None = None, side: str | None = None) -> Roles:
    """Find each side's arm and hand joints.

    Parameters
    ----------
    skeleton : Skeleton
    source : str, optional
        File name, for messages and to tell the side of a hand-only file whose joint
        names carry none (``teapot_leftHand.bvh``).
    mapping : dict, optional
        Explicit roles, overriding detection: ``{"left": {"wrist": "L_Wrist", "elbow": ...,
        "upper_arm": ..., "fingers": {"index": ["L_Idx1", "L_Idx2"], ...}}, "right": {...}}``.
        Sides not in the mapping are detected.
    up : {"x", "y", "z"} or int, optional
        Vertical axis; detected from the rest skeleton when omitted.
    side : {"left", "right"}, optional
        Side of a hand-only skeleton whose names do not tell it.

    Returns
    -------
    Roles

    Raises
    ------
    RoleError
        When no side has a wrist; the message lists the joints that were found.
    """
    src = source or "skeleton"
    sk = skeleton
    if up is None:
        up_axis = detect_up_axis(sk)
    elif isinstance(up, str):
        if up.lower() not in _AXES:
            raise RoleError(f"{src}: up axis must be x, y or z, not {up!r}")
        up_axis = _AXES[up.lower()]
    else:
        up_axis = int(up)
    rest = rest_positions(sk)
    mapping = mapping or {}
    sides: dict[str, ArmRoles] = {}
    for s, spec in mapping.items():
        if s not in SIDES:
            raise RoleError(f"{src}: unknown side {s!r} in the joint mapping (use left or right)")
        if not isinstance(spec, dict) or "wrist" not in spec:
            raise RoleError(f"{src}: the {s} joint mapping needs at least a 'wrist' entry")
        sides[s] = _roles_from_mapping(sk, s, spec, src)

    # wrist candidates: stem "hand" or "wrist" (prefer wrist: SMPL has left_wrist -> left_hand)
    cands: dict[str | None, list[int]] = {}
    for j, n in enumerate(sk.names):
        st = _stem(n)
        if st in ("wrist", "hand", "handwrist"):
            cands.setdefault(joint_side(n), []).append(j)
    for s in SIDES + (None,):
        if s in cands:
            cands[s].sort(key=lambda j: (0 if "wrist" in _stem(sk.names[j]) else 1, len(sk.chain(j))))
    unsided = cands.pop(None, [])
    if unsided and not any(cands.values()):
        s = side or _side_from_path(source)
        if s is None:
            raise RoleError(
                f"{src}: found hand joint {sk.names[unsided[0]]!r} but cannot tell whether it is the left or "
                "right hand (neither the joint names nor the file name say); give the side (--hands-side or "
                "'side' in the config)"
            )
        cands[s] = unsided
    for s in SIDES:
        if s in sides or not cands.get(s):
            continue
        wrist = cands[s][0]
        elbow, upper = _arm_above(sk, wrist, rest)
        sides[s] = ArmRoles(s, wrist, elbow, upper, _fingers_under(sk, wrist))
    if not sides:
        armish = [n for n in sk.names if re.search(r"arm|hand|wrist|elbow|shoulder|finger|thumb|index", n, re.I)]
        found = ", ".join(armish[:12]) if armish else "none"
        raise RoleError(
            f"{src}: no wrist/hand joint found on either side (arm or hand joints seen: {found}); "
            f"joints in the file: {', '.join(sk.names[:8])}{' ...' if sk.n_joints > 8 else ''}. "
            "Map them in the config file under 'joints:' (see README, 'Skeleton conventions')"
        )
    return Roles(up_axis, sides)
