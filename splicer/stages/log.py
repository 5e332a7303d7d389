"""The splice's log: warnings for the report, stage timings, progress."""

from __future__ import annotations

import time

__all__ = ['Log']


class Log:
    """Warnings, stage timings and progress of one splice (the only mutable piece, kept here)."""

    def __init__(self, progress=None):
        self.warnings: list[str] = []
        self.timings: dict[str, float] = {}
        self._progress = progress
        self._t0 = time.perf_counter()
        self._start = self._t0

    def note(self, msg: str) -> None:
        """Add a warning for the report and the summary."""
        self.warnings.append(msg)

    def progress(self, stage: str, fraction: float) -> None:
        if self._progress is not None:
            self._progress(stage, fraction)

    def aside(self, label: str) -> Log:
        """A new log (its own warnings and timings) for an alternative the splice may keep
        instead (a second opinion), whose progress reaches this log's bar as ``"label: stage"``:
        a stage run again for it is told apart from its first run, and no bar goes back."""
        outer = self._progress
        return Log(None if outer is None else (lambda stage, fraction: outer(f"{label}: {stage}", fraction)))

    def tick(self, stage: str) -> None:
        """Charge the time since the last tick to ``stage``."""
        t1 = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + (t1 - self._t0)
        self._t0 = t1

    def total(self) -> float:
        return time.perf_counter() - self._start
