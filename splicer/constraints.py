"""The constraints file: animator-pinned matching frames (YAML).

Example::

    # sync.yaml
    tolerance: 2            # default T, in hands frames (or seconds: "0.05s")
    side: both              # left | right | both (default both)
    pairs:
      - {body: 120, hands: 251}           # 0-based frame numbers
      - {body: 4.2s, hands: 9.0s, tolerance: 0, side: right}
    joints:                 # optional: explicit joint roles, overriding detection
      body:
        left: {wrist: L_Wrist, elbow: L_Elbow, upper_arm: L_UpperArm}
      hands:
        right: {wrist: WRIST, fingers: {index: [INDEX_MCP, INDEX_PIP_FE, INDEX_DIP_FE]}}
    up: {body: y, hands: z}  # optional: vertical axes, detected when omitted
    hands_side: left         # optional: side of a hand-only file whose names do not tell it
    markers:                 # optional: optical marker roles per take and side (splicer.marker_roles)
      hands: {up: z, right: {p1: STYLr, p2: STYLu, p3: [LARMl, LARMm], p4: INDEX, shoulder: ACRO_tip}}

Errors name the file, the line and the entry at fault.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from .errors import ConstraintError

__all__ = ["PairSpec", "SpliceConfig", "read_config", "parse_config", "frame_number"]

_TOP_KEYS = {"tolerance", "side", "pairs", "joints", "up", "hands_side", "markers"}
_PAIR_KEYS = {"body", "hands", "tolerance", "side"}
_SIDES = ("left", "right", "both")
_TIME = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*s\s*$")


@dataclass(frozen=True)
class PairSpec:
    """One matching pair as written: values are ints (frames) or strings like ``"4.2s"``."""

    body: int | str
    hands: int | str
    tolerance: int | str | None
    side: str
    line: int  # 1-based line of the entry in the file
    index: int  # 0-based position in the list


@dataclass(frozen=True)
class SpliceConfig:
    """Everything a constraints/config file can say."""

    pairs: tuple[PairSpec, ...] = ()
    tolerance: int | str = 0
    joints: dict = field(default_factory=dict)
    up: dict = field(default_factory=dict)
    hands_side: str | None = None
    source: str = "<config>"
    markers: dict = field(default_factory=dict)  # {"body"|"hands": {"up": ..., side: {role: label(s)}}}


def frame_number(value, fps: float, *, what: str) -> int:
    """A frame number from an int (frames) or a ``"<seconds>s"`` string, rounded to the nearest frame."""
    if isinstance(value, bool):
        raise ConstraintError(f"{what}: expected a frame number or a time like 4.2s, got {value!r}")
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        if value.is_integer():
            return int(value)
        raise ConstraintError(f"{what}: frame numbers are whole numbers; write seconds with an s (e.g. {value}s)")
    if isinstance(value, str):
        m = _TIME.match(value)
        if m:
            return int(round(float(m.group(1)) * fps))
        if value.strip().isdigit():
            return int(value.strip())
    raise ConstraintError(f"{what}: expected a frame number or a time like 4.2s, got {value!r}")


def _scalar(node):
    return yaml.safe_load(yaml.serialize(node)) if node is not None else None


def parse_config(text: str, source: str = "<config>") -> SpliceConfig:
    """Parse a constraints/config document; see the module docstring for the format."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ConstraintError(f"{source}{where}: not valid YAML ({problem})") from None
    if root is None:
        return SpliceConfig(source=source)
    if not isinstance(root, yaml.MappingNode):
        raise ConstraintError(f"{source}, line {root.start_mark.line + 1}: expected a mapping with 'pairs:' and options at the top level")
    top: dict = {}
    lines: dict = {}
    for knode, vnode in root.value:
        key = knode.value
        if key not in _TOP_KEYS:
            raise ConstraintError(
                f"{source}, line {knode.start_mark.line + 1}: unknown key {key!r} (known: {', '.join(sorted(_TOP_KEYS))})")
        top[key] = vnode
        lines[key] = knode.start_mark.line + 1

    tol = _scalar(top.get("tolerance")) if "tolerance" in top else 0
    _check_tolerance(tol, f"{source}, line {lines.get('tolerance', 1)}: tolerance")
    side = _scalar(top.get("side")) if "side" in top else "both"
    if side not in _SIDES:
        raise ConstraintError(f"{source}, line {lines['side']}: side must be left, right or both, not {side!r}")

    pairs: list[PairSpec] = []
    if "pairs" in top:
        pnode = top["pairs"]
        if isinstance(pnode, yaml.ScalarNode) and pnode.value in ("", "null", "~"):
            pnode = yaml.SequenceNode(tag="tag:yaml.org,2002:seq", value=[])
        if not isinstance(pnode, yaml.SequenceNode):
            raise ConstraintError(f"{source}, line {lines['pairs']}: 'pairs' must be a list of {{body: ..., hands: ...}} entries")
        for k, item in enumerate(pnode.value):
            line = item.start_mark.line + 1
            what = f"{source}, line {line}: pair {k + 1}"
            if not isinstance(item, yaml.MappingNode):
                raise ConstraintError(f"{what}: expected {{body: <frame>, hands: <frame>}}, got {_scalar(item)!r}")
            entry = {}
            for knode, vnode in item.value:
                if knode.value not in _PAIR_KEYS:
                    raise ConstraintError(f"{what}: unknown key {knode.value!r} (known: {', '.join(sorted(_PAIR_KEYS))})")
                entry[knode.value] = _scalar(vnode)
            for need in ("body", "hands"):
                if need not in entry:
                    raise ConstraintError(f"{what}: missing '{need}' frame")
                v = entry[need]
                if isinstance(v, bool) or not isinstance(v, (int, float, str)):
                    raise ConstraintError(f"{what}: {need} must be a frame number or a time like 4.2s, got {v!r}")
                frame_number(v, 1.0, what=f"{what}, {need}")  # syntax check now, value later
                if isinstance(v, (int, float)) and v < 0:
                    raise ConstraintError(f"{what}: {need} frame {v} is negative (frames are 0-based)")
            if "tolerance" in entry:
                _check_tolerance(entry["tolerance"], f"{what}: tolerance")
            pside = entry.get("side", side)
            if pside not in _SIDES:
                raise ConstraintError(f"{what}: side must be left, right or both, not {pside!r}")
            pairs.append(PairSpec(entry["body"], entry["hands"], entry.get("tolerance"), pside, line, k))

    joints = _scalar(top["joints"]) if "joints" in top else {}
    if joints and (not isinstance(joints, dict) or set(joints) - {"body", "hands"}):
        raise ConstraintError(f"{source}, line {lines['joints']}: 'joints' takes 'body:' and/or 'hands:' mappings")
    up = _scalar(top["up"]) if "up" in top else {}
    if isinstance(up, str):
        up = {"body": up, "hands": up}
    if not isinstance(up, dict) or set(up) - {"body", "hands"} or any(str(v).lower() not in ("x", "y", "z") for v in up.values()):
        raise ConstraintError(f"{source}, line {lines.get('up', 1)}: 'up' is x, y or z, or {{body: y, hands: z}}")
    hands_side = _scalar(top["hands_side"]) if "hands_side" in top else None
    if hands_side not in (None, "left", "right"):
        raise ConstraintError(f"{source}, line {lines['hands_side']}: hands_side must be left or right, not {hands_side!r}")
    # --- markers: (issue 14, optical marker roles; checked in splicer.marker_roles) ---
    markers = _scalar(top["markers"]) if "markers" in top else {}
    if markers and (not isinstance(markers, dict) or set(markers) - {"body", "hands"}
                    or any(not isinstance(v, dict) or set(v) - {"up", "left", "right"} for v in markers.values())):
        raise ConstraintError(f"{source}, line {lines['markers']}: 'markers' takes 'body:' and/or 'hands:' mappings "
                              "of 'up:', 'left:' and 'right:' (roles p1, p2, p3, p4, shoulder)")
    return SpliceConfig(tuple(pairs), tol, joints or {}, {k: str(v).lower() for k, v in up.items()}, hands_side, source,
                        markers or {})


def _check_tolerance(tol, what: str) -> None:
    if isinstance(tol, bool):
        raise ConstraintError(f"{what} must be a number of frames or a time like 0.1s, got {tol!r}")
    if isinstance(tol, (int, float)):
        if tol < 0 or not float(tol).is_integer():
            raise ConstraintError(f"{what} must be a whole number of frames >= 0, got {tol!r}")
        return
    if isinstance(tol, str) and _TIME.match(tol):
        return
    raise ConstraintError(f"{what} must be a number of frames or a time like 0.1s, got {tol!r}")


def read_config(path: str | Path) -> SpliceConfig:
    """Read a constraints/config YAML file.  Raises :class:`ConstraintError` naming the file and line."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConstraintError(f"{p}: constraints file not found") from None
    except IsADirectoryError:
        raise ConstraintError(f"{p}: is a directory, not a constraints file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ConstraintError(f"{p}: cannot read constraints file ({e.__class__.__name__}: {e})") from None
    return parse_config(text, str(p))
