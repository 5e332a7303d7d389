"""Rigid segments fitted to marker clusters, and the paper's markers derived from them.

A real marker pipeline does not use single skin markers: it fits each segment as a rigid body
to its cluster every frame (least squares, Kabsch / Soederkvist-Wedin), which averages the
noise of the cluster's markers, and places anatomical points in the segment frames:

* the hand segment from the hand markers (``INDEX``, ``LASTC``, ``MEDH``, ``LATH``...);
* the forearm segment from the forearm cluster and the styloids;
* the shoulder girdle from the acromion cluster (when it has three markers or more);
* the wrist joint centre: the point fixed in both the hand and the forearm frames (SCoRE,
  Ehrig et al. 2006, least squares over the take), pulled weakly towards the mid-styloid
  point so that a take with little wrist motion still has a well-posed answer;
* ``p1``, ``p2``: the wrist centre plus or minus half the radial-ulnar (styloid) vector,
  the vector carried by the HAND frame (its direction in the hand frame at the mean wrist
  posture, its length the styloid distance), so the wrist markers follow wrist flexion as the
  virtual ``p1``, ``p2`` do (ALGORITHM.md section 1);
* ``p3``: the forearm role markers' place in the forearm frame; ``p4``: the hand role
  markers' place in the hand frame; the shoulder: its role markers' place in the girdle
  frame.

The reference shape of a cluster (its markers in the segment's own frame) is the generalised
Procrustes mean over the take (:func:`cluster_shape`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gapfill import rigid_transform

__all__ = ["SegmentFit", "cluster_shape", "fit_segment", "joint_centre", "rigid_markers"]

#: Weight of the mid-styloid prior in the wrist-centre least squares (per frame, relative to the SCoRE rows).
STYLOID_PRIOR = 0.05


@dataclass(frozen=True, eq=False)
class SegmentFit:
    """One segment fitted to its cluster in every frame.

    Attributes
    ----------
    shape : np.ndarray [shape=(K, 3)]
        The cluster's markers in the segment frame (centred on their mean), file units.
    rotation : np.ndarray [shape=(T, 3, 3)]
        Segment frame -> world.
    origin : np.ndarray [shape=(T, 3)]
        The cluster's centre in the world, file units.
    rms : float
        Root-mean-square distance of the markers from the fitted shape, file units.
    """

    shape: np.ndarray
    rotation: np.ndarray
    origin: np.ndarray
    rms: float

    def world(self, local: np.ndarray) -> np.ndarray:
        """Points fixed in the segment frame, in the world: ``local`` (3,) -> (T, 3)."""
        return np.einsum("tij,j->ti", self.rotation, np.asarray(local, dtype=np.float64)) + self.origin

    def local(self, world: np.ndarray) -> np.ndarray:
        """World points (T, 3) in the segment frame of each frame, (T, 3)."""
        return np.einsum("tji,tj->ti", self.rotation, np.asarray(world, dtype=np.float64) - self.origin)


def cluster_shape(points: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Generalised Procrustes mean shape of a marker cluster.

    Parameters
    ----------
    points : np.ndarray [shape=(T, K, 3)]
        ``K >= 3`` markers, complete (gaps filled).
    iterations : int
        Rounds of fitting every frame to the shape and averaging the frames brought back.

    Returns
    -------
    np.ndarray [shape=(K, 3)]
        Centred on its mean; in the orientation of the first frame.
    """
    pts = np.asarray(points, dtype=np.float64)
    ref = pts[0] - pts[0].mean(axis=0)
    for _ in range(iterations):
        r, _ = rigid_transform(ref, pts)
        centred = pts - pts.mean(axis=1, keepdims=True)
        back = np.einsum("tji,tkj->tki", r, centred)  # R^T (p - c)
        ref = back.mean(axis=0)
        ref -= ref.mean(axis=0)
    return ref


def fit_segment(points: np.ndarray) -> SegmentFit:
    """Fit a rigid segment to a complete marker cluster in every frame.

    Parameters
    ----------
    points : np.ndarray [shape=(T, K, 3)]
        ``K >= 3`` markers, not collinear, no missing samples.

    Returns
    -------
    SegmentFit
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 3 or pts.shape[1] < 3 or pts.shape[2] != 3:
        raise ValueError(f"a segment needs (T, K>=3, 3) points, not {pts.shape}")
    if not np.isfinite(pts).all():
        raise ValueError("a segment fit needs complete markers (fill the gaps first)")
    shape = cluster_shape(pts)
    r, t = rigid_transform(shape, pts)
    fitted = np.einsum("tij,kj->tki", r, shape) + t[:, None, :]
    rms = float(np.sqrt(np.mean(np.sum((fitted - pts) ** 2, axis=-1))))
    return SegmentFit(shape, r, t, rms)


def joint_centre(a: SegmentFit, b: SegmentFit, prior_in_a: np.ndarray | None = None,
                 prior_weight: float = STYLOID_PRIOR) -> tuple[np.ndarray, np.ndarray]:
    """The point fixed in both segments' frames (SCoRE): least squares over the take.

    Minimises ``sum_t |R_a c_a + o_a - R_b c_b - o_b|^2 + w^2 T |c_a - prior|^2`` over the local
    points ``c_a``, ``c_b``.

    Parameters
    ----------
    a, b : SegmentFit
        The two segments, same frames.
    prior_in_a : np.ndarray [shape=(3,)], optional
        A guess of the centre in ``a``'s frame (e.g. the mid-styloid point); keeps the problem
        well posed when the joint hardly moves.
    prior_weight : float
        ``w`` above.

    Returns
    -------
    (c_a, c_b) : np.ndarray [shape=(3,)] each
        The centre in each segment's frame.
    """
    n = a.rotation.shape[0]
    rows = np.concatenate([a.rotation, -b.rotation], axis=2).reshape(3 * n, 6)
    rhs = (b.origin - a.origin).reshape(3 * n)
    if prior_in_a is not None and prior_weight > 0:
        w = prior_weight * np.sqrt(n)
        rows = np.concatenate([rows, np.hstack([w * np.eye(3), np.zeros((3, 3))])])
        rhs = np.concatenate([rhs, w * np.asarray(prior_in_a, dtype=np.float64)])
    sol, *_ = np.linalg.lstsq(rows, rhs, rcond=None)
    return sol[:3], sol[3:]


def rigid_markers(points: np.ndarray, roles: dict, segments: dict) -> tuple[dict, tuple] | None:
    """The paper's markers from rigid segment fits (see the module docstring).

    Parameters
    ----------
    points : np.ndarray [shape=(T, K, 3)]
        All markers; the role and segment columns used are complete.
    roles : dict of str to tuple of int
        ``p1``, ``p2``, ``p3``, ``p4``, ``shoulder`` -> columns.
    segments : dict of str to tuple of int
        ``hand``, ``forearm`` (and ``shoulder``) -> columns.

    Returns
    -------
    (dict of str to np.ndarray [shape=(T, 3)], tuple of str) or None
        Role -> position, and notes; None when the hand or the forearm has fewer than three markers
        (besides the wrist markers, for the hand), or when a role marker is not in its segment.
    """
    wrist = set(roles["p1"]) | set(roles["p2"])
    hand = [c for c in segments.get("hand", ()) if c not in wrist]
    forearm = list(dict.fromkeys(list(segments.get("forearm", ())) + sorted(wrist)))
    if len(hand) < 3 or len(forearm) < 3 or not set(roles["p4"]) <= set(hand) or not set(roles["p3"]) <= set(forearm):
        return None
    usable = [c for c in hand + forearm if np.isfinite(points[:, c]).all()]
    if len(usable) < len(hand) + len(forearm):
        return None
    fh, ff = fit_segment(points[:, hand]), fit_segment(points[:, forearm])

    def place(fit: SegmentFit, cols: list, which) -> np.ndarray:
        return fit.world(np.mean([fit.shape[cols.index(c)] for c in which], axis=0))

    p1_f = np.mean([ff.shape[forearm.index(c)] for c in roles["p1"]], axis=0)
    p2_f = np.mean([ff.shape[forearm.index(c)] for c in roles["p2"]], axis=0)
    c_f, _ = joint_centre(ff, fh, prior_in_a=0.5 * (p1_f + p2_f))
    centre_f = ff.world(c_f)
    c_h = fh.local(centre_f).mean(axis=0)
    centre = 0.5 * (centre_f + fh.world(c_h))
    # the radial-ulnar vector (styloid to styloid), carried by the hand
    # the radial-ulnar (styloid) vector in the hand frame at the mean wrist posture, at its own length
    across_h = np.einsum("tji,tj->ti", fh.rotation, ff.world(p1_f) - ff.world(p2_f)).mean(axis=0)
    across_h *= np.linalg.norm(p1_f - p2_f) / max(float(np.linalg.norm(across_h)), 1e-12)

    across = np.einsum("tij,j->ti", fh.rotation, across_h)
    out = {"p1": centre + 0.5 * across, "p2": centre - 0.5 * across,
           "p3": place(ff, forearm, roles["p3"]), "p4": place(fh, hand, roles["p4"])}
    notes = [f"hand fit rms {fh.rms:.2f}, forearm fit rms {ff.rms:.2f}"]
    girdle = [c for c in segments.get("shoulder", ()) if np.isfinite(points[:, c]).all()]
    if len(girdle) >= 3 and set(roles["shoulder"]) <= set(girdle):
        fs = fit_segment(points[:, girdle])
        out["shoulder"] = place(fs, girdle, roles["shoulder"])
    else:
        out["shoulder"] = points[:, list(roles["shoulder"])].mean(axis=1)
    return out, tuple(notes)
