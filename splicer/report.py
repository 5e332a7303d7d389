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

__all__ = ["SideReport", "Report"]


class _DictView(Mapping):
    """Read-only mapping over ``to_dict()`` (the JSON form), shared by both report classes."""

    def __getitem__(self, key):
        return self.to_dict()[key]

    def __iter__(self):
        return iter(self.to_dict())

    def __len__(self) -> int:
        return len(self.to_dict())


def _round_list(a, digits=4) -> list:
    """Numbers rounded for JSON; NaN (no value, e.g. an uncovered frame) becomes None (null)."""
    return [round(float(v), digits) if np.isfinite(v) else None for v in np.asarray(a, dtype=np.float64)]


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
        """The report as JSON text."""
        return json.dumps(self.to_dict(), indent=indent)

    def __getitem__(self, key):
        if key == "sides":  # the typed per-side reports, not their JSON
            return self.sides
        return super().__getitem__(key)

    def __repr__(self) -> str:
        return (f"Report(body={self.body.get('frames')} frames @ {self.body.get('fps')} fps, "
                f"hands={self.hands.get('frames')} frames @ {self.hands.get('fps')} fps, "
                f"sides={sorted(self.sides)}, warnings={len(self.warnings)})")
