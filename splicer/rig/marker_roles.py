"""The paper's four markers and the shoulder, found among real optical markers by name.

Roles per side (ALGORITHM.md section 1): ``p1``, ``p2`` the two wrist markers (radial,
ulnar), ``p3`` the forearm, ``p4`` the hand, and the ``shoulder``.  Known marker sets, in
the order they are tried:

==================  ==============  ==============  ==========================  ===========================  ================
set                 p1              p2              p3                          p4                           shoulder
==================  ==============  ==============  ==========================  ===========================  ================
Plug-in Gait        RWRA            RWRB            RFRM                        RFIN                         RSHO
biomechanics        STYLr (RS)      STYLu (US)      LARMl LARMm LARM_elb        INDEX LASTC (averaged:       ACRO_tip CLAV_AC
                                                    LARM_ant (averaged)         the middle finger's base;    SCAP_AA (averaged;
                                                                                or MCP2 MCP5, MEDH LATH)     or ACRO)
OptiTrack/Qualisys  RWristOut       RWristIn        RForeArm (RFArm, RForearm)  RHandOut RHandIn (averaged)  RShoulderTop
==================  ==============  ==============  ==========================  ===========================  ================

Sides: Plug-in Gait names carry an ``R``/``L`` prefix; the other sets may carry ``R``,
``R_``, ``Right``, ``Right_`` (or a ``_R``, ``_Right``, ``.R`` suffix), or no side at all (as
the one-arm capture ``markers_analogs.c3d``; such markers serve whichever side is asked).
Subject prefixes (``Daphnee:``) and case are ignored.  Several markers in one role (a
cluster) are averaged after gap filling (or fitted as rigid segments with ``derive: rigid``,
:mod:`splicer.rig.marker_arm`).  ``p4`` is the midpoint of the index and little-finger
knuckle markers where a set has them — the base of the middle finger, as the virtual ``p4``
(ALGORITHM.md section 1); it aligned better than the centroid of all four hand markers on
the evaluation protocol (0.08 body frames less mean error, seeds 100-101).  The other hand
markers serve as rigid-fill donors.  The ``shoulder`` is the mean of the markers around the
acromioclavicular joint that the set has (acromion tip, AC joint, acromial angle): every other
marker is taken relative to it, so its noise enters all twelve coordinates of D1 at once, and
three markers carry 1/sqrt(3) of one's (on the protocol's C3D markers, tuning seeds 0-4: 0.575
-> 0.533 body frames of mean error; 0.498 either way without noise).

The constraints file overrides any role, per take and side, and may state the up axis::

    markers:
      hands:
        up: z                       # x, y, z, or -x, -y, -z; detected when omitted
        derive: averages            # or rigid: p1..p4 and the shoulder from rigid segment fits
        right: {p1: STYLr, p2: STYLu, p3: [LARMl, LARMm], p4: INDEX, shoulder: ACRO_tip}
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RoleError
from ..io.trajectories import Trajectories

__all__ = ["MARKER_ROLES", "MARKER_SETS", "MarkerRoles", "find_marker_roles", "marker_sides", "detect_marker_up",
           "FORMAT_UP"]

MARKER_ROLES = ("p1", "p2", "p3", "p4", "shoulder")

#: name -> (roles: role -> alternatives (each a cluster of base names), segments: name -> base names,
#: sides: "prefix" (R/L prefix only) or "any" (prefixes, suffixes or none))
MARKER_SETS = {
    "Plug-in Gait": (
        {"p1": [("WRA",)], "p2": [("WRB",)], "p3": [("FRM",)], "p4": [("FIN",)], "shoulder": [("SHO",)]},
        {"forearm": ("WRA", "WRB", "FRM"), "hand": ("FIN", "WRA", "WRB")},
        "prefix"),
    "biomechanics": (
        {"p1": [("STYLr",), ("RS",), ("RSP",)], "p2": [("STYLu",), ("US",), ("USP",)],
         "p3": [("LARMl", "LARMm", "LARM_elb", "LARM_ant"), ("FA1", "FA2", "FA3", "FA4"), ("FARM",)],
         "p4": [("INDEX", "LASTC"), ("MCP2", "MCP5"), ("MEDH", "LATH"), ("HAND",)],
         "shoulder": [("ACRO_tip", "CLAV_AC", "SCAP_AA"), ("ACRO",), ("AC",)]},
        {"forearm": ("STYLr", "STYLr_up", "STYLu", "LARMl", "LARMm", "LARM_elb", "LARM_ant", "RS", "US",
                     "FA1", "FA2", "FA3", "FA4"),
         "hand": ("INDEX", "LASTC", "MEDH", "LATH", "MCP2", "MCP5"),
         "shoulder": ("ACRO_tip", "ACRO", "AC", "CLAV_AC", "SCAP_AA", "SCAPl", "SCAPm", "SCAP_CP")},
        "any"),
    "OptiTrack/Qualisys": (
        {"p1": [("WristOut",)], "p2": [("WristIn",)], "p3": [("ForeArm",), ("FArm",), ("ForearmOut",)],
         "p4": [("HandOut", "HandIn"), ("Hand",)], "shoulder": [("ShoulderTop",), ("Shoulder",)]},
        {"forearm": ("WristOut", "WristIn", "ForeArm", "FArm", "ForearmOut", "ElbowIn"),
         "hand": ("HandOut", "HandIn", "WristOut", "WristIn")},
        "any"),
}

_SIDE_WORDS = {"right": ("R", "Right"), "left": ("L", "Left")}


def _variants(base: str, side: str, style: str) -> list[str]:
    """Spellings of ``base`` on ``side`` (lower case); the unsided spelling last."""
    out = []
    for w in _SIDE_WORDS[side]:
        out += [w + base, w + "_" + base]
        if style == "any":
            out += [base + "_" + w, base + "." + w]
    if style == "prefix":
        out = [w + base for w in _SIDE_WORDS[side][:1]]
    return [s.lower() for s in out]


@dataclass(frozen=True)
class MarkerRoles:
    """Which marker columns play each role on one side.

    Attributes
    ----------
    side : str
    roles : dict of str to tuple of int
        Role -> columns (averaged when several).
    segments : dict of str to tuple of int
        Rigid segments for gap filling.
    marker_set : str
        The set recognised (or ``"constraints file"``).
    sided : bool
        False when the names say no side (the markers were taken for ``side``).
    """

    side: str
    roles: dict
    segments: dict
    marker_set: str
    sided: bool

    def labels(self, traj: Trajectories) -> dict:
        """Role -> marker labels, for messages and reports."""
        return {r: [traj.labels[c] for c in cols] for r, cols in self.roles.items()}


def _lookup(traj: Trajectories) -> dict:
    seen = ~traj.missing
    out = {}
    for k, name in enumerate(traj.names):
        if seen[:, k].any():
            out.setdefault(name.lower(), k)
    return out


def _match(names: dict, base: str, side: str, style: str, allow_unsided: bool) -> tuple[int | None, bool]:
    for v in _variants(base, side, style):
        if v in names:
            return names[v], True
    if allow_unsided and style == "any" and base.lower() in names:
        return names[base.lower()], False
    return None, False


def _try_set(traj: Trajectories, names: dict, set_name: str, side: str, allow_unsided: bool):
    roles_spec, seg_spec, style = MARKER_SETS[set_name]
    roles, sided = {}, set()
    for role, alternatives in roles_spec.items():
        for cluster in alternatives:
            found = [_match(names, b, side, style, allow_unsided) for b in cluster]
            cols = tuple(c for c, _ in found if c is not None)
            if cols:
                roles[role] = cols
                sided.update(s for c, s in found if c is not None)
                break
    segments = {}
    for seg, bases in seg_spec.items():
        cols = tuple(dict.fromkeys(c for c, _ in (_match(names, b, side, style, allow_unsided) for b in bases)
                                   if c is not None))
        if cols:
            segments[seg] = cols
    return roles, segments, (True in sided)


def _columns(traj: Trajectories, names: dict, value, where: str) -> tuple:
    items = value if isinstance(value, (list, tuple)) else [value]
    cols = []
    for item in items:
        k = traj.index(str(item))
        if k is None:
            raise RoleError(f"{where}: marker {item!r} is not in {traj.source} (labels: {', '.join(traj.labels)})")
        cols.append(k)
    return tuple(cols)


def find_marker_roles(traj: Trajectories, side: str, *, mapping: dict | None = None,
                      allow_unsided: bool = True) -> MarkerRoles:
    """The markers of each role on ``side``.

    Parameters
    ----------
    traj : Trajectories
    side : {"left", "right"}
    mapping : dict, optional
        The constraints file's ``markers: <take>:`` entry: ``{side: {role: label or [labels]}}``
        (``up`` is ignored here).  Given roles win; the others are detected.
    allow_unsided : bool
        Accept markers whose names tell no side.

    Raises
    ------
    RoleError
        A role not found: one line naming the roles missing and the labels in the file.
    """
    if side not in _SIDE_WORDS:
        raise ValueError(f"side must be left or right, not {side!r}")
    names = _lookup(traj)
    given = dict((mapping or {}).get(side) or {})
    unknown = sorted(set(given) - set(MARKER_ROLES))
    if unknown:
        raise RoleError(f"constraints file, markers, {side}: unknown role(s) {', '.join(unknown)} "
                        f"(roles: {', '.join(MARKER_ROLES)})")
    best = None
    for set_name in MARKER_SETS:
        roles, segments, sided = _try_set(traj, names, set_name, side, allow_unsided)
        roles.update({r: _columns(traj, names, v, f"constraints file, markers, {side}, {r}") for r, v in given.items()})
        if best is None or len(roles) > len(best[1]):
            best = (set_name, roles, segments, sided)
        if len(roles) == len(MARKER_ROLES):
            break
    set_name, roles, segments, sided = best
    missing = [r for r in MARKER_ROLES if r not in roles]
    if missing:
        raise RoleError(
            f"{traj.source}: no {side}-side marker for {', '.join(missing)} (closest set: {set_name}); name them "
            f"under 'markers:' in the constraints file. Labels found: {', '.join(traj.labels)}")
    if given:
        set_name = f"{set_name} + constraints file"
        sided = True
    return MarkerRoles(side, {r: roles[r] for r in MARKER_ROLES}, segments, set_name, sided)


def marker_sides(traj: Trajectories, *, mapping: dict | None = None) -> dict:
    """Every side whose five roles are found by side-specific names (or the mapping).

    Returns
    -------
    dict of str to MarkerRoles
        Possibly empty; a file whose names tell no side gives ``{}`` (see :func:`find_marker_roles`).
    """
    out = {}
    for side in _SIDE_WORDS:
        try:
            r = find_marker_roles(traj, side, mapping=mapping, allow_unsided=False)
        except RoleError:
            continue
        out[side] = r
    return out


_AXIS = {"x": 0, "y": 1, "z": 2}


def _parse_up(value) -> tuple[int, float]:
    s = str(value).strip().lower()
    sign = -1.0 if s.startswith("-") else 1.0
    s = s.lstrip("+-")
    if s not in _AXIS:
        raise RoleError(f"constraints file, markers: up must be x, y, z, -x, -y or -z, not {value!r}")
    return _AXIS[s], sign


_LOW = {"asis", "asisr", "asisl", "rasi", "lasi", "psis", "psisr", "psisl", "rpsi", "lpsi", "sacr", "sacrum",
        "lfwt", "rfwt", "lbwt", "rbwt", "waistlfront", "waistrfront", "waistlback", "waistrback"}
_HIGH = {"c7", "t1", "clav", "strn", "ster", "clav_sc", "lfhd", "rfhd", "lbhd", "rbhd", "headtop", "headfront",
         "rsho", "lsho", "rshoulder", "lshoulder", "rshouldertop", "lshouldertop", "acro_tip"}
#: Vertical axis of each file format's usual convention (Vicon, Qualisys and Motive C3D: z; OpenSim TRC: y).
FORMAT_UP = {".c3d": 2, ".trc": 1, ".csv": 2}


def detect_marker_up(traj: Trajectories) -> tuple[int, float, str]:
    """Vertical axis and sign of a marker capture.

    From the trunk when the file has pelvis markers (ASIS, PSIS, SACR, waist) and upper-trunk
    or head markers (C7, T1, CLAV, STRN, head, shoulders): the axis of their mean offset, with
    its sign.  Otherwise the file format's convention (:data:`FORMAT_UP`, +z by default).

    Returns
    -------
    (axis, sign, how) : (int, float, str)
        ``sign`` is -1 when the vertical points along ``-axis``; ``how`` says which rule decided.
    """
    names = [n.lower() for n in traj.names]
    seen = ~traj.missing

    def centre(group):
        cols = [k for k, n in enumerate(names) if n in group and seen[:, k].any()]
        return np.nanmean(traj.points[:, cols].reshape(-1, 3), axis=0) if cols else None

    lo, hi = centre(_LOW), centre(_HIGH)
    if lo is not None and hi is not None and np.linalg.norm(hi - lo) > 0:
        d = hi - lo
        k = int(np.argmax(np.abs(d)))
        return k, (1.0 if d[k] >= 0 else -1.0), "pelvis to upper-trunk markers"
    ext = "." + traj.source.rsplit(".", 1)[-1].lower() if "." in traj.source else ""
    return FORMAT_UP.get(ext, 2), 1.0, f"the {ext or 'default'} convention"
