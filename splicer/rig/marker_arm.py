"""One side's paper markers from real optical trajectories: roles, gap filling, rigid segments.

:func:`arm_from_trajectories` finds the roles (:mod:`splicer.rig.marker_roles`), fills the gaps
of every role and segment marker (:mod:`splicer.rig.gapfill`), then derives ``p1..p4`` and the
shoulder from rigid segment fits (:mod:`splicer.rig.segment_fit`) when the set has a hand and a
forearm cluster of three markers or more, else by averaging each role's markers.
:func:`on_frames` brings them onto the frames of the take solved from them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import RoleError
from ..io.trajectories import Trajectories
from .gapfill import GapFill, fill_gaps
from .marker_roles import MarkerRoles, _parse_up, detect_marker_up, find_marker_roles
from .marker_noise import marker_noise, noise_markers, role_noise
from .markers import Markers
from .segment_fit import rigid_markers

__all__ = ["MarkerArm", "arm_from_trajectories", "on_frames"]


def _upright(points: np.ndarray, axis: int, sign: float) -> np.ndarray:
    """Points turned (a proper rotation) so that ``sign * axis`` points along ``+axis``."""
    if sign > 0:
        return points
    out = np.array(points)
    out[..., axis] *= -1.0
    out[..., (axis + 1) % 3] *= -1.0  # a half turn about the third axis
    return out


@dataclass(frozen=True, eq=False)
class MarkerArm:
    """One side's real markers, ready for the alignment.

    Attributes
    ----------
    markers : Markers
        ``p1..p4`` and the shoulder at the file's rate, every gap filled, vertical along ``up``.
    roles : MarkerRoles
    gaps : GapFill
        The filled ranges (and the filled trajectories).
    notes : tuple of str
        Warnings for the report (long gaps, the side guessed, the up axis chosen).
    derivation : str
        ``"rigid segments"`` (:func:`splicer.rig.segment_fit.rigid_markers`) or ``"role averages"``
        (each role's markers averaged).
    noise : dict
        ``"p1".."p4"``, ``"shoulder"`` -> the white noise of that point, file units
        (:func:`splicer.rig.marker_noise.role_noise` of the role's markers, averaged); with rigid
        segments the same figure, an approximation (the fit spreads the markers' noise otherwise).
    """

    markers: Markers
    roles: MarkerRoles
    gaps: GapFill
    notes: tuple
    derivation: str = "role averages"
    noise: dict = field(default_factory=dict)

    def noise_sample(self, seed: int = 0) -> Markers | None:
        """A draw of white noise like this arm's (:attr:`noise`), shaped and timed as :attr:`markers`;
        None when the noise is not known.  Carry it through the markers' own resampling."""
        if not self.noise:
            return None
        m = self.markers
        pts, sh = noise_markers(self.noise, m.n_frames, seed=seed)
        return Markers(pts, sh, np.zeros(m.n_frames), m.up, m.fps, m.side)

    def report(self, traj: Trajectories) -> dict:
        """JSON-ready summary: file, rate, set, role labels, up axis, filled ranges, each point's noise (file units)."""
        return {"path": traj.source, "frames": traj.n_frames, "fps": traj.fps, "first_frame": traj.first_frame,
                "units": traj.units, "marker_set": self.roles.marker_set, "roles": self.roles.labels(traj),
                "derivation": self.derivation, "gaps_filled": [f.to_dict() for f in self.gaps.fills],
                "noise": {r: round(v, 3) for r, v in self.noise.items() if np.isfinite(v)}}


def arm_from_trajectories(traj: Trajectories, side: str, *, mapping: dict | None = None,
                          max_gap_s: float = 0.5, rigid: bool = False) -> MarkerArm:
    """One side's four markers and shoulder from real trajectories: roles, gap filling, segments.

    Parameters
    ----------
    traj : Trajectories
    side : {"left", "right"}
    mapping : dict, optional
        The constraints file's ``markers: <take>:`` entry (roles per side, ``up``, ``derive``:
        ``rigid`` or ``averages``, which wins over ``rigid``).
    max_gap_s : float
        Gaps longer than this (seconds) are reported (:mod:`splicer.rig.gapfill`).
    rigid : bool
        Derive the markers from rigid segment fits where the set allows (the module docstring);
        False: average each role's markers.

    Returns
    -------
    MarkerArm
        ``markers.heading`` is zero (real markers carry no root); use ``theta="window"``.

    Raises
    ------
    RoleError
        A role missing (naming the labels found) or a role marker never seen.
    """
    roles = find_marker_roles(traj, side, mapping=mapping)
    derive = str((mapping or {}).get("derive", "rigid" if rigid else "averages"))
    if derive not in ("rigid", "averages"):
        raise RoleError(f"constraints file, markers: derive must be rigid or averages, not {derive!r}")
    rigid = derive == "rigid"
    notes = []
    if not roles.sided:
        notes.append(f"{traj.source}: the marker names tell no side; taken as the {side} arm")
    role_cols = sorted({c for cols in roles.roles.values() for c in cols})
    seg_cols = sorted({c for cols in roles.segments.values() for c in cols}) if rigid else []
    gaps = fill_gaps(traj, roles.segments, columns=sorted(set(role_cols) | set(seg_cols)), max_gap_s=max_gap_s)
    long = [f for f in gaps.fills if f.too_long]
    notes += [w for w in gaps.warnings if "never seen" in w]
    if len(long) <= 3:
        notes += [w for w in gaps.warnings if "never seen" not in w]
    else:
        worst = max(long, key=lambda f: f.stop - f.start)
        notes.append(f"{traj.source}: {len(long)} gaps of the {side} arm's markers are longer than the {max_gap_s:g} s "
                     f"limit (longest {worst.describe()}); see gaps_filled (too_long) in the report")
    filled = gaps.trajectories.points
    never = [traj.labels[c] for c in role_cols if np.isnan(filled[:, c]).all()]
    if never:
        raise RoleError(f"{traj.source}: marker(s) {', '.join(never)} never seen; name others under 'markers:'")
    fitted = rigid_markers(filled, roles.roles, roles.segments) if rigid else None
    noise = role_noise(marker_noise(traj.points), roles.roles)  # as recorded: gaps are left out
    if fitted is not None:
        by_role, derivation = fitted[0], "rigid segments"
    else:
        by_role = {r: filled[:, list(cols)].mean(axis=1) for r, cols in roles.roles.items()}
        derivation = "role averages"
    points = np.stack([by_role[r] for r in ("p1", "p2", "p3", "p4")], axis=1)
    shoulder = by_role["shoulder"]
    up_spec = (mapping or {}).get("up")
    if up_spec is not None:
        axis, sign = _parse_up(up_spec)
    else:
        axis, sign, how = detect_marker_up(traj)
        if "convention" in how:
            notes.append(f"{traj.source}: vertical axis taken as {'-' if sign < 0 else '+'}{'xyz'[axis]} "
                         f"(from {how}); set 'markers: up:' in the constraints file if wrong")
    points, shoulder = _upright(points, axis, sign), _upright(shoulder, axis, sign)
    mk = Markers(points, shoulder, np.zeros(traj.n_frames), axis, traj.fps, side)
    return MarkerArm(mk, roles, gaps, tuple(notes), derivation, noise)


def on_frames(markers: Markers, n_frames: int, fps: float, *, what: str = "markers") -> tuple[Markers, tuple]:
    """Markers brought onto the frames of the take solved from them (e.g. its BVH).

    The marker file and the take share a timeline: marker row 0 and take frame 0 are the
    same instant, each file at its own rate.  Take frame ``i`` (at ``i / fps`` s) gets the
    markers at ``i / fps`` s (linear; Gaussian anti-aliasing when the rate goes down).

    Returns
    -------
    (Markers, notes)
        ``n_frames`` frames at ``fps``; a take longer than the markers holds their last
        sample (reported in ``notes`` when the durations differ by more than a frame).
    """
    from ..align.passes import resample_markers

    notes = []
    dur_m, dur_t = (markers.n_frames - 1) / markers.fps, (n_frames - 1) / fps
    if abs(dur_m - dur_t) > 1.0 / min(fps, markers.fps):
        notes.append(f"{what}: the markers last {dur_m:.2f} s but the take {dur_t:.2f} s; they are taken to start "
                     "together" + (" (the markers' last sample is held)" if dur_t > dur_m else ""))
    mk = resample_markers(markers, fps)
    if mk.n_frames >= n_frames:
        idx = np.arange(n_frames)
    else:
        idx = np.minimum(np.arange(n_frames), mk.n_frames - 1)
    return Markers(mk.points[idx], mk.shoulder[idx], mk.heading[idx], mk.up, fps, mk.side), tuple(notes)
