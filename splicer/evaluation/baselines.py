"""Alignments to compare the splice against (ALGORITHM.md section 8).

Each baseline returns, for one side, the (fractional, 0-based) hands-file frame used for
every body frame — the same quantity as ``SpliceResult.sides[side].hands_frame`` — so that
:mod:`splicer.evaluate` scores every method alike.  The finger rotations of a baseline are
the hands' finger rotations sampled at those frames by slerp (:func:`finger_rotations`), as
the splice's time-map merge does.

* :func:`oracle_frames`: the true time map (the best any method can do).
* :func:`uniform_frames`: uniform time scaling, first frame to first frame, last to last.
* :func:`generic_dtw_frames`: what a user would do without this package: shoulder-relative
  wrist and hand marker positions in the root's frame, the hands resampled to the body rate,
  each channel z-normalised per sequence, multivariate DTW from dtaidistance (full, or a
  Sakoe-Chiba window), the per-body-frame median of the path.
"""

from __future__ import annotations

import numpy as np

from ..align.passes import path_median
from ..errors import SplicerError
from ..model.kinematics import global_transforms
from ..rig.markers import arm_markers
from ..model.motion import Motion
from ..rig.roles import ArmRoles
from ..model.rotations import quat_conj, quat_rotate
from ..transfer.sampling import sample_linear, sample_rotations

__all__ = ["oracle_frames", "uniform_frames", "root_frame_hand_positions", "generic_dtw_frames",
           "finger_rotations", "flat_rotations"]

#: Markers used by the generic DTW: p1, p2 (wrist, radial and ulnar) and p4 (hand).
_WRIST_HAND = [0, 1, 3]


def oracle_frames(truth: np.ndarray) -> np.ndarray:
    """The true hands frame of every body frame (a copy of ``truth``), shape (n_body,)."""
    return np.array(truth, dtype=np.float64)


def uniform_frames(n_body: int, n_hands: int) -> np.ndarray:
    """Uniform time scaling: body frame ``i`` -> hands frame ``i (m - 1) / (n - 1)``, shape (n_body,)."""
    if n_body < 2:
        return np.zeros(n_body)
    return np.arange(n_body, dtype=np.float64) * ((n_hands - 1) / (n_body - 1))


def root_frame_hand_positions(motion: Motion, arm: ArmRoles, up: int) -> np.ndarray:
    """Shoulder-relative wrist and hand marker positions in the root joint's frame.

    Returns
    -------
    np.ndarray [shape=(T, 9), dtype=float64]
        ``p1, p2, p4`` (see :mod:`splicer.markers`) minus the shoulder, rotated by the inverse
        of the root's world rotation; file units.
    """
    mk = arm_markers(motion, arm, up)
    rel = mk.relative()[:, _WRIST_HAND]
    root_q, _ = global_transforms(motion, [0])
    local = quat_rotate(quat_conj(root_q[:, 0])[:, None, :], rel)
    return local.reshape(motion.n_frames, -1)


def _znorm(x: np.ndarray) -> np.ndarray:
    sd = x.std(axis=0)
    return (x - x.mean(axis=0)) / np.where(sd > 0, sd, 1.0)


def generic_dtw_frames(body: Motion, hands: Motion, body_arm: ArmRoles, hands_arm: ArmRoles, up: int, *,
                       window: int | None = None, open_ends: bool = False) -> np.ndarray:
    """Generic multivariate DTW (dtaidistance) on hand positions in the root frame.

    Parameters
    ----------
    body, hands : Motion
    body_arm, hands_arm : ArmRoles
        The side's joints in each skeleton.
    up : int
        Vertical axis (both files).
    window : int, optional
        Sakoe-Chiba window in body-rate frames (dtaidistance's ``window``: ``|i - j|`` up to
        ``window`` plus the length difference); full DTW when None.

    Returns
    -------
    np.ndarray [shape=(n_body,), dtype=float64]
        Hands-file frame (fractional) for each body frame.

    Notes
    -----
    O(n * m) time and memory with the full matrix (dtaidistance's C path keeps the window;
    with ``open_ends`` the full cost matrix is kept, n * m doubles).
    """
    try:
        from dtaidistance import dtw, dtw_ndim
    except ImportError:
        raise SplicerError("the generic-DTW baseline uses dtaidistance, as a user would: "
                           "pip install -e '.[bench]' (or '.[test]')") from None

    ratio = hands.fps / body.fps
    xb = root_frame_hand_positions(body, body_arm, up)
    xh_full = root_frame_hand_positions(hands, hands_arm, up)
    m = int(np.floor((hands.n_frames - 1) / ratio + 1e-9)) + 1
    xh = sample_linear(xh_full, np.arange(m) * ratio)
    s1 = np.ascontiguousarray(_znorm(xb))
    s2 = np.ascontiguousarray(_znorm(xh))
    kwargs = {"use_c": bool(dtw.try_import_c(verbose=False))}
    if window is not None:
        kwargs["window"] = int(window)
    if open_ends:
        _, paths = dtw_ndim.warping_paths(s1, s2, psi=(0, 0, len(s2), len(s2)), psi_neg=False, **kwargs)
        # end at the cheapest cell of the last body row (dtaidistance's own choice of the end
        # can drop the last body row when it marks the relaxed cells with -1)
        col = 1 + int(np.argmin(paths[-1, 1:]))
        path = np.asarray(dtw.best_path(paths, row=paths.shape[0] - 1, col=col), dtype=np.int64)
    else:
        path = np.asarray(dtw_ndim.warping_path(s1, s2, **kwargs), dtype=np.int64)
    per_frame = path_median(path, body.n_frames)
    return np.clip(per_frame * ratio, 0.0, hands.n_frames - 1)


def finger_rotations(hands_q: np.ndarray, hands_frames: np.ndarray) -> np.ndarray:
    """Finger rotations at fractional hands frames, by slerp.

    Parameters
    ----------
    hands_q : np.ndarray [shape=(m, K, 4)]
        Local rotations of K joints of the hands capture.
    hands_frames : np.ndarray [shape=(n,)]

    Returns
    -------
    np.ndarray [shape=(n, K, 4)]
    """
    return sample_rotations(hands_q, hands_frames)


def flat_rotations(n: int, k: int) -> np.ndarray:
    """Identity rotations (fingers flat, the body capture unchanged), shape (n, k, 4)."""
    q = np.zeros((n, k, 4))
    q[..., 0] = 1.0
    return q
