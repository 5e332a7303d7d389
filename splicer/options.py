"""The options of a splice, in one place: :class:`SpliceOptions` and its validation."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from . import defaults as D
from .errors import SplicerError

__all__ = ["SpliceOptions", "resolve_options"]


@dataclass(frozen=True)
class SpliceOptions:
    """Options of :func:`splicer.splice` (each also a keyword argument there).

    Band widths accept frames (an int, ``120``), a share of the body take (``"30%"``) or
    seconds (``"20s"``).  Times are in seconds (``_s``), angles in radians unless named
    ``_deg``.
    """

    side: str = "both"
    band1: int | float | str | None = None  # None: 30% with fixed ends (the paper), 3 s around the located path with open ends, 4 s around the coarse guide's path for a long take end to end (band_width.pass_widths)
    band2: int | float | str | None = None  # None: a third of band1 (the paper: 30% and 10%); a third of 20 s with the long takes' 4 s
    theta: str = "window"  # or "heading"
    passes: str = D.PASSES  # "auto": both, but pass 1 alone for a side aligned on optical markers (defaults.PASSES); "pass1", "pass2" (pass 2 alone, for comparison) or "both"
    pass2_weight: float = D.PASS2_WEIGHT  # radians per band width of departure from the pass-1 warp; 0 = literal
    pass2_d1_weight: float = D.PASS2_D1_WEIGHT  # weight of D1 (normalised) added to D2 in pass 2; 0 = literal
    merge: str = "timemap"  # or "median"
    smooth_s: float = D.SMOOTH_S  # marker smoothing before derivatives, seconds
    dead_zone: float = D.DEAD_ZONE  # sign dead zone, fraction of the motion's RMS speed
    sign_ramp: float = D.SIGN_RAMP  # the sign rises to 1 over this share of the RMS speed past the dead zone; 0 = step
    sign_ramp_noisy: float = D.SIGN_RAMP_NOISY  # the same in pass 1 with fixed ends where noise matching smoothed the pair (a second performance; not optical markers); sign_ramp's value: no difference
    temperature_s: float = D.PASS1_TEMPERATURE_S  # pass 1: a path costing 1 D1 unit more per frame for this long is e times less likely; 0 = the best path alone
    posterior_radius_s: float = D.POSTERIOR_RADIUS_S  # pass 1: hands time each side of the best path weighed, seconds
    noise_ratio: float | str | None = "auto"  # "auto": when one take's signs flip over NOISE_TRIGGER times as often, smooth both until within NOISE_RATIO; a number R: whenever over R, until within R; None: off
    position_weight: float | str = "auto"  # pass 1 adds this many D1 units per unit of the position term; "auto": POSITION_WEIGHT_NOISY where noise matching smoothed the pair, else POSITION_WEIGHT with fixed ends and 0 open-ended, OPTICAL_SIGN_WEIGHT on the hand-in-forearm signs alone for optical markers (stages.align.position_weights); 0: D1 alone (the paper)
    pass1_arms: str = D.PASS1_ARMS  # "both": one pass 1 weighs both arms (both hands of one hands take share its clock; stages.align.align_pair); "each": each side's own pass 1 (the paper)
    timemap_sigma_s: float = D.TIMEMAP_SIGMA_S  # time-map smoothing, seconds
    tempo_var_per_s: float = D.TEMPO_VAR_PER_S  # the time map weighed by the expected path's spread, the tempo (hands s per body s) drifting by this variance per second (stages.transfer.trend_time_maps); 0: the smoothed map alone
    body_holds: str = "on"  # "on": stretches where the body holds still are crossed on one hands frame (align.holds); "off": the paper's DTW there
    wrist_radius_s: float = D.WRIST_RADIUS_S  # the time map moved by the hand's motion relative to the forearm, within this many seconds (stages.transfer.refine_time_maps); 0: off
    blend_window: int = D.BLEND_WINDOW_FRAMES  # median merge: frames blended each side of a jump
    uncovered_blend_s: float = 0.25  # body frames without hands material: blend in/out over this, seconds
    wrist: str = "body"  # or "hands": the wrist rotation comes from the hands capture too
    coarse: str = "auto"  # "on", "off", or "auto": on for takes over coarse_above_s seconds
    coarse_fps: float = D.COARSE_FPS  # rate of the coarse guide pass, frames per second
    coarse_above_s: float = D.COARSE_ABOVE_S
    hands_side: str | None = None  # side of a hand-only file whose names do not say
    ends: str | None = None  # "auto", "open" (find the overlap) or "fixed" (first and last frames match); None: config, else auto
    offset_s: float | None = None  # open ends: body frame 0 shows this hands time, seconds (a starting guess)
    uncovered_quantile: float = D.UNCOVERED_QUANTILE  # open ends: an uncovered body frame costs this quantile of D1
    both_skip: str = "auto"  # open ends: "on": the takes may overlap partly, the path skipping both takes' heads (tails) at once (defaults.BOTH_SKIP_WEIGHT); "off": on one take's only (0.32.0); "auto": on where the hand-in-forearm motion compares, checked against "off" where it skipped both (stages.overlap), else off
    unsure_edge_s: float = D.UNSURE_EDGE_S  # open ends: a stretch this long next to uncovered frames, estimated error over UNSURE_EDGE_ERROR_S throughout, is uncovered too (stages.coverage.unsure_edges); 0: off
    unmatched_edge_s: float = D.UNMATCHED_EDGE_S  # open ends: a stretch this long next to uncovered frames that matches no better than the hands played backwards is uncovered too (stages.coverage.unmatched_edges), and at the body's own start or end one that matches worse on the whole (unmatched_body_ends); 0: both off
    mirror_hands: str | None = None  # "auto", "yes", "no"; None: the config file's, else auto
    repair: str = "on"  # "on": dropouts and gaps of the hands capture repaired (and reported) first; "off"

    def __repr__(self) -> str:
        changed = [f"{f.name}={getattr(self, f.name)!r}" for f in fields(self)
                   if getattr(self, f.name) != f.default]
        return f"SpliceOptions({', '.join(changed)})"


_CHOICES = {"side": ("left", "right", "both"), "theta": ("window", "heading"), "passes": ("auto", "pass1", "pass2", "both"),
            "merge": ("timemap", "median"), "wrist": ("body", "hands"), "hands_side": (None, "left", "right"),
            "coarse": ("auto", "on", "off"), "pass1_arms": ("both", "each"),
            "mirror_hands": (None, "auto", "yes", "no"), "repair": ("on", "off"), "body_holds": ("on", "off"), "ends": (None, "auto", "open", "fixed"),
            "both_skip": ("auto", "on", "off")}
_NONNEGATIVE = ("uncovered_quantile", "uncovered_blend_s", "smooth_s", "dead_zone", "sign_ramp", "sign_ramp_noisy", "temperature_s",
                "posterior_radius_s", "timemap_sigma_s", "tempo_var_per_s", "wrist_radius_s", "pass2_weight", "pass2_d1_weight", "coarse_fps",
                "coarse_above_s", "unsure_edge_s", "unmatched_edge_s")


def resolve_options(options: SpliceOptions | None = None, overrides: dict | None = None) -> SpliceOptions:
    """``options`` (default :class:`SpliceOptions`) with ``overrides`` applied, validated.

    Raises
    ------
    TypeError
        An unknown option name.
    SplicerError
        A value out of its range, naming the option.
    """
    opts = options if options is not None else SpliceOptions()
    if not isinstance(opts, SpliceOptions):
        raise TypeError(f"splice(): options must be a SpliceOptions, not {type(opts).__name__}")
    if overrides:
        known = {f.name for f in fields(SpliceOptions)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise TypeError(f"splice(): unknown option(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        opts = replace(opts, **overrides)
    for k, allowed in _CHOICES.items():
        if getattr(opts, k) not in allowed:
            raise SplicerError(f"{k} must be one of {', '.join(str(a) for a in allowed)}, not {getattr(opts, k)!r}")
    for k in _NONNEGATIVE:
        v = getattr(opts, k)
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and v >= 0 and math.isfinite(v)):
            raise SplicerError(f"{k} must be a number >= 0, not {v!r}")
    if opts.offset_s is not None and (isinstance(opts.offset_s, bool) or not isinstance(opts.offset_s, (int, float))
                                      or not math.isfinite(opts.offset_s)):
        raise SplicerError(f"offset_s must be a number of seconds, not {opts.offset_s!r}")
    nr = opts.noise_ratio
    if nr is not None and nr != "auto" and (isinstance(nr, bool) or not isinstance(nr, (int, float))
                                            or not (nr >= 1 and math.isfinite(nr))):
        raise SplicerError(f"noise_ratio must be 'auto', a number >= 1 or None (off), not {nr!r}")
    pw = opts.position_weight
    if pw != "auto" and (isinstance(pw, bool) or not isinstance(pw, (int, float)) or not (pw >= 0 and math.isfinite(pw))):
        raise SplicerError(f"position_weight must be 'auto' or a number >= 0 (0: D1 alone, the paper), not {pw!r}")
    if isinstance(opts.blend_window, bool) or not (isinstance(opts.blend_window, int) and opts.blend_window >= 0):
        raise SplicerError(f"blend_window must be a whole number of frames >= 0, not {opts.blend_window!r}")
    return opts
