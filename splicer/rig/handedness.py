"""Handedness: is a hand geometrically the right or the left hand its name says?

A hand captured in a left-handed engine and exported without converting the rotations is a
mirror image: the file's "right" hand is, in geometry, a left hand.  A rotation cannot undo
a reflection, so spliced as it is its fingers bend toward the back of the body's hand.

The evidence (:func:`hand_handedness`) is the side the fingers flex toward over the take.
Read as a right hand (:func:`splicer.sanity.finger_angles` with chirality +1), the PIP and
DIP joints of index to pinky of a proper right hand bend mostly forward (toward the palm);
those of a left hand (or a mirrored right hand) mostly backward.  Frames where a finger
bends by at least :data:`MIN_BEND_DEG` (PIP + DIP) vote (of a long take, :data:`VOTE_FRAMES`
frames evenly spaced); a side is decided when at least :data:`DECIDE_SHARE` of the votes
agree.  Without such motion, a weak static cue is used: the thumb's base sits on the palm
side of the knuckle plane (by at least a tenth of the hand length) in most rigs.

:func:`mirror_motion` reflects a whole motion through a coordinate plane: offsets and
positions flip one coordinate, rotations ``R -> M R M`` (the rotation about the plane's
normal stays, the other two angles change sign; Euler channels are rewritten in place, no
re-conversion).  Fingers keep their real flexion; the motion becomes that of the other hand.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SplicerError
from .handgeom import hand_frame, hand_length, hand_points
from ..model.kinematics import rest_positions
from ..model.motion import Motion, Skeleton, _Owned
from .roles import ArmRoles, Roles
from ..transfer.sanity import finger_angles

__all__ = ["Handedness", "hand_handedness", "mirror_motion", "resolve_handedness", "MIRROR_CHOICES"]

MIN_BEND_DEG = 20.0
DECIDE_SHARE = 0.75
MIN_VOTES = 10
# the flexion vote reads at most this many frames, evenly spaced over the take: a share of votes
# needs no more, and a 20-minute hands take at 120 fps (144,000 frames) took 5 s to read whole
VOTE_FRAMES = 12_000
THUMB_CUE = 0.1  # thumb base off the knuckle plane, in hand lengths
MIRROR_CHOICES = ("auto", "yes", "no")


@dataclass(frozen=True)
class Handedness:
    """What a hand's geometry says.

    Attributes
    ----------
    named : str
        The side its joint names (or the file name) give.
    geometric : str or None
        ``"right"`` or ``"left"`` by geometry; None when undecided.
    status : str
        ``"flexion"`` (decided by finger flexion), ``"thumb"`` (weak static cue),
        ``"contradictory"`` (flexion votes disagree), ``"no axis"`` (no across-the-palm axis
        to tell the palm side by) or ``"no evidence"``.
    right_share : float or None
        Share of the flexion votes for a right hand.
    votes : int
        Finger-frames that bent by at least :data:`MIN_BEND_DEG` (of the frames read: at most
        :data:`VOTE_FRAMES`).
    """

    named: str
    geometric: str | None
    status: str
    right_share: float | None
    votes: int

    def describe(self) -> str:
        if self.status == "flexion":
            share = self.right_share if self.geometric == "right" else 1.0 - self.right_share
            return (f"a {self.geometric} hand: its fingers flex toward the {self.geometric} hand's palm in "
                    f"{100 * share:.0f}% of {self.votes} bending finger-frames")
        if self.status == "thumb":
            return f"a {self.geometric} hand by the thumb's side of the palm (weak: the fingers hardly bend)"
        if self.status == "contradictory":
            return (f"undecided: the fingers flex toward a right hand's palm in {100 * self.right_share:.0f}% and a "
                    f"left hand's in {100 * (1 - self.right_share):.0f}% of {self.votes} bending finger-frames")
        if self.status == "no axis":
            return "undecided: the hand has no across-the-palm axis (index/thumb and pinky/ring bases)"
        return "undecided: the fingers hardly bend and the thumb sits in the knuckle plane"

    def as_dict(self) -> dict:
        return {"named": self.named, "geometric": self.geometric, "status": self.status,
                "right_share": None if self.right_share is None else round(self.right_share, 4),
                "votes": self.votes, "why": self.describe()}


def _thumb_cue(sk: Skeleton, arm: ArmRoles) -> str | None:
    pts = hand_points(sk, arm)
    length = hand_length(sk, arm)
    if "thumb" not in pts or not length:
        return None
    n = hand_frame(sk, arm)[:, 2]  # long x radial: back of a right hand, palm of a left one
    off = float(np.dot(pts["thumb"] - rest_positions(sk)[arm.wrist], n)) / length
    if abs(off) < THUMB_CUE:
        return None
    return "right" if off < 0 else "left"


def hand_handedness(motion: Motion, arm: ArmRoles) -> Handedness:
    """Geometric handedness of one hand of ``motion`` (see the module docstring)."""
    _, how = hand_frame(motion.skeleton, arm, explain=True)
    if "radial axis from none" in how:  # no across-the-palm axis: the palm side means nothing
        return Handedness(arm.side, None, "no axis", None, 0)
    T = motion.n_frames
    probe = motion if T <= VOTE_FRAMES else motion.frames(np.linspace(0, T - 1, VOTE_FRAMES).round().astype(np.int64))
    fa = finger_angles(probe, arm, +1)
    votes = []
    for finger in ("index", "middle", "ring", "pinky"):
        a = fa.angles.get(finger, {})
        bend = a.get("PIP", 0.0) + a.get("DIP", 0.0) if ("PIP" in a or "DIP" in a) else None
        if bend is None:
            continue
        votes.append(bend[np.abs(bend) >= MIN_BEND_DEG])
    v = np.concatenate(votes) if votes else np.zeros(0)
    n = int(v.size)
    if n >= MIN_VOTES:
        share = float(np.mean(v > 0))
        if share >= DECIDE_SHARE:
            return Handedness(arm.side, "right", "flexion", share, n)
        if share <= 1.0 - DECIDE_SHARE:
            return Handedness(arm.side, "left", "flexion", share, n)
        return Handedness(arm.side, None, "contradictory", share, n)
    cue = _thumb_cue(motion.skeleton, arm)
    if cue is not None:
        return Handedness(arm.side, cue, "thumb", None, n)
    return Handedness(arm.side, None, "no evidence", None, n)


def mirror_motion(motion: Motion, axis: int) -> Motion:
    """The motion reflected through the plane perpendicular to world axis ``axis`` (0, 1, 2).

    Offsets, End Sites and position channels flip that coordinate; each rotation ``R``
    becomes ``M R M`` (``M`` the reflection): in any Euler order the angle about ``axis``
    is kept and the two others change sign.
    """
    sk = motion.skeleton
    flip = np.ones(3)
    flip[axis] = -1.0
    letter = "XYZ"[axis]
    ch = np.array(motion.channels)
    for j, names in enumerate(sk.channels):
        o = int(sk.channel_offsets[j])
        for k, c in enumerate(names):
            if c.endswith("position"):
                if c[0] == letter:
                    ch[:, o + k] *= -1.0
            elif c[0] != letter:
                ch[:, o + k] *= -1.0
    new_sk = Skeleton(sk.names, sk.parents, sk.offsets * flip, sk.channels, sk.end_sites * flip)
    return Motion(new_sk, _Owned(ch), motion.frame_time, motion.source)


def resolve_handedness(body: Motion, broles: Roles, hands: Motion, hroles: Roles, sides, *, mode: str = "auto",
                       note=lambda msg: None) -> tuple[Motion, dict]:
    """Decide whether the hands file must be mirrored to match the body's hands, and do it.

    Parameters
    ----------
    body, hands : Motion
    broles, hroles : Roles
    sides : sequence of str
        Sides being spliced.
    mode : {"auto", "yes", "no"}
        ``yes``/``no`` force; ``auto`` mirrors when every decided side of the hands file has the
        other handedness than the body's hand of that side (the body's geometry when decided,
        else its name).
    note : callable
        Receives warning lines.

    Returns
    -------
    hands : Motion
        Mirrored or unchanged.
    report : dict
        ``{"mode", "mirrored", "body": {side: ...}, "hands": {side: ...}}``.

    Raises
    ------
    SplicerError
        In ``auto`` mode, when the hands file's flexion contradicts itself, or its sides disagree.
    """
    if mode not in MIRROR_CHOICES:
        raise SplicerError(f"mirror_hands must be one of {', '.join(MIRROR_CHOICES)}, not {mode!r}")
    hsrc = hands.source or "hands"
    bsrc = body.source or "body"
    rep: dict = {"mode": mode, "mirrored": False, "body": {}, "hands": {}}
    need: dict[str, bool] = {}
    for s in sides:
        bh = hand_handedness(body, broles.sides[s]) if broles.sides[s].fingers else None
        hh = hand_handedness(hands, hroles.sides[s])
        if bh is not None:
            rep["body"][s] = bh.as_dict()
        rep["hands"][s] = hh.as_dict()
        target = bh.geometric if bh is not None and bh.geometric else s
        if bh is not None and bh.geometric and bh.geometric != s:
            note(f"{bsrc}: the {s} hand is geometrically {bh.describe()}; the hands capture is matched to it")
        if hh.geometric is None:
            if hh.status == "contradictory" and mode == "auto":
                raise SplicerError(
                    f"{hsrc}: cannot tell whether the {s} hand is mirrored ({hh.describe()}); "
                    "choose with --mirror-hands yes or --mirror-hands no")
            if mode == "auto":
                note(f"{hsrc}: handedness of the {s} hand {hh.describe()}; taken as a {s} hand, as named")
            continue
        need[s] = hh.geometric != target
    if mode == "auto":
        if len(set(need.values())) > 1:
            raise SplicerError(
                f"{hsrc}: the hands file's sides disagree on being mirrored ("
                + ", ".join(f"{s}: {'mirrored' if v else 'proper'}" for s, v in need.items())
                + "); choose with --mirror-hands yes or --mirror-hands no")
        do = bool(need) and all(need.values())
    else:
        do = mode == "yes"
    if do:
        axis = (hroles.up + 1) % 3
        hands = mirror_motion(hands, axis)
        rep["mirrored"] = True
        rep["plane"] = f"{'xyz'[axis]} = 0"
        why = "; ".join(f"{s}: {rep['hands'][s]['why']}, body wants a {rep['body'].get(s, {}).get('geometric') or s} hand"
                        for s in need) if mode == "auto" else "forced by mirror_hands=yes"
        note(f"{hsrc}: mirror image of the body's hands (left-handed export?); mirrored through the plane "
             f"{'xyz'[axis]} = 0 so the fingers flex toward the palm ({why})")
    elif mode == "no" and any(need.values()):
        note(f"{hsrc}: looks like a mirror image of the body's hands ("
             + "; ".join(rep["hands"][s]["why"] for s, v in need.items() if v)
             + "); kept as it is (mirror_hands=no): its fingers may bend backwards")
    return hands, rep
