"""Optical markers made from a skeleton take, as a marker session would record them.

For the evaluation protocol with real-marker input (issue 14): skin markers sit at fixed
offsets from the bones (radial and ulnar styloid and a four-marker cluster on the forearm,
four markers on the back of the hand, the acromion and three more on the shoulder girdle,
carried by the upper arm's parent joint — the clavicle),
are sampled at their own rate, get 1-2 mm of white noise and occlusion gaps.  Names follow
the biomechanics set of :mod:`splicer.marker_roles` with a side prefix and a subject
(``Sim:R_STYLr``).
"""

from __future__ import annotations

import numpy as np

from ..model.kinematics import global_transforms, rest_positions
from ..model.motion import Motion
from ..rig.roles import Roles, find_roles
from ..model.rotations import quat_conj, quat_mul, quat_rotate, quat_slerp, quat_twist
from ..transfer.sampling import resample_motion
from ..io.trajectories import Trajectories

__all__ = ["skin_markers", "add_gaps"]


def _unit(v):
    return v / np.linalg.norm(v)


def _layout(rest: np.ndarray, arm, up: int, girdle: int | None = None) -> dict:
    """Marker name -> (segment joint, rest position), for one arm, at rest (world = joint frames)."""
    w, e = rest[arm.wrist], rest[arm.elbow]
    u = _unit(w - e)
    length = float(np.linalg.norm(w - e))
    bases = {f: rest[ch[0]] for f, ch in arm.fingers.items() if ch}
    radial = bases.get("index", bases.get("thumb"))
    ulnar = bases.get("pinky", bases.get("ring"))
    if radial is not None and ulnar is not None:
        r = radial - ulnar
        width = float(np.linalg.norm(r))
    else:
        r = np.cross(u, np.eye(3)[up])
        width = 0.3 * length
    r = _unit(r - np.dot(r, u) * u)
    n = np.cross(u, r)
    mid = bases.get("middle", w + 0.4 * length * u)
    fa, hand = arm.elbow, arm.wrist
    out = {
        "STYLr": (fa, w - 0.03 * length * u + 0.45 * width * r),
        "STYLu": (fa, w - 0.03 * length * u - 0.45 * width * r),
        "LARMl": (fa, e + 0.55 * length * u + 0.35 * width * r + 0.2 * width * n),
        "LARMm": (fa, e + 0.55 * length * u - 0.35 * width * r + 0.2 * width * n),
        "LARM_elb": (fa, e + 0.2 * length * u + 0.3 * width * n),
        "LARM_ant": (fa, e + 0.7 * length * u - 0.3 * width * n),
        "INDEX": (hand, (radial if radial is not None else mid + 0.4 * width * r) + 0.15 * width * n),
        "LASTC": (hand, (ulnar if ulnar is not None else mid - 0.4 * width * r) + 0.15 * width * n),
        "MEDH": (hand, w + 0.5 * (mid - w) + 0.2 * width * r + 0.2 * width * n),
        "LATH": (hand, w + 0.5 * (mid - w) - 0.3 * width * r + 0.2 * width * n),
    }
    if arm.upper_arm is not None:
        s = rest[arm.upper_arm]
        girdle = arm.upper_arm if girdle is None else girdle  # the acromion moves with the clavicle, not the humerus
        sk_up = np.eye(3)[up]
        out.update({
            "ACRO_tip": (girdle, s + 0.1 * length * sk_up),
            "CLAV_AC": (girdle, s + 0.08 * length * sk_up - 0.1 * length * n),
            "SCAP_AA": (girdle, s + 0.05 * length * sk_up + 0.12 * length * n),
            "SCAPl": (girdle, s - 0.1 * length * sk_up + 0.15 * length * n),
        })
    return out


def add_gaps(points: np.ndarray, fps: float, rng: np.random.Generator, *, per_minute: float = 6.0,
             length_s: tuple[float, float] = (0.05, 1.0)) -> np.ndarray:
    """Occlusions: each marker loses ``Poisson(per_minute * minutes)`` runs of uniform length (seconds).

    Returns a copy of ``points [T, K, 3]`` with NaN in the gaps; the first and last frames may be hit.
    """
    out = np.array(points, dtype=np.float64)
    t, k = out.shape[:2]
    for c in range(k):
        for _ in range(rng.poisson(per_minute * t / fps / 60.0)):
            ln = max(1, int(round(rng.uniform(*length_s) * fps)))
            a = int(rng.integers(0, max(1, t - ln)))
            out[a:a + ln, c] = np.nan
    return out


def skin_markers(motion: Motion, *, rng: np.random.Generator, roles: Roles | None = None, fps: float | None = None,
                 scale: float = 10.0, units: str = "mm", noise_mm: tuple[float, float] = (1.0, 2.0),
                 gaps_per_minute: float = 6.0, gap_s: tuple[float, float] = (0.05, 1.0), subject: str = "Sim",
                 source: str = "markers.c3d") -> Trajectories:
    """Skin markers of both arms of ``motion`` as an optical session would record them.

    Parameters
    ----------
    motion : Motion
        A take with elbows (and ideally finger bases) on the sides to mark.
    rng : np.random.Generator
        Noise, gaps.
    roles : Roles, optional
        Found when omitted.
    fps : float, optional
        Marker rate (the take's by default); row ``k`` is at ``k / fps`` s of the take.
    scale : float
        ``units`` per file unit of the take (10: a take in cm, markers in mm).
    noise_mm : (float, float)
        Each marker's white-noise standard deviation is drawn in this range (in ``units``).
    gaps_per_minute, gap_s
        Occlusions per marker and minute, and their length range in seconds (:func:`add_gaps`).

    Returns
    -------
    Trajectories
        Labels ``"<subject>:R_STYLr"`` etc.; ``first_frame`` 1; z up (the take's up axis
        relabelled cyclically), as optical systems record.
    """
    r = roles if roles is not None else find_roles(motion.skeleton, source=motion.source)
    fps = float(fps or motion.fps)
    if abs(fps - motion.fps) > 1e-9:
        n_out = int(np.floor((motion.n_frames - 1) / motion.fps * fps + 1e-9)) + 1
        motion = resample_motion(motion, np.arange(n_out) * motion.fps / fps, 1.0 / fps)
    rest = rest_positions(motion.skeleton)
    labels, cols = [], []
    for side, arm in sorted(r.sides.items()):
        if arm.elbow is None:
            continue
        prefix = "R_" if side == "right" else "L_"
        parent = int(motion.skeleton.parents[arm.upper_arm]) if arm.upper_arm is not None else -1
        layout = _layout(rest, arm, r.up, parent if parent >= 0 else None)
        joints = sorted({j for j, _ in layout.values()} | {arm.wrist})
        rot, pos = global_transforms(motion, joints)
        # forearm markers pronate with the radius: they take the wrist's twist about the forearm axis
        # (a skeleton without twist bones keeps it in the wrist joint), in proportion to their
        # distance along the forearm (1 at the styloids)
        ke, kw = joints.index(arm.elbow), joints.index(arm.wrist)
        axis = _unit(rest[arm.wrist] - rest[arm.elbow])  # in the elbow's frame (joint frames are world at rest)
        twist = quat_twist(quat_mul(quat_conj(rot[:, ke]), rot[:, kw]), axis)
        length = float(np.linalg.norm(rest[arm.wrist] - rest[arm.elbow]))
        for name, (j, p_rest) in layout.items():
            k = joints.index(j)
            local = np.broadcast_to(p_rest - rest[j], (motion.n_frames, 3))
            if j == arm.elbow:
                frac = float(np.clip(np.dot(p_rest - rest[j], axis) / length, 0.0, 1.0))
                q = quat_slerp(np.broadcast_to([1.0, 0, 0, 0], twist.shape), twist, np.full(len(twist), frac))
                local = quat_rotate(q, local)
            cols.append(pos[:, k] + quat_rotate(rot[:, k], local))
            labels.append(f"{subject}:{prefix}{name}")
    pts = np.stack(cols, axis=1) * scale
    shift = (2 - r.up) % 3  # axes relabelled cyclically (a proper rotation): the take's up becomes +z, as in a lab
    pts = pts[..., [(k - shift) % 3 for k in range(3)]]
    sigma = rng.uniform(*noise_mm, size=len(labels))
    pts = pts + rng.normal(0.0, 1.0, pts.shape) * sigma[None, :, None]
    pts = add_gaps(pts, fps, rng, per_minute=gaps_per_minute, length_s=gap_s)
    return Trajectories(tuple(labels), pts, fps, 1, units, source)
