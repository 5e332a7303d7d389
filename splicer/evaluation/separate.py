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

The hands capture in hand-only forms (wrist- or forearm-rooted, mirrored):
:mod:`splicer.evaluation.handforms`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.motion import Motion, Skeleton
from ..rig.roles import Roles, find_roles
from ..model.rotations import quat_angle_deg, quat_hemisphere, quat_mul, quat_normalize, quat_slerp, yaw_quat_deg
from ..transfer.sampling import resample_motion
# the hand-only forms, re-exported: they were defined here before the split
from .handforms import forearm_rooted, hand_only_files, mirror_motion, wrist_rooted  # noqa: F401
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
