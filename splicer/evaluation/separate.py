"""Ground truth without a second session: split one take into a body and a hands capture.

The evaluation protocol of ALGORITHM.md section 8.  From a full-body take with moving
fingers, :func:`separate` makes

* ``body``: the take with every finger joint's rotation set to the identity;
* ``hands``: the take as a separate hand capture would record it — re-timed by a random
  smooth monotone warp, resampled to another frame rate, arm and torso rotations pulled
  toward their mean (a confined capture volume), the root held nearly still and turned
  about the vertical axis, small noise on the wrist and finger rotations;
* ``truth``: for every body frame, the (fractional) hands frame showing the same instant.

Time semantics: the hands clock runs at ``speed(t)`` hands-seconds per take-second, with
``speed`` smooth and within ``warp_speed``; hands frame ``k`` is at hands time ``k / hands_fps``;
``truth[i] = hands_fps * integral_0^{t_i} speed``, rescaled by less than half a frame so that
the last body frame maps exactly onto the last hands frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.kinematics import global_transforms
from ..model.motion import Motion, Skeleton
from ..rig.roles import Roles, find_roles
from ..model.rotations import quat_angle_deg, quat_conj, quat_hemisphere, quat_mul, quat_normalize, quat_slerp, yaw_quat_deg
from ..transfer.sampling import resample_motion
from .warps import smooth_monotone_warp, smooth_noise

__all__ = ["Separation", "separate", "warp_time_map", "confine_capture", "finger_joints", "moving_finger_joints",
           "wrist_rooted", "forearm_rooted", "hand_only_files", "mirror_motion", "protocol_joints"]


@dataclass(frozen=True, eq=False)
class Separation:
    """A take split into a body and a hands capture, with the true time correspondence.

    Attributes
    ----------
    body : Motion
        The take (same frames and frame time) with finger rotations set to identity.
    hands : Motion
        The full skeleton as a hand capture: re-timed, resampled, arms confined, root still and turned.
    truth : np.ndarray [shape=(n_body,), dtype=float64]
        Fractional hands frame of every body frame; strictly increasing, ``truth[0] = 0`` and
        ``truth[-1] = hands.n_frames - 1``.
    params : dict
        The drawn values: ``yaw_deg`` (signed, degrees about the up axis), ``hands_fps``,
        ``speed`` (n_body,) hands-seconds per take-second, ``amplitude`` (n_hands,) pull factor,
        ``root_drift`` (n_hands, 3) file units, ``noise_deg``, ``pulled_joints``, ``noisy_joints``,
        ``finger_joints`` (joint indices).
    hand_only : dict of str to Motion
        With ``hand_only="wrist"``: per side, the hands as a wrist-rooted hand-only skeleton
        (source ``"hands_left.bvh"`` / ``"hands_right.bvh"``); empty otherwise.
    """

    body: Motion
    hands: Motion
    truth: np.ndarray
    params: dict
    hand_only: dict = field(default_factory=dict)


def _roles(take: Motion, roles: Roles | None) -> Roles:
    return roles if roles is not None else find_roles(take.skeleton, source=take.source)


def finger_joints(take: Motion, roles: Roles | None = None) -> list[int]:
    """Every finger joint of both sides (indices into ``take.skeleton``), sorted."""
    r = _roles(take, roles)
    return sorted({j for arm in r.sides.values() for j in arm.finger_joints})


def _mean_rotation(q: np.ndarray) -> np.ndarray:
    """Chordal mean of quaternions ``(T, K, 4)`` over time, hemisphere-aligned to frame 0 -> (K, 4)."""
    sign = np.where(np.sum(q * q[:1], axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return quat_normalize(np.mean(q * sign, axis=0))


def moving_finger_joints(take: Motion, roles: Roles | None = None, *, min_range_deg: float = 5.0) -> list[int]:
    """Finger joints whose rotation moves: at some frame it is at least ``min_range_deg``
    degrees (geodesic) away from the joint's mean rotation over the take.  Sorted indices."""
    fj = finger_joints(take, roles)
    if not fj:
        return []
    q = take.rotations[:, fj]
    dev = quat_angle_deg(q, _mean_rotation(q)[None])
    return [j for j, d in zip(fj, dev.max(axis=0)) if d >= min_range_deg]


def protocol_joints(take: Motion) -> tuple[Roles, list[int]]:
    """The take's roles and its moving finger joints, which every score of the protocol needs.

    Raises
    ------
    SplicerError
        No finger joint moves (the finger error would be meaningless).
    """
    from ..errors import SplicerError

    roles = find_roles(take.skeleton, source=take.source)
    moving = moving_finger_joints(take, roles)
    if not moving:
        raise SplicerError(f"{take.source or 'take'}: no finger joint moves; the protocol needs moving fingers")
    return roles, moving


def _arm_torso_joints(sk: Skeleton, r: Roles) -> list[int]:
    """Joints between the root (excluded) and each elbow (included): spine, shoulders, upper arms, forearms."""
    out: set[int] = set()
    for arm in r.sides.values():
        top = arm.elbow if arm.elbow is not None else None
        if top is None:
            continue
        out.update(j for j in sk.chain(top) if sk.parents[j] >= 0)
    return sorted(j for j in out if len(sk.rotation_columns(j)) == 3)


def separate(take: Motion, *, rng: np.random.Generator, roles: Roles | None = None,
             hands_fps: float | None = None, warp_speed: tuple[float, float] = (0.5, 2.0),
             amplitude: tuple[float, float] = (0.25, 0.7), yaw_deg: tuple[float, float] = (25.0, 60.0),
             noise_deg: float = 0.5, root_drift: float | None = None, warp_sigma_s: float = 1.5,
             hand_only: str | None = None) -> Separation:
    """Split a full-body take with moving fingers into body, hands and truth (ALGORITHM.md 8).

    Parameters
    ----------
    take : Motion
        A full-body take whose skeleton has finger joints (found by :func:`~splicer.roles.find_roles`).
    rng : np.random.Generator
        Source of every random draw; the same seed gives the same separation.
    roles : Roles, optional
        Roles of ``take.skeleton``; found when omitted.
    hands_fps : float, optional
        Frame rate of the hands capture, frames per second; ``2 * take.fps`` by default.
    warp_speed : (float, float)
        Bounds of the local speed of the hands clock relative to the take (ratio).
    amplitude : (float, float)
        Bounds of the factor (varying smoothly over time) by which arm and torso rotations
        are pulled toward their mean: 1 keeps them, 0 freezes them at the mean.
    yaw_deg : (float, float)
        Bounds of the magnitude of the turn about the vertical axis, degrees; the sign is random.
    noise_deg : float
        RMS angle of the white rotation noise (random axis) on wrist and finger joints, degrees.
    root_drift : float, optional
        Scale of the smooth horizontal drift of the held root, file units; 2 % of the
        root's rest height above the origin (about 2 cm for a human in cm) by default.
    warp_sigma_s : float
        Smoothing width of the log-speed of the warp, seconds of the take.
    hand_only : {"wrist"}, optional
        Also return, per side, the hands as a wrist-rooted hand-only skeleton in
        :attr:`Separation.hand_only`.

    Returns
    -------
    Separation
        The input ``take`` is not modified.
    """
    if hand_only not in (None, "wrist"):
        raise ValueError(f"hand_only must be None or 'wrist', got {hand_only!r}")
    if take.n_frames < 2:
        raise ValueError("the take needs at least two frames")
    sk = take.skeleton
    r = _roles(take, roles)
    fingers = finger_joints(take, r)
    if not fingers:
        raise ValueError(f"{take.source or 'take'}: no finger joints found; the protocol needs a take with fingers")
    fps = take.fps
    g = float(hands_fps) if hands_fps is not None else 2.0 * fps
    if not g > 0:
        raise ValueError(f"hands_fps must be positive, got {hands_fps}")
    n = take.n_frames

    # body: fingers at identity
    ch = np.array(take.channels)
    for j in fingers:
        ch[:, sk.rotation_columns(j)] = 0.0
    body = take.with_channels(ch)

    truth, take_frames, speed = warp_time_map(n, fps, g, rng, warp_speed=warp_speed, warp_sigma_s=warp_sigma_s)
    hands = resample_motion(take, take_frames, 1.0 / g)
    hands, cap = confine_capture(hands, take, rng, roles=r, amplitude=amplitude, yaw_deg=yaw_deg,
                                 noise_deg=noise_deg, root_drift=root_drift)
    params = dict(hands_fps=g, speed=speed, noise_deg=float(noise_deg), finger_joints=fingers, **cap)
    extra = {}
    if hand_only == "wrist":
        extra = {side: wrist_rooted(hands, arm.wrist, source=f"hands_{side}.bvh") for side, arm in r.sides.items()}
    return Separation(body, hands, truth, params, extra)


def warp_time_map(n: int, fps: float, hands_fps: float, rng: np.random.Generator, *,
                  warp_speed: tuple[float, float] = (0.5, 2.0), warp_sigma_s: float = 1.5):
    """The random re-timing of :func:`separate` (one draw from ``rng``).

    Parameters
    ----------
    n : int
        Frames of the take.
    fps, hands_fps : float
        Frame rates of the take and of the hands capture, frames per second.

    Returns
    -------
    truth : np.ndarray [shape=(n,)]
        Fractional hands frame of each take frame; ``truth[0] = 0``, ``truth[-1] = m - 1``.
    take_frames : np.ndarray [shape=(m,)]
        Fractional take frame shown by each hands frame (the inverse of ``truth``).
    speed : np.ndarray [shape=(n,)]
        Hands-seconds per take-second.
    """
    w = smooth_monotone_warp(n, rng, min_speed=warp_speed[0], max_speed=warp_speed[1], sigma=warp_sigma_s * fps)
    truth = w * (hands_fps / fps)
    m = int(round(truth[-1])) + 1
    truth = truth * ((m - 1) / truth[-1])
    speed = np.gradient(truth) * fps / hands_fps
    take_frames = np.interp(np.arange(m, dtype=np.float64), truth, np.arange(n, dtype=np.float64))
    return truth, take_frames, speed


def confine_capture(hands: Motion, take: Motion, rng: np.random.Generator, *, roles: Roles | None = None,
                    amplitude: tuple[float, float] = (0.25, 0.7), yaw_deg: tuple[float, float] = (25.0, 60.0),
                    noise_deg: float = 0.5, root_drift: float | None = None) -> tuple[Motion, dict]:
    """Make a re-timed copy of ``take`` look like a separate hand capture (ALGORITHM.md 8).

    Arm and torso rotations are pulled toward their mean by a smoothly varying factor (a
    confined capture volume), the root is turned about the vertical axis and held near its
    mean horizontal position, and white rotation noise is added to wrists and fingers.
    Random draws, in this order: pull factor, yaw, root drift, noise (``separate`` relies on it).

    Parameters
    ----------
    hands : Motion
        The take's skeleton, already re-timed (any frame count); its frame time is kept.
    take : Motion
        The original take (for the root's rest height).
    rng : np.random.Generator
    roles, amplitude, yaw_deg, noise_deg, root_drift
        As in :func:`separate`.

    Returns
    -------
    (Motion, dict)
        The capture (source ``"hands.bvh"``) and the drawn values: ``amplitude`` (m,),
        ``yaw_deg``, ``root_drift`` (m, 3), ``pulled_joints``, ``noisy_joints``.
    """
    sk = take.skeleton
    r = _roles(take, roles)
    fingers = finger_joints(take, r)
    up = r.up
    m = hands.n_frames
    g = hands.fps

    # arms and torso pulled toward their mean by a smoothly varying factor
    pulled = _arm_torso_joints(sk, r)
    amp = amplitude[0] + (amplitude[1] - amplitude[0]) * (0.5 + 0.5 * np.tanh(1.2 * smooth_noise(m, rng, sigma=1.0 * g)))
    q = np.array(hands.rotations)
    if pulled:
        mean = _mean_rotation(q[:, pulled])
        q[:, pulled] = quat_slerp(np.broadcast_to(mean, q[:, pulled].shape), q[:, pulled],
                                  np.broadcast_to(amp[:, None], (m, len(pulled))))

    # root: turned about the vertical axis, held near its mean horizontal position
    root = 0
    yaw = rng.uniform(*yaw_deg) * rng.choice([-1.0, 1.0])
    q[:, root] = quat_mul(yaw_quat_deg(np.full(m, float(yaw)), up), q[:, root])
    horiz = [a for a in range(3) if a != up]
    pos = np.array(hands.translations[:, root])
    scale = root_drift if root_drift is not None else 0.02 * max(abs(float(np.mean(take.translations[:, root, up]))), 1.0)
    drift = np.zeros((m, 3))
    drift[:, horiz] = scale * smooth_noise(m, rng, sigma=2.0 * g, dims=(2,))
    pos[:, horiz] = pos[:, horiz].mean(axis=0) + drift[:, horiz]

    # capture noise on wrists and fingers
    noisy = sorted(set(fingers) | {arm.wrist for arm in r.sides.values()})
    noisy = [j for j in noisy if len(sk.rotation_columns(j)) == 3]
    rotvec = rng.normal(0.0, np.radians(noise_deg) / np.sqrt(3.0), (m, len(noisy), 3))
    ang = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    axis = np.where(ang > 0, rotvec / np.where(ang > 0, ang, 1.0), 0.0)
    dq = np.concatenate([np.cos(ang / 2), np.sin(ang / 2) * axis], axis=-1)
    q[:, noisy] = quat_mul(q[:, noisy], dq)

    changed = set(pulled) | set(noisy)
    if len(sk.rotation_columns(root)) == 3:
        changed.add(root)
    changed = sorted(changed)
    hands = hands.with_rotations(changed, quat_hemisphere(q[:, changed], axis=0))
    if sk.position_columns(root):
        hands = hands.with_translations(root, pos)
    hands = Motion(sk, hands.channels, hands.frame_time, "hands.bvh")

    return hands, dict(amplitude=amp, yaw_deg=float(yaw), root_drift=drift, pulled_joints=pulled, noisy_joints=noisy)


def wrist_rooted(motion: Motion, wrist: int, *, source: str | None = None) -> Motion:
    """The subtree of ``wrist`` as its own motion: the wrist becomes the root, with six
    channels (``Xposition Yposition Zposition`` then its rotation channels) holding its world
    position and rotation; the joints below keep their offsets and channels.

    Parameters
    ----------
    motion : Motion
    wrist : int
        Joint index in ``motion.skeleton``; it must have three rotation channels.
    source : str, optional
        Source of the result (e.g. ``"hands_left.bvh"``, which names the side).

    Returns
    -------
    Motion
        Same frames and frame time.
    """
    sk = motion.skeleton
    if len(sk.rotation_columns(wrist)) != 3:
        raise ValueError(f"joint {sk.names[wrist]!r} needs three rotation channels to become a root")
    joints = [wrist] + sk.descendants(wrist)
    new_index = {j: k for k, j in enumerate(joints)}
    rot_ch = tuple(c for c in sk.channels[wrist] if c.endswith("rotation"))
    channels = [("Xposition", "Yposition", "Zposition") + rot_ch] + [sk.channels[j] for j in joints[1:]]
    parents = [-1] + [new_index[int(sk.parents[j])] for j in joints[1:]]
    offsets = np.array(sk.offsets[joints])
    offsets[0] = 0.0
    sub = Skeleton(tuple(sk.names[j] for j in joints), np.array(parents), offsets, tuple(channels), sk.end_sites[joints])
    gq, gp = global_transforms(motion, [wrist])
    cols = np.concatenate([sk.channel_offsets[j] + np.arange(len(sk.channels[j])) for j in joints[1:]]).astype(np.int64) \
        if len(joints) > 1 else np.zeros(0, np.int64)
    ch = np.zeros((motion.n_frames, sub.n_channels))
    ch[:, 3 + len(rot_ch):] = motion.channels[:, cols]
    ch[:, :3] = gp[:, 0]
    out = Motion(sub, ch, motion.frame_time, source)
    return out.with_rotations([0], quat_hemisphere(gq, axis=0))


def forearm_rooted(motion: Motion, forearm: int, wrist: int, *, source: str | None = None) -> Motion:
    """The subtree of ``wrist`` under a forearm root placed AT the wrist, as Leap hand files are.

    The root (named as ``forearm``) has six channels: position = the wrist's world position,
    rotation = the forearm joint's world rotation; the wrist follows at offset zero with its
    rotation relative to the forearm joint (``conj(G_forearm) G_wrist``, the local rotation when
    the forearm is the wrist's parent); the joints below keep their offsets and channels.  The
    forearm's length and the shoulder are lost, as in a Leap capture.

    Parameters
    ----------
    motion : Motion
    forearm, wrist : int
        Joint indices in ``motion.skeleton`` (``forearm`` an ancestor of ``wrist``); both need
        three rotation channels.
    source : str, optional
        Source of the result (e.g. ``"hands_right.bvh"``).

    Returns
    -------
    Motion
        Same frames and frame time.
    """
    sk = motion.skeleton
    for j in (forearm, wrist):
        if len(sk.rotation_columns(j)) != 3:
            raise ValueError(f"joint {sk.names[j]!r} needs three rotation channels")
    if forearm not in sk.chain(wrist)[:-1]:
        raise ValueError(f"joint {sk.names[forearm]!r} is not above {sk.names[wrist]!r}")
    below = sk.descendants(wrist)
    joints = [wrist] + below
    new_index = {j: k + 1 for k, j in enumerate(joints)}
    rot_f = tuple(c for c in sk.channels[forearm] if c.endswith("rotation"))
    rot_w = tuple(c for c in sk.channels[wrist] if c.endswith("rotation"))
    channels = [("Xposition", "Yposition", "Zposition") + rot_f, rot_w] + [sk.channels[j] for j in below]
    parents = [-1, 0] + [new_index[int(sk.parents[j])] for j in below]
    offsets = np.concatenate([np.zeros((2, 3)), sk.offsets[below]])
    ends = np.concatenate([np.full((1, 3), np.nan), sk.end_sites[joints]])
    sub = Skeleton((sk.names[forearm],) + tuple(sk.names[j] for j in joints), np.array(parents), offsets,
                   tuple(channels), ends)
    gq, gp = global_transforms(motion, [forearm, wrist])
    ch = np.zeros((motion.n_frames, sub.n_channels))
    if below:
        cols = np.concatenate([sk.channel_offsets[j] + np.arange(len(sk.channels[j])) for j in below]).astype(np.int64)
        ch[:, 6 + len(rot_w):] = motion.channels[:, cols]
    ch[:, :3] = gp[:, 1]
    out = Motion(sub, ch, motion.frame_time, source)
    rel = quat_mul(quat_conj(gq[:, 0]), gq[:, 1])
    return out.with_rotations([0, 1], quat_hemisphere(np.stack([gq[:, 0], rel], axis=1), axis=0))


def hand_only_files(hands: Motion, roles: Roles, form: str) -> dict:
    """Per side, the hands take as the hand-only file a real capture would give.

    Parameters
    ----------
    hands : Motion
        A full-skeleton hands take (e.g. :attr:`Separation.hands`).
    roles : Roles
        Roles of ``hands.skeleton``.
    form : {"wrist", "forearm"}
        ``"wrist"``: wrist-rooted (ManipNet-like, :func:`wrist_rooted`); ``"forearm"``: forearm
        root at the wrist (Leap-like, :func:`forearm_rooted`).

    Returns
    -------
    dict of str to Motion
        ``{"left": ..., "right": ...}`` with sources ``hands_left.bvh`` / ``hands_right.bvh``.
    """
    if form not in ("wrist", "forearm"):
        raise ValueError(f"form must be 'wrist' or 'forearm', got {form!r}")
    out = {}
    for side, arm in roles.sides.items():
        src = f"hands_{side}.bvh"
        if form == "wrist":
            out[side] = wrist_rooted(hands, arm.wrist, source=src)
        else:
            if arm.elbow is None:
                raise ValueError(f"the {side} arm has no forearm joint to root a Leap-like file at")
            out[side] = forearm_rooted(hands, arm.elbow, arm.wrist, source=src)
    return out


def mirror_motion(motion: Motion, axis: int = 0) -> Motion:
    """The motion reflected through the plane normal to coordinate axis ``axis`` (0=X, 1=Y, 2=Z).

    The convention of left-handed-engine exports (the ManipNet files): every position and
    offset has its ``axis`` component negated, and a rotation ``R`` becomes ``M R M`` with
    ``M`` the reflection, which for BVH Euler channels means negating the angles about the two
    other axes (``M R_a(t) M = R_a(t)`` for ``a == axis``, ``R_a(-t)`` otherwise).  Joint names
    are kept: a right hand reflected this way is shaped like a left hand but still named right.
    Applying it twice gives back the input exactly.

    Parameters
    ----------
    motion : Motion
    axis : int
        The coordinate axis the reflection negates.

    Returns
    -------
    Motion
        Same skeleton topology, names, channels and frames.
    """
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
    sk = motion.skeleton
    letter = "XYZ"[axis]
    offsets = np.array(sk.offsets)
    offsets[:, axis] *= -1.0
    ends = np.array(sk.end_sites)
    ends[:, axis] *= -1.0
    flip = np.ones(sk.n_channels)
    for j in range(sk.n_joints):
        o = int(sk.channel_offsets[j])
        for k, c in enumerate(sk.channels[j]):
            if c.endswith("position") and c[0] == letter:
                flip[o + k] = -1.0
            elif c.endswith("rotation") and c[0] != letter:
                flip[o + k] = -1.0
    new_sk = Skeleton(sk.names, sk.parents, offsets, sk.channels, ends)
    return Motion(new_sk, motion.channels * flip, motion.frame_time, motion.source)
