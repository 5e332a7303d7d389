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

The file is read with a strict safe loader (limits in :mod:`splicer.limits`): tags such as
``!foo`` or ``!!float`` are refused, aliases are expanded at most to
``MAX_YAML_NODES`` nodes in all (no "billion laughs"), nesting is at most ``MAX_YAML_DEPTH``
deep, a scalar at most ``MAX_YAML_SCALAR`` characters, the file at most ``MAX_YAML_BYTES``.
Scalars are read as null, booleans, numbers or strings only (an implicit date such as
``2001-13-45`` stays a string, and is then refused as a frame number).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from . import limits
from ..errors import ConstraintError
from .limits import shorten

__all__ = ["PairSpec", "SpliceConfig", "read_config", "parse_config", "frame_number"]

_TOP_KEYS = {"tolerance", "side", "pairs", "joints", "up", "hands_side", "mirror_hands", "markers", "ends", "offset"}
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
    mirror_hands: str | None = None  # "auto", "yes", "no"; None = not given
    markers: dict = field(default_factory=dict)  # {"body"|"hands": {"up": ..., side: {role: label(s)}}}
    ends: str | None = None  # "open" | "fixed"; None = not given
    offset_s: float | None = None  # body frame 0 shows this hands time, seconds (open ends: a starting guess)


def frame_number(value, fps: float, *, what: str) -> int:
    """A frame number from an int (frames) or a ``"<seconds>s"`` string, rounded to the nearest frame.

    At most ``limits.MAX_FRAME_NUMBER`` in magnitude.
    """
    big = f"{what}: {shorten(value)} is too large (at most {limits.MAX_FRAME_NUMBER:,} frames)"
    if isinstance(value, bool):
        raise ConstraintError(f"{what}: expected a frame number or a time like 4.2s, got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ConstraintError(f"{what}: expected a frame number or a time like 4.2s, got {value!r}")
    if isinstance(value, (int, float)):
        if isinstance(value, float) and not value.is_integer():
            raise ConstraintError(f"{what}: frame numbers are whole numbers; write seconds with an s (e.g. {value}s)")
        if abs(value) > limits.MAX_FRAME_NUMBER:
            raise ConstraintError(big)
        return int(value)
    if isinstance(value, str):
        m = _TIME.match(value) if len(value) <= limits.MAX_YAML_SCALAR else None
        if m:
            frames = float(m.group(1)) * fps
            if not (math.isfinite(frames) and frames <= limits.MAX_FRAME_NUMBER):
                raise ConstraintError(big)
            return int(round(frames))
        v = value.strip()
        if v.isascii() and v.isdigit():
            if len(v.lstrip("0")) > 10 or int(v) > limits.MAX_FRAME_NUMBER:
                raise ConstraintError(big)
            return int(v)
    raise ConstraintError(f"{what}: expected a frame number or a time like 4.2s, got {shorten(value)}")


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses explicit tags and nesting deeper than ``limits.MAX_YAML_DEPTH``."""

    def __init__(self, stream, source: str):
        super().__init__(stream)
        self.source = source
        self.depth = 0

    def compose_node(self, parent, index):
        event = self.peek_event()
        line = event.start_mark.line + 1
        tag = getattr(event, "tag", None)
        if tag is not None:
            if tag.startswith("tag:yaml.org,2002:"):
                tag = "!!" + tag[len("tag:yaml.org,2002:"):]
            raise ConstraintError(f"{self.source}, line {line}: YAML tags such as {shorten(tag)} are not accepted "
                                  "in a constraints file")
        self.depth += 1
        if self.depth > limits.MAX_YAML_DEPTH:
            raise ConstraintError(f"{self.source}, line {line}: nested more than {limits.MAX_YAML_DEPTH} deep")
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


_PLAIN_TAGS = {"tag:yaml.org,2002:null": "construct_yaml_null", "tag:yaml.org,2002:bool": "construct_yaml_bool",
               "tag:yaml.org,2002:int": "construct_yaml_int", "tag:yaml.org,2002:float": "construct_yaml_float"}


class _Converter:
    """Nodes to Python values (dict, list, None, bool, int, float, str), with a node budget.

    Aliases are followed, each visit counting against ``limits.MAX_YAML_NODES``, so an alias
    bomb stops after that many nodes instead of expanding exponentially.
    """

    def __init__(self, loader: _StrictLoader):
        self.loader = loader
        self.source = loader.source
        self.left = limits.MAX_YAML_NODES

    def __call__(self, node, depth: int = 0):
        if node is None:
            return None
        line = node.start_mark.line + 1
        self.left -= 1
        if self.left < 0:
            raise ConstraintError(f"{self.source}, line {line}: more than {limits.MAX_YAML_NODES:,} YAML values "
                                  "(after expanding aliases)")
        if depth > limits.MAX_YAML_DEPTH:
            raise ConstraintError(f"{self.source}, line {line}: nested more than {limits.MAX_YAML_DEPTH} deep "
                                  "(after expanding aliases)")
        if isinstance(node, yaml.ScalarNode):
            return self.scalar(node, line)
        if isinstance(node, yaml.SequenceNode):
            return [self(item, depth + 1) for item in node.value]
        out = {}
        for knode, vnode in node.value:
            key = self(knode, depth + 1)
            if not isinstance(key, (str, int, float, bool, type(None))):
                raise ConstraintError(f"{self.source}, line {knode.start_mark.line + 1}: a mapping key must be a "
                                      "plain value")
            out[key] = self(vnode, depth + 1)
        return out

    def scalar(self, node, line: int):
        value = node.value
        if len(value) > limits.MAX_YAML_SCALAR:
            raise ConstraintError(f"{self.source}, line {line}: a value of {len(value):,} characters "
                                  f"({shorten(value)}); the limit is {limits.MAX_YAML_SCALAR}")
        method = _PLAIN_TAGS.get(node.tag)
        if method is None:
            return value  # str, and implicit timestamps / binary kept as their text
        try:
            return getattr(self.loader, method)(node)
        except (ValueError, OverflowError, KeyError, yaml.YAMLError):
            return value


def _key(knode, source: str) -> str:
    if not isinstance(knode, yaml.ScalarNode):
        raise ConstraintError(f"{source}, line {knode.start_mark.line + 1}: a key must be a plain word")
    return knode.value


def parse_config(text: str, source: str = "<config>") -> SpliceConfig:
    """Parse a constraints/config document; see the module docstring for the format."""
    if len(text) > limits.MAX_YAML_BYTES:
        raise ConstraintError(f"{source}: the constraints file has {len(text):,} characters, more than the limit "
                              f"of {limits.MAX_YAML_BYTES:,}")
    loader = None
    try:
        loader = _StrictLoader(text, source)  # the reader refuses control characters here
        root = loader.get_single_node()
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ConstraintError(f"{source}{where}: not valid YAML ({limits.one_line(problem, 120)})") from None
    finally:
        if loader is not None:
            loader.dispose()
    _scalar = _Converter(loader)
    if root is None:
        return SpliceConfig(source=source)
    if not isinstance(root, yaml.MappingNode):
        raise ConstraintError(f"{source}, line {root.start_mark.line + 1}: expected a mapping with 'pairs:' and options at the top level")
    top: dict = {}
    lines: dict = {}
    for knode, vnode in root.value:
        key = _key(knode, source)
        if key not in _TOP_KEYS:
            raise ConstraintError(
                f"{source}, line {knode.start_mark.line + 1}: unknown key {shorten(key)} "
                f"(known: {', '.join(sorted(_TOP_KEYS))})")
        top[key] = vnode
        lines[key] = knode.start_mark.line + 1

    tol = _scalar(top.get("tolerance")) if "tolerance" in top else 0
    _check_tolerance(tol, f"{source}, line {lines.get('tolerance', 1)}: tolerance")
    side = _scalar(top.get("side")) if "side" in top else "both"
    if side not in _SIDES:
        raise ConstraintError(f"{source}, line {lines['side']}: side must be left, right or both, not {shorten(side)}")

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
                raise ConstraintError(f"{what}: expected {{body: <frame>, hands: <frame>}}, got {shorten(_scalar(item))}")
            entry = {}
            for knode, vnode in item.value:
                key = _key(knode, source)
                if key not in _PAIR_KEYS:
                    raise ConstraintError(f"{what}: unknown key {shorten(key)} (known: {', '.join(sorted(_PAIR_KEYS))})")
                entry[key] = _scalar(vnode)
            for need in ("body", "hands"):
                if need not in entry:
                    raise ConstraintError(f"{what}: missing '{need}' frame")
                v = entry[need]
                if isinstance(v, bool) or not isinstance(v, (int, float, str)):
                    raise ConstraintError(f"{what}: {need} must be a frame number or a time like 4.2s, got {shorten(v)}")
                frame_number(v, 1.0, what=f"{what}, {need}")  # syntax check now, value later
                if isinstance(v, (int, float)) and v < 0:
                    raise ConstraintError(f"{what}: {need} frame {v} is negative (frames are 0-based)")
            if "tolerance" in entry:
                _check_tolerance(entry["tolerance"], f"{what}: tolerance")
            pside = entry.get("side", side)
            if pside not in _SIDES:
                raise ConstraintError(f"{what}: side must be left, right or both, not {shorten(pside)}")
            pairs.append(PairSpec(entry["body"], entry["hands"], entry.get("tolerance"), pside, line, k))

    joints = _scalar(top["joints"]) if "joints" in top else {}
    if joints and (not isinstance(joints, dict) or set(joints) - {"body", "hands"}):
        raise ConstraintError(f"{source}, line {lines['joints']}: 'joints' takes 'body:' and/or 'hands:' mappings")
    if joints:
        _check_joints(joints, f"{source}, line {lines['joints']}: joints")
    up = _scalar(top["up"]) if "up" in top else {}
    if isinstance(up, str):
        up = {"body": up, "hands": up}
    if not isinstance(up, dict) or set(up) - {"body", "hands"} or any(str(v).lower() not in ("x", "y", "z") for v in up.values()):
        raise ConstraintError(f"{source}, line {lines.get('up', 1)}: 'up' is x, y or z, or {{body: y, hands: z}}")
    hands_side = _scalar(top["hands_side"]) if "hands_side" in top else None
    if hands_side not in (None, "left", "right"):
        raise ConstraintError(f"{source}, line {lines['hands_side']}: hands_side must be left or right, "
                              f"not {shorten(hands_side)}")
    mirror = _scalar(top["mirror_hands"]) if "mirror_hands" in top else None
    if isinstance(mirror, bool):  # YAML 1.1 reads yes/no as booleans
        mirror = "yes" if mirror else "no"
    if mirror not in (None, "auto", "yes", "no"):
        raise ConstraintError(f"{source}, line {lines['mirror_hands']}: mirror_hands must be auto, yes or no, "
                              f"not {shorten(mirror)}")
    # markers: optical marker roles (checked in splicer.marker_roles)
    markers = _scalar(top["markers"]) if "markers" in top else {}
    if markers and (not isinstance(markers, dict) or set(markers) - {"body", "hands"}
                    or any(not isinstance(v, dict) or set(v) - {"up", "derive", "left", "right"} for v in markers.values())):
        raise ConstraintError(f"{source}, line {lines['markers']}: 'markers' takes 'body:' and/or 'hands:' mappings "
                              "of 'up:', 'derive:' (rigid or averages), 'left:' and 'right:' (roles p1, p2, p3, p4, shoulder)")
    ends = _scalar(top["ends"]) if "ends" in top else None
    if ends not in (None, "auto", "open", "fixed"):
        raise ConstraintError(f"{source}, line {lines['ends']}: ends must be auto, open or fixed, not {shorten(ends)}")
    offset_s = None
    if "offset" in top:
        raw = _scalar(top["offset"])
        m = _TIME.match(raw) if isinstance(raw, str) else None
        neg = isinstance(raw, str) and raw.strip().startswith("-") and _TIME.match(raw.strip()[1:])
        if m:
            offset_s = float(m.group(1))
        elif neg:
            offset_s = -float(neg.group(1))
        else:
            raise ConstraintError(f"{source}, line {lines['offset']}: offset is the hands time shown at body frame 0, "
                                  f"in seconds like 12.5s or -3s, not {shorten(raw)}")
        if not math.isfinite(offset_s) or abs(offset_s) > 1e6:
            raise ConstraintError(f"{source}, line {lines['offset']}: offset {shorten(raw)} is out of range")
    return SpliceConfig(tuple(pairs), tol, joints or {}, {k: str(v).lower() for k, v in up.items()}, hands_side, source,
                        mirror_hands=mirror, markers=markers or {}, ends=ends, offset_s=offset_s)


_ARM_KEYS = {"wrist", "elbow", "upper_arm", "fingers"}


def _check_joints(joints: dict, what: str) -> None:
    """``{body|hands: {left|right: {wrist: name, elbow: name, upper_arm: name, fingers: {finger: [names]}}}}``."""
    for who, sides in joints.items():
        if sides is None:
            continue
        if not isinstance(sides, dict):
            raise ConstraintError(f"{what}: '{who}' takes 'left:' and/or 'right:' mappings")
        for side, spec in sides.items():
            w = f"{what}: {who}: {shorten(side)}"
            if side not in ("left", "right"):
                raise ConstraintError(f"{w}: unknown side (use left or right)")
            if not isinstance(spec, dict) or "wrist" not in spec:
                raise ConstraintError(f"{w}: expected a mapping with at least 'wrist: <joint name>'")
            for key, value in spec.items():
                if key not in _ARM_KEYS:
                    raise ConstraintError(f"{w}: unknown key {shorten(key)} (known: {', '.join(sorted(_ARM_KEYS))})")
                if key == "fingers":
                    ok = isinstance(value, dict) and all(
                        isinstance(v, list) and all(isinstance(n, str) for n in v) for v in value.values())
                    if not ok:
                        raise ConstraintError(f"{w}: fingers: expected {{index: [joint names], ...}}")
                elif not isinstance(value, str) and not (key != "wrist" and value is None):
                    raise ConstraintError(f"{w}: {key}: expected a joint name, got {shorten(value)}")


def _check_tolerance(tol, what: str) -> None:
    if isinstance(tol, bool):
        raise ConstraintError(f"{what} must be a number of frames or a time like 0.1s, got {tol!r}")
    if isinstance(tol, (int, float)):
        if not (0 <= tol <= limits.MAX_FRAME_NUMBER) or not float(tol).is_integer():
            raise ConstraintError(f"{what} must be a whole number of frames from 0 to {limits.MAX_FRAME_NUMBER:,}, "
                                  f"got {shorten(tol)}")
        return
    if isinstance(tol, str) and _TIME.match(tol) and len(tol) <= limits.MAX_YAML_SCALAR:
        frame_number(tol, 1000.0, what=what)  # the size at the highest accepted frame rate
        return
    raise ConstraintError(f"{what} must be a number of frames or a time like 0.1s, got {shorten(tol)}")


def read_config(path: str | Path) -> SpliceConfig:
    """Read a constraints/config YAML file.  Raises :class:`ConstraintError` naming the file and line."""
    p = Path(path)

    def error(message: str) -> ConstraintError:
        if message == "file not found":
            message = "constraints file not found"
        return ConstraintError(f"{p}: {message}")

    data = limits.read_input(p, max_bytes=limits.MAX_YAML_BYTES, error=error, what="constraints file")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise ConstraintError(f"{p}, line {line}: cannot read constraints file (not UTF-8 text)") from None
    return parse_config(text, str(p))
