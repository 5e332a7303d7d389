"""Slow plain references of the metric kernels (the tests compare the numba kernels with these)."""

from __future__ import annotations

import numpy as np

from splicer.align.costs import PalmFeatures, PhaseFeatures, horizontal_axes, kgp_theta

def d1_reference(body: PhaseFeatures, hands: PhaseFeatures, i: int, j: int, theta: str = "window") -> float:
    """D1 of one cell, written plainly with numpy (for tests)."""
    if theta == "window":
        th = kgp_theta(body.window[i], hands.window[j])
    else:
        th = body.heading[i] - hands.heading[j]
    up = body.up
    a, b = horizontal_axes(up)
    R = np.eye(3)
    R[a, a], R[a, b], R[b, a], R[b, b] = np.cos(th), -np.sin(th), np.sin(th), np.cos(th)

    def sgn(x, eps, ramp):
        # 0 inside the dead zone, then a linear rise to +-1 over ``ramp`` (a step when ramp == 0)
        mag = np.clip((np.abs(x) - eps) / ramp, 0.0, 1.0) if ramp > 0 else (np.abs(x) > eps).astype(float)
        return np.sign(x) * mag

    vh = hands.vel[j] @ R.T
    ah = hands.acc[j] @ R.T
    return float(np.sum((sgn(body.vel[i], body.eps_vel, body.ramp_vel) - sgn(vh, hands.eps_vel, hands.ramp_vel)) ** 2)
                 + np.sum((sgn(body.acc[i], body.eps_acc, body.ramp_acc) - sgn(ah, hands.eps_acc, hands.ramp_acc)) ** 2))


def d2_reference(body: PalmFeatures, hands: PalmFeatures, i: int, j: int) -> float:
    """D2 of one cell via scipy rotations (for tests)."""
    from scipy.spatial.transform import Rotation

    f, h, g, k = body.forearm[i], body.hand[i], hands.forearm[j], hands.hand[j]
    axis = np.cross(g, f)
    s = np.linalg.norm(axis)
    ang = np.arctan2(s, np.dot(g, f))
    rot = Rotation.from_rotvec(axis / s * ang) if s > 1e-15 else Rotation.identity()
    rk = rot.apply(k)
    return float(np.arccos(np.clip(np.dot(h, rk) / np.linalg.norm(rk), -1, 1)))


def position_reference(body: PhaseFeatures, hands: PhaseFeatures, i: int, j: int) -> float:
    """The position term of one cell: the mean squared difference of the two frames' features."""
    return float(np.mean((body.position[i] - hands.position[j]) ** 2))


def sgn_branching(x: float, eps: float, ramp: float) -> float:
    """The dead-zoned sign of D1 as first written, with branches (the kernel's select form must
    give these values bit for bit)."""
    if x > eps:
        if ramp > 0.0 and x < eps + ramp:
            return (x - eps) / ramp
        return 1.0
    if x < -eps:
        if ramp > 0.0 and x > -eps - ramp:
            return (x + eps) / ramp
        return -1.0
    return 0.0
