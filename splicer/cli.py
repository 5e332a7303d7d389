"""The ``splice`` command: parses options and calls :func:`splicer.splice`.

Exit status: 0 done, 1 bad input (files, joints, constraints, output path), 2 usage.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

from .errors import SplicerError

EXAMPLES = """\
examples:
  splice body.bvh hands.bvh -o out.bvh
  splice body.bvh hands.bvh -o out.bvh --constraints sync.yaml
  splice body.bvh hands.bvh -o out.bvh --report report.json --plot align.png
  splice body.bvh right_hand.bvh -o out.bvh --side right --band 20s

bands take frames (120), a share of the body take (30%%) or seconds (20s).
The constraints file format is in the README (section "Constraints file").
"""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="splice",
        description="Splice a hand capture's finger motion onto a full-body capture: the output keeps the "
                    "body take's skeleton, frames and timing, with the fingers (and optionally the wrists) "
                    "driven by the hands take, aligned by two-pass dynamic time warping.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("body", help="full-body BVH (its timing is kept)")
    p.add_argument("hands", help="hand BVH: a full skeleton, a forearm-rooted or a wrist-rooted hand")
    p.add_argument("-o", "--output", required=True, help="output BVH (written atomically; never an input file)")
    p.add_argument("--constraints", metavar="YAML", help="matching frames pinned by the animator, joint mappings")
    p.add_argument("--report", metavar="JSON", help="write the alignment report (time map per side, costs, timings)")
    p.add_argument("--plot", metavar="PNG", help="write cost matrices, bands, constraints and paths")
    p.add_argument("--side", choices=("left", "right", "both"), default="both", help="sides to splice (default both)")
    p.add_argument("--hands-side", choices=("left", "right"), help="side of a hand-only file whose joint names do not say")
    p.add_argument("--band", "--band1", dest="band1", default="30%",
                   help="pass-1 band width: frames (120), share of the body take (30%%, the default) or seconds (20s)")
    p.add_argument("--band2", default=None, help="pass-2 band width (default: a third of --band)")
    p.add_argument("--theta", choices=("window", "heading"), default="window",
                   help="vertical-axis alignment: per frame pair from marker windows (paper) or root heading")
    p.add_argument("--passes", choices=("both", "pass1"), default="both", help="run both passes (default) or pass 1 only")
    p.add_argument("--merge", choices=("timemap", "median"), default="timemap",
                   help="smooth time map with slerp (default) or the paper's median + blend")
    p.add_argument("--wrist", choices=("body", "hands"), default="body", help="wrist rotation from the body (default) or the hands take")
    p.add_argument("--hands-markers", metavar="C3D", help="optical markers of the hands session (C3D, TRC, CSV), "
                   "sharing the hands BVH's timeline: the alignment uses them instead of virtual markers")
    p.add_argument("--body-markers", metavar="C3D", help="optical markers of the body session, likewise")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress, no summary (errors still go to stderr)")
    return p


class _Progress:
    """A one-line bar on a terminal; silent otherwise."""

    def __init__(self, stream, enabled: bool):
        self.stream = stream
        self.enabled = enabled and stream.isatty()
        self.stage = None
        self.t0 = time.perf_counter()

    def __call__(self, stage: str, fraction: float) -> None:
        if not self.enabled:
            return
        width = 28
        filled = int(round(width * max(0.0, min(1.0, fraction))))
        self.stream.write(f"\r{stage:<18} [{'#' * filled}{'.' * (width - filled)}] {100 * fraction:5.1f}%  "
                          f"{time.perf_counter() - self.t0:6.1f}s")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\r" + " " * 70 + "\r")
            self.stream.flush()


def _check_output(path: Path, inputs) -> None:
    for i in inputs:
        if i is not None and Path(i).exists() and path.exists() and os.path.samefile(i, path):
            raise SplicerError(f"{path}: the output would overwrite an input file; choose another name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise SplicerError(f"{path}: cannot write the output: folder {parent} does not exist")
    if path.is_dir():
        raise SplicerError(f"{path}: is a folder; give a file name for the output")
    if not os.access(parent, os.W_OK):
        raise SplicerError(f"{path}: cannot write the output: folder {parent} is not writable")


def _write_json(obj, path: Path) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent if str(path.parent) else ".")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(obj, f, indent=1)
        os.replace(tmp, path)
    except OSError as e:
        raise SplicerError(f"{path}: cannot write the report ({e.strerror or e})") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _summary(result, out: Path, elapsed: float) -> str:
    rep = result.report
    b, h = rep["body"], rep["hands"]
    sides = ", ".join(rep["sides"]) or "none"
    stages = ", ".join(f"{k} {v:.2f}s" for k, v in rep["timings_s"].items() if k != "total")
    joints = sum(len(s["joints"]) for s in rep["sides"].values())
    text = (f"Spliced {h['frames']} hand frames at {h['fps']:.4g} fps onto {b['frames']} body frames at "
            f"{b['fps']:.4g} fps; sides: {sides}; {joints} joints driven by the hands take. "
            f"Wrote {out} in {elapsed:.1f}s ({stages}).")
    if rep["warnings"]:
        text += f" {len(rep['warnings'])} warning(s): " + " | ".join(rep["warnings"])
    return text


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    progress = _Progress(sys.stderr, not args.quiet)
    try:
        from .bvh import write_bvh
        from .pipeline import splice

        out = Path(args.output)
        _check_output(out, [args.body, args.hands, args.constraints, args.hands_markers, args.body_markers])
        for extra, what in ((args.report, "report"), (args.plot, "plot")):
            if extra:
                _check_output(Path(extra), [args.body, args.hands, args.constraints, args.output])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # warnings are collected into the report and the summary
            result = splice(args.body, args.hands, config=args.constraints, progress=progress,
                            side=args.side, band1=args.band1, band2=args.band2, theta=args.theta,
                            passes=args.passes, merge=args.merge, wrist=args.wrist, hands_side=args.hands_side,
                            hands_markers=args.hands_markers, body_markers=args.body_markers)
        write_bvh(result.motion, out)
        if args.report:
            _write_json(result.report.to_dict(), Path(args.report))
        if args.plot:
            from .plot import plot_alignment

            progress("plot", 0.5)
            plot_alignment(result, args.plot)
        progress.close()
    except SplicerError as e:
        progress.close()
        print(f"splice: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        progress.close()
        print("splice: interrupted; nothing was written", file=sys.stderr)
        return 130
    if not args.quiet:
        print(_summary(result, out, time.perf_counter() - t0))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
