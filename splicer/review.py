"""Pins by pointing: an interactive review of one side's alignment in a notebook.

``review = PinReview(body, hands, constraints="sync.yaml", side="left")`` solves the side
once; ``review.figure()`` draws the pass-1 cost matrix (body frames across, hands-file frames
up), the time map and the pins.  In Jupyter with ipympl (``pip install "splicer[notebook]"``,
then ``%matplotlib widget``) a click on the figure adds a pin there, or removes the pin
under the pointer; only the stretch between the neighbouring pins is solved again, and the
time map is rebuilt.  ``review.save()`` writes the pins to the constraints YAML.

Everything a click does is :meth:`PinReview.click` (body frame, hands frame), a plain method
that tests and scripts call directly; :meth:`PinReview.on_click` only turns a matplotlib
mouse event into that call.

Re-solving a stretch.  Between two neighbouring pins (or a pin and the end of the takes) both
passes run again on that stretch only, with its ends held exactly at the pins (the whole-take
solve lets the path pass within a pin's tolerance); the rest of the alignment is kept
exactly, and the time map is rebuilt with all pins held (which moves it up to the
neighbouring pins on either side, not further).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from .errors import ConstraintError, SplicerError
from .align.frames import FrameSpaces, Pin

__all__ = ["PinReview"]


class PinReview:
    """One side's alignment, with pins added and removed by pointing.

    Parameters
    ----------
    body, hands : path or Motion
    constraints : path, optional
        The constraints YAML: its pins are the starting pins, and :meth:`save` writes there
        by default.
    side : {"left", "right"}
    tolerance : int
        Tolerance (hands frames) of pins added by clicking.
    **options
        :class:`~splicer.options.SpliceOptions` fields.

    Attributes
    ----------
    pins : list of Pin
        Current pins of the side, by body frame.
    per_frame : np.ndarray [shape=(n_body,)]
        Common-rate hands frame matched to each body frame (the alignment).
    time_map : np.ndarray [shape=(n_body,)]
        Hands-file frame for each body frame (smoothed, pins held).
    """

    def __init__(self, body, hands, *, constraints=None, side: str = "left", tolerance: int = 2, **options):
        from .options import resolve_options
        from .pipeline import Log, align_side, condition_hands, find_rig, load_inputs, side_markers, time_map

        if side not in ("left", "right"):
            raise SplicerError(f"review one side at a time: side must be left or right, not {side!r}")
        self.side, self.tolerance = side, int(tolerance)
        self.constraints = None if constraints is None else Path(constraints)
        self.opts = resolve_options(None, {**options, "side": side})
        log = Log()
        inputs = load_inputs(body, hands, constraints, log)
        rig = find_rig(inputs, self.opts, log)
        self.inputs = condition_hands(inputs, rig, self.opts, log).inputs
        self.markers = side_markers(self.inputs, rig, side, log)
        self.alignment = align_side(self.markers, self.opts, log)
        self.pins: list[Pin] = list(self.markers.pins)
        self.per_frame = np.array(self.alignment.per_frame, dtype=np.float64)
        self.time_map = time_map(self.alignment, self.markers, self.opts)
        self.history: list[dict] = []
        self._fig = None

    # ------------------------------------------------------------------ the logic
    @property
    def spaces(self) -> FrameSpaces:
        return self.markers.spaces

    def pin_near(self, body_frame: float, hands_frame: float, *, radius: float = 0.02):
        """Index of the pin within ``radius`` (share of each take's length) of the point, or None."""
        sp = self.spaces
        best, where = None, None
        for k, p in enumerate(self.pins):
            d = max(abs(p.body - body_frame) / sp.n_body, abs(p.hands - hands_frame) / sp.n_hands)
            if d <= radius and (best is None or d < best):
                best, where = d, k
        return where

    def click(self, body_frame: float, hands_frame: float) -> dict:
        """Add a pin at (body frame, hands-file frame), or remove the pin there; re-solve the stretch.

        Returns
        -------
        dict
            ``{"action": "added" | "removed" | "refused", "pin": (body, hands), "stretch": (a, b),
            "why": str}``: ``stretch`` the body frames solved again (both ends included);
            ``why`` says why a pin was refused (outside the takes, or not increasing in both).
        """
        sp = self.spaces
        k = self.pin_near(body_frame, hands_frame)
        if k is not None:
            pin = self.pins.pop(k)
            out = {"action": "removed", "pin": (pin.body, pin.hands)}
        else:
            b, h = int(round(body_frame)), int(round(hands_frame))
            why = None
            if not (0 < b < sp.n_body - 1 and 0 < h < sp.n_hands - 1):
                why = f"({b}, {h}) is outside the takes (body 1..{sp.n_body - 2}, hands 1..{sp.n_hands - 2})"
            else:
                before = [p for p in self.pins if p.body < b]
                after = [p for p in self.pins if p.body > b]
                if (any(p.body == b for p in self.pins) or (before and before[-1].hands >= h)
                        or (after and after[0].hands <= h)):
                    why = f"a pin at body {b}, hands {h} would not increase in both takes with its neighbours"
            if why:
                out = {"action": "refused", "pin": (b, h), "why": why}
                self.history.append(out)
                return out
            pin = Pin(b, h, self.tolerance, f"review click {len(self.history) + 1}")
            self.pins = sorted(self.pins + [pin], key=lambda p: p.body)
            out = {"action": "added", "pin": (b, h)}
        out["stretch"] = self._resolve_around(pin.body)
        self.history.append(out)
        self._redraw()
        return out

    def _resolve_around(self, body_frame: int) -> tuple[int, int]:
        """Solve both passes again between the pins either side of ``body_frame``; rebuild the time map."""
        from .rig.markers import Markers
        from .pipeline import Alignment, SideMarkers, align_side, time_map

        sp = self.spaces
        n, m = sp.n_body, self.markers.hands.n_frames
        left = [p for p in self.pins if p.body < body_frame]
        right = [p for p in self.pins if p.body > body_frame]
        here = [p for p in self.pins if p.body == body_frame]
        # the stretch: from the previous pin (or the start) to the next (or the end); a new pin splits it
        a, ya = (left[-1].body, left[-1].hands / sp.ratio) if left else (0, 0.0)
        b, yb = (right[0].body, right[0].hands / sp.ratio) if right else (n - 1, float(m - 1))
        ya, yb = int(round(ya)), int(round(yb))
        cuts = [(a, ya)] + [(p.body, int(round(p.hands / sp.ratio))) for p in here] + [(b, yb)]

        def cut(mk, lo, hi):
            return Markers(mk.points[lo:hi + 1], mk.shoulder[lo:hi + 1], mk.heading[lo:hi + 1], mk.up, mk.fps, mk.side)

        for (x0, y0), (x1, y1) in zip(cuts, cuts[1:]):
            if x1 - x0 < 2 or y1 - y0 < 2:
                self.per_frame[x0:x1 + 1] = np.linspace(y0, y1, x1 - x0 + 1)
                continue
            sub_sp = FrameSpaces(x1 - x0 + 1, int(round((y1 - y0) * sp.ratio)) + 1, sp.body_fps, sp.hands_fps)
            sub = SideMarkers(self.side, cut(self.markers.body, x0, x1), cut(self.markers.hands, y0, y1), sub_sp, (),
                              self.markers.real, self.markers.hand_only)
            try:
                aln = align_side(sub, self.opts)
            except SplicerError as e:
                raise ConstraintError(f"{self.side} side, body frames {x0}-{x1}: {e}") from None
            self.per_frame[x0:x1 + 1] = aln.per_frame + y0
        path = np.stack([np.arange(n, dtype=np.float64), self.per_frame], axis=1)
        self.alignment = Alignment(self.per_frame.copy(), path, self.alignment.pass1, self.alignment.pass2, (),
                                   self.alignment.covered)
        self.markers = replace(self.markers, pins=tuple(self.pins))
        self.time_map = time_map(self.alignment, self.markers, self.opts)
        return (a, b)

    # ------------------------------------------------------------------ saving
    def save(self, path=None) -> Path:
        """Write the pins to the constraints YAML (default: the file given at the start).

        Pairs of the other side are kept; a ``both`` pair removed here is kept for the other
        side; the other keys of the file (tolerance, joints, up, ...) are kept.  Written atomically.
        """
        import yaml

        from .io.atomic import write_atomic

        path = Path(path) if path is not None else self.constraints
        if path is None:
            raise SplicerError("save(path): no constraints file was given at the start")
        doc = {}
        if self.constraints is not None and self.constraints.is_file():
            doc = yaml.safe_load(self.constraints.read_text(encoding="utf-8")) or {}
        other = "right" if self.side == "left" else "left"
        default_side = doc.get("side", "both")
        kept, both_here = [], set()
        for e in doc.get("pairs", []) or []:
            s = e.get("side", default_side)
            if s == other:
                kept.append(e)
            elif s == "both":
                key = (e["body"], e["hands"])
                if any((p.body, p.hands) == key for p in self.pins):
                    both_here.add(key)
                    kept.append(e)
                else:
                    kept.append({**e, "side": other})
        for p in self.pins:
            if (p.body, p.hands) not in both_here:
                e = {"body": p.body, "hands": p.hands, "side": self.side}
                if p.tolerance != doc.get("tolerance", 0):
                    e["tolerance"] = p.tolerance
                kept.append(e)
        fps = self.spaces.body_fps
        def body_frame(e):  # a frame number, or "<seconds>s"
            b = e["body"]
            return b if isinstance(b, (int, float)) else float(str(b).rstrip("s")) * fps

        kept.sort(key=body_frame)
        doc["pairs"] = kept
        text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)
        write_atomic(path, lambda f: f.write(text.encode("utf-8")), what="constraints file")
        return path

    # ------------------------------------------------------------------ the figure
    def figure(self, *, max_pixels: int = 300):
        """The cost matrix of pass 1 (body frames across, hands-file frames up), the time map and
        the pins; clicks go to :meth:`on_click`.  Interactive with ipympl (``%matplotlib widget``)."""
        import matplotlib.pyplot as plt

        from .plot import band_image

        fig, ax = plt.subplots(figsize=(7, 5))
        pr = self.alignment.pass1
        if pr is not None:
            img, rs, cs = band_image(pr, max_pixels=max_pixels)
            r = self.spaces.ratio
            ax.imshow(img.T, origin="lower", aspect="auto", cmap="viridis", interpolation="nearest",
                      extent=(-0.5 * rs, (pr.band.n - 1) + 0.5 * rs, -0.5 * cs * r, ((pr.band.m - 1) + 0.5 * cs) * r))
        (self._line,) = ax.plot(np.arange(len(self.time_map)), self.time_map, color="red", lw=1.2, label="time map")
        (self._dots,) = ax.plot([], [], "o", color="orange", ms=6, label="pins")
        ax.set_xlabel("body frame")
        ax.set_ylabel("hands frame")
        ax.set_title(f"{self.side} side: click to add a pin, click a pin to remove it", fontsize=9)
        ax.legend(loc="upper left", fontsize=8)
        self._fig, self._ax = fig, ax
        fig.canvas.mpl_connect("button_press_event", self.on_click)
        self._redraw()
        return fig

    def on_click(self, event) -> dict | None:
        """A matplotlib ``button_press_event`` inside the axes -> :meth:`click`."""
        if self._fig is None or event.inaxes is not self._ax or event.xdata is None:
            return None
        return self.click(float(event.xdata), float(event.ydata))

    def _redraw(self) -> None:
        if self._fig is None:
            return
        self._line.set_data(np.arange(len(self.time_map)), self.time_map)
        self._dots.set_data([p.body for p in self.pins], [p.hands for p in self.pins])
        self._fig.canvas.draw_idle()
