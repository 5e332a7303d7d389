"""The report of a splice: a typed, frozen object with a JSON form.

``report.to_dict()`` is what ``splice --report`` writes; its keys are stable (README,
"Report").  Both classes are read-only mappings over that dict (``report["sides"]``,
``"uncovered" in report["sides"]["left"]``, ``report.get("up")``), so
``result.report["sides"]["left"]["hands_frame"]`` works.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SideReport", "Report", "json_text"]


class _DictView(Mapping):
    """Read-only mapping over ``to_dict()`` (the JSON form), shared by both report classes."""

    def __getitem__(self, key):
        return self.to_dict()[key]

    def __iter__(self):
        return iter(self.to_dict())

    def __len__(self) -> int:
        return len(self.to_dict())


def _round_list(a, digits=4) -> list:
    """Numbers rounded for JSON (``numpy.round``); NaN or infinite (no value, e.g. an uncovered
    frame) becomes None (null)."""
    a = np.round(np.asarray(a, dtype=np.float64), digits)
    out = a.tolist()
    if not np.isfinite(a).all():
        for k in np.flatnonzero(~np.isfinite(a)):
            out[k] = None
    return out


_NUMBERS = frozenset({int, float, type(None)})


def _encode(obj, level: int) -> str:
    if isinstance(obj, (list, tuple)) and set(map(type, obj)) <= _NUMBERS:
        return json.dumps(obj)  # numbers on one line (json's C encoder: no indent)
    if isinstance(obj, dict):
        items = [(k if isinstance(k, str) else json.dumps(k), v) for k, v in obj.items()]
        parts = [f"{json.dumps(k)}: {_encode(v, level + 1)}" for k, v in items]
        open_, close = "{", "}"
    elif isinstance(obj, (list, tuple)):
        parts = [_encode(v, level + 1) for v in obj]
        open_, close = "[", "]"
    else:
        return json.dumps(obj)
    if not parts:
        return open_ + close
    pad = "\n" + " " * (level + 1)
    return open_ + pad + ("," + pad).join(parts) + "\n" + " " * level + close


def json_text(obj) -> str:
    """JSON text as splicer writes its reports: indented one space per level, with every list of
    numbers (per-frame values, a range's ``[first, last]``) on one line.

    ``json.loads(json_text(x)) == json.loads(json.dumps(x))``; where ``json.dumps(x, indent=1)``
    gives each of a long take's per-frame numbers its own line and encodes them in Python,
    this keeps them on one line through json's C encoder (a 60-minute take's report: 0.8 s
    instead of 2 s, and a fifth of the lines).

    >>> print(json_text({"a": [1, 2.5, None], "b": {"c": "d", "e": []}}))
    {
     "a": [1, 2.5, null],
     "b": {
      "c": "d",
      "e": []
     }
    }
    """
    return _encode(obj, 0)


@dataclass(frozen=True, eq=False)
class SideReport(_DictView):
    """What the report says about one side.

    Attributes
    ----------
    side : str
    hands_frame : np.ndarray [shape=(n_body,)]
        0-based, possibly fractional, hands-file frame used for each body frame.
    pass1, pass2 : dict or None
        ``{"band_frames": W, "cost": total}`` of each pass that ran.
    pins : tuple of dict
        The pins as applied: body frame, hands frame, tolerance (hands frames), line.
    joints : dict
        Output joint -> the hands joints whose rotations drive it.
    extra : dict
        Further JSON-ready keys of later stages (e.g. confidence, uncovered ranges).
    """

    side: str
    hands_frame: np.ndarray
    pass1: dict | None
    pass2: dict | None
    pins: tuple
    joints: dict
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        d = {"hands_frame": _round_list(self.hands_frame), "pass1": self.pass1, "pass2": self.pass2,
             "constraints": [dict(p) for p in self.pins], "joints": dict(self.joints)}
        d.update(self.extra)
        return d

    def __repr__(self) -> str:
        return (f"SideReport(side={self.side!r}, body_frames={len(self.hands_frame)}, pins={len(self.pins)}, "
                f"joints={len(self.joints)})")


@dataclass(frozen=True, eq=False)
class Report(_DictView):
    """The report of one splice.

    Attributes
    ----------
    version : str
        splicer's version.
    body, hands : dict
        ``{"path", "frames", "fps"}`` of each input.
    options : dict
        The options used.
    sides : dict of str to SideReport
    timings_s : dict of str to float
        Seconds per stage, and ``"total"``.
    warnings : tuple of str
        Everything the user should know: skipped sides, fallbacks, odd input.
    extra : dict
        Further JSON-ready top-level keys.
    """

    version: str
    body: dict
    hands: dict
    options: dict
    sides: dict
    timings_s: dict
    warnings: tuple
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The JSON-ready report (plain dicts, lists, numbers and strings)."""
        d = {"splicer": self.version, "body": dict(self.body), "hands": dict(self.hands),
             "options": dict(self.options), "sides": {k: v.to_dict() for k, v in self.sides.items()},
             "timings_s": {k: round(float(v), 4) for k, v in self.timings_s.items()},
             "warnings": list(self.warnings)}
        d.update(self.extra)
        return d

    def to_json(self, *, indent: int | None = 1) -> str:
        """The report as JSON text: what ``splice --report`` writes (:func:`json_text`) with
        ``indent=1``, else ``json.dumps(..., indent=indent)``."""
        d = self.to_dict()
        return json_text(d) if indent == 1 else json.dumps(d, indent=indent)

    def __getitem__(self, key):
        if key == "sides":  # the typed per-side reports, not their JSON
            return self.sides
        return super().__getitem__(key)

    def __repr__(self) -> str:
        return (f"Report(body={self.body.get('frames')} frames @ {self.body.get('fps')} fps, "
                f"hands={self.hands.get('frames')} frames @ {self.hands.get('fps')} fps, "
                f"sides={sorted(self.sides)}, warnings={len(self.warnings)})")
