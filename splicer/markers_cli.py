"""``splice-markers``: the alignment alone, on two optical marker files.

For studios that solve skeletons in their own pipeline: the body session's and the hands
session's markers in, the report (time map per side, pass costs, filled gaps) and the hands
markers re-timed onto the body's timeline out::

    splice-markers body.c3d hands.c3d --report r.json -o hands_retimed.c3d

The output has the body file's frame count, rate and first frame; frame ``i`` holds every
hands marker at the time map's hands frame for body frame ``i`` (linear between the two
nearest hands frames; a sample next to a gap of the hands file stays missing: the output
never shows filled data).  Body frames the hands session does not cover (open ends: the time
map is NaN there, the report lists them as ``uncovered``) hold the hands markers as missing.
Exit status: 0 done, 1 bad input, 2 usage.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .cli import _band_text, _forget_caught_interrupt, _Parser, _write_json
from .errors import SplicerError

__all__ = ["MarkerAlignment", "align_marker_files", "retime", "main"]

EXAMPLES = """\
examples:
  splice-markers body.c3d hands.c3d --report r.json -o hands_retimed.c3d
  splice-markers body.trc hands.c3d -o hands_retimed.c3d --constraints sync.yaml --side right

marker roles (p1, p2 wrist; p3 forearm; p4 hand; shoulder) are found by name for Plug-in Gait,
biomechanics (styloids, forearm cluster) and OptiTrack/Qualisys sets; name them under
'markers:' in the constraints file otherwise.
"""


@dataclass(frozen=True, eq=False)
class MarkerAlignment:
    """The result of :func:`align_marker_files`.

    Attributes
    ----------
    body, hands : Trajectories
        As read.
    time_maps : dict of str to np.ndarray [shape=(n_body,)]
        Per side: fractional, 0-based hands row for each body row; NaN for body rows the hands
        session does not cover (open ends).
    retimed : Trajectories
        The hands markers on the body's timeline (body frame count, rate, first frame); missing
        (NaN) at body rows no side covers, and each arm's markers at rows its side leaves uncovered.
    report : Report
    """

    body: object
    hands: object
    time_maps: dict
    retimed: object
    report: object


def retime(traj, frames: np.ndarray, *, fps: float, first_frame: int, columns=None, into=None):
    """Markers of ``traj`` sampled at fractional rows ``frames`` (linear; missing next to a gap).

    Parameters
    ----------
    traj : Trajectories
    frames : np.ndarray [shape=(n,)]
        Fractional 0-based rows of ``traj``, within ``[0, T - 1]``; NaN (an uncovered body
        frame): the markers are missing (NaN) there.
    fps, first_frame
        Of the result.
    columns : sequence of int, optional
        Markers to sample (all by default); with ``into``, the others keep ``into``'s values.
    into : np.ndarray [shape=(n, K, 3)], optional
        Array to write into.

    Returns
    -------
    np.ndarray [shape=(n, K, 3)]
    """
    f = np.asarray(frames, dtype=np.float64)
    covered = np.isfinite(f)
    f = np.clip(np.where(covered, f, 0.0), 0, traj.n_frames - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, traj.n_frames - 1)
    w = (f - i0)[:, None, None]
    cols = list(range(traj.n_markers)) if columns is None else list(columns)
    out = np.full((len(f), traj.n_markers, 3), np.nan) if into is None else into
    a, b = traj.points[i0][:, cols], traj.points[i1][:, cols]
    val = (1 - w) * a + w * b
    exact = (w == 0)[..., 0, 0]
    val[exact] = a[exact]  # on a sample: its value, even when the next one is missing
    val[~covered] = np.nan  # no hands material for these body frames
    out[:, cols] = val
    return out


def _sides_for(body, hands, side: str, cfg, log) -> list[str]:
    from .rig.marker_roles import marker_sides

    if side in ("left", "right"):
        return [side]
    sb = set(marker_sides(body, mapping=cfg.markers.get("body")))
    sh = set(marker_sides(hands, mapping=cfg.markers.get("hands")))
    if sb and sh:
        common = sorted(sb & sh)
        if not common:
            raise SplicerError(f"no side has markers in both files: {body.source} has {sorted(sb)}, "
                               f"{hands.source} has {sorted(sh)}")
        return common
    if sb or sh:
        return sorted(sb or sh)
    log.note("neither marker file names a side; the arm is called 'right' (use --side to name it)")
    return ["right"]


def align_marker_files(body, hands, *, config=None, side: str = "both", max_gap_s: float = 0.5,
                       options=None, log=None, **overrides) -> MarkerAlignment:
    """Align two marker sessions (paths or Trajectories) as :func:`splicer.splice` aligns two takes.

    Parameters
    ----------
    body, hands : path or Trajectories
    config : path or SpliceConfig, optional
        Pins (in 0-based rows of each file) and ``markers:`` roles.
    side : {"left", "right", "both"}
        ``both``: every side with markers in both files.
    max_gap_s : float
        Gaps longer than this (seconds) are reported.
    options : SpliceOptions, optional
        Band widths, passes...; ``merge="timemap"`` is used for the time map.

    Raises
    ------
    SplicerError
        Unreadable file, roles missing, band errors (one line each).
    """
    from . import __version__
    from .io.config import SpliceConfig, read_config
    from .align.frames import FrameSpaces, pins_from_config
    from .rig.marker_arm import arm_from_trajectories
    from .options import resolve_options
    from .pipeline import (Log, SideMarkers, SideResult, _coverage_report, align_side, mark_coverage_edges,
                           refine_time_maps, time_map)
    from .stages.markers import to_common
    from .report import Report, SideReport
    from .transfer.timemap import mean_map
    from .io.trajectories import Trajectories, read_trajectories

    log = log or Log()
    opts = resolve_options(options, overrides)
    bt = body if isinstance(body, Trajectories) else read_trajectories(body)
    ht = hands if isinstance(hands, Trajectories) else read_trajectories(hands)
    for w in bt.warnings + ht.warnings:
        log.note(w)
    cfg = read_config(config) if isinstance(config, (str, Path)) else (config or SpliceConfig())
    log.tick("read")
    spaces = FrameSpaces(bt.n_frames, ht.n_frames, bt.fps, ht.fps)
    maps, side_reports, columns = {}, {}, {}

    sides = _sides_for(bt, ht, side, cfg, log)
    unsided = any("neither marker file names a side" in w for w in log.warnings)
    for s in sides:
        barm = arm_from_trajectories(bt, s, mapping=cfg.markers.get("body"), max_gap_s=max_gap_s)
        harm = arm_from_trajectories(ht, s, mapping=cfg.markers.get("hands"), max_gap_s=max_gap_s)
        for msg in barm.notes + harm.notes:
            if msg not in log.warnings and not (unsided and "tell no side" in msg):
                log.note(msg)
        hmk = to_common(harm.markers, barm.markers.up, bt.fps)
        real = {"body": barm.report(bt), "hands": harm.report(ht)}
        noise, bnoise, hnoise = {}, barm.noise_sample(), harm.noise_sample()  # each drawn once
        if bnoise is not None:
            noise["body"] = to_common(bnoise, barm.markers.up).points
        if hnoise is not None:  # carried as the hands' markers are
            noise["hands"] = to_common(hnoise, barm.markers.up, bt.fps).points
        sm = SideMarkers(s, barm.markers, hmk, spaces, tuple(pins_from_config(cfg, s, spaces)), real,
                         placed=("optical", "optical"), noise=noise)
        log.tick("markers")
        alignment = align_side(sm, opts, log)
        tm = time_map(alignment, sm, opts)
        # the wrist's refinement, as splice runs it (stages.transfer.refine_time_maps)
        refined = refine_time_maps({s: SideResult(s, tm, sm, alignment)}, opts, log)[s]
        tm = refined.hands_frame
        maps[s] = tm
        columns[s] = sorted({c for cols in list(harm.roles.roles.values()) + list(harm.roles.segments.values())
                             for c in cols})
        info = lambda p: None if p is None else {"band_frames": round(float(p.band.width), 3), "cost": float(p.cost)}
        extra = {"hands_file_frame": [round(float(v) + ht.first_frame, 4) if np.isfinite(v) else None for v in tm],
                 "markers": real, **refined.extra}
        # covered / uncovered ranges, confidence and low-confidence ranges as splice reports them
        side = mark_coverage_edges({s: refined})[s]  # as splice: the edges of coverage
        extra.update(_coverage_report(side, bt.n_frames, log))
        pins = tuple({"body": p.body, "hands": p.hands, "tolerance": p.tolerance, "line": p.line} for p in sm.pins)
        side_reports[s] = SideReport(s, tm, info(alignment.pass1), info(alignment.pass2), pins, {}, extra)
        log.tick("align")
    # markers of no side follow the mean map of the sides covering each frame (NaN: none does)
    pts = retime(ht, mean_map(list(maps.values())), fps=bt.fps, first_frame=bt.first_frame)
    if len(maps) > 1:  # each arm's markers follow their own side's map
        for s, tm in maps.items():
            retime(ht, tm, fps=bt.fps, first_frame=bt.first_frame, columns=columns[s], into=pts)
    out = Trajectories(ht.labels, pts, bt.fps, bt.first_frame, ht.units, "hands_retimed")
    timings = dict(log.timings, total=log.total())
    report = Report(__version__,
                    {"path": bt.source, "frames": bt.n_frames, "fps": bt.fps, "first_frame": bt.first_frame},
                    {"path": ht.source, "frames": ht.n_frames, "fps": ht.fps, "first_frame": ht.first_frame},
                    {f: getattr(opts, f) for f in opts.__dataclass_fields__} | {"max_gap_s": max_gap_s},
                    side_reports, timings, tuple(log.warnings),
                    {"time_map": "hands_frame: 0-based hands row per body row; hands_file_frame: in the hands "
                                 "file's frame numbers"})
    return MarkerAlignment(bt, ht, maps, out, report)


def _seconds(text: str) -> float:
    """A positive, finite number of seconds, as typed."""
    try:
        v = float(_band_text(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (np.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: give a positive number of seconds")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="splice-markers",
        description="Align a hands marker session to a body marker session (two-pass DTW on the wrist, forearm "
                    "and hand markers) and write the time map and the hands markers re-timed onto the body's "
                    "timeline.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("body", help="body session markers (.c3d, .trc, .csv); its timing is kept")
    p.add_argument("hands", help="hands session markers (.c3d, .trc, .csv)")
    p.add_argument("-o", "--output", required=True, help="re-timed hands markers (.c3d or .trc)")
    p.add_argument("--report", metavar="JSON", help="write the report (time map per side, costs, filled gaps)")
    p.add_argument("--constraints", metavar="YAML", help="pins (0-based rows of each file) and 'markers:' roles")
    p.add_argument("--side", choices=("left", "right", "both"), default="both",
                   help="arm to align (default: every side with markers in both files)")
    p.add_argument("--band", "--band1", dest="band1", default="30%", type=_band_text,
                   help="pass-1 band width: frames (120), share of the body take (30%%) or seconds (20s)")
    p.add_argument("--max-gap", type=_seconds, default=0.5, metavar="S",
                   help="report gaps longer than this many seconds (default 0.5)")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary")
    return p


def _check_output(path: Path, inputs) -> None:
    for i in inputs:
        if i is not None and Path(i).exists() and path.exists() and os.path.samefile(i, path):
            raise SplicerError(f"{path}: the output would overwrite an input file; choose another name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise SplicerError(f"{path}: cannot write: folder {parent} does not exist")
    if path.is_dir():
        raise SplicerError(f"{path}: is a folder; give a file name")


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    t0 = time.perf_counter()
    try:
        from .io.trajectory_writers import write_c3d, write_trc

        out = Path(args.output)
        if out.suffix.lower() not in (".c3d", ".trc"):
            raise SplicerError(f"{out}: the output must be a .c3d or .trc file")
        inputs = [args.body, args.hands, args.constraints]
        _check_output(out, inputs)
        if args.report:
            _check_output(Path(args.report), inputs + [args.output])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = align_marker_files(args.body, args.hands, config=args.constraints, side=args.side,
                                     max_gap_s=args.max_gap, band1=args.band1)
        retimed = replace(res.retimed, source=str(out))
        (write_c3d if out.suffix.lower() == ".c3d" else write_trc)(retimed, out)
        if args.report:
            _write_json(res.report.to_dict(), Path(args.report))
    except SplicerError as e:
        print(f"splice-markers: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("splice-markers: interrupted; nothing was written", file=sys.stderr)
        _forget_caught_interrupt()
        return 130
    if not args.quiet:
        rep = res.report
        fills = sum(len(s.extra["markers"][k]["gaps_filled"]) for s in rep.sides.values() for k in ("body", "hands"))
        text = (f"Aligned {res.hands.n_frames} hands frames at {res.hands.fps:g} Hz to {res.body.n_frames} body "
                f"frames at {res.body.fps:g} Hz; sides: {', '.join(rep.sides)}; {fills} gap(s) filled for the "
                f"alignment. Wrote {out} in {time.perf_counter() - t0:.1f}s.")
        if rep.warnings:
            text += f" {len(rep.warnings)} warning(s): " + " | ".join(rep.warnings)
        print(text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
