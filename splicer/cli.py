"""The ``splice`` command: parses options and calls :func:`splicer.splice`.

Exit status: 0 done, 1 bad input (files, joints, constraints, output path), 2 usage,
130 / 143 / 129 interrupted by SIGINT / SIGTERM / SIGHUP.

The outputs (``-o``, ``--report``, ``--plot``) are one transaction (:mod:`splicer.atomic`):
all are written to temporaries and renamed only when all are complete; on an error or a
signal the temporaries are removed and the message says what exists.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import time
import warnings
from pathlib import Path

from . import __version__
from . import defaults as D
from .io.atomic import Transaction, write_text_atomic
from .errors import SplicerError
from .io.limits import one_line, shorten

EXAMPLES = """\
examples:
  splice body.bvh hands.bvh -o out.bvh
  splice body.fbx hands.fbx -o out.fbx
  splice body.bvh hands.bvh -o out.bvh --constraints sync.yaml
  splice body.bvh hands.bvh -o out.bvh --report report.json --plot align.png
  splice body.bvh right_hand.bvh -o out.bvh --side right --band 20s

bands take frames (120), a share of the body take (30%%) or seconds (20s).
The constraints file format is in the README (section "Constraints file").
"""


class _Parser(argparse.ArgumentParser):
    """Usage errors on one line (exit 2)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {one_line(message, 300)} (see {self.prog} --help)\n")


def _band_text(text: str) -> str:
    """A band width as typed; refuses absurdly long text before any parsing (regex) sees it."""
    if len(text) > 40:
        raise argparse.ArgumentTypeError(f"band width {shorten(text, 20)} is {len(text):,} characters long")
    return text


def _finite_at_least(text: str, low: float, expected: str) -> float:
    """``text`` as a finite number >= ``low``, else the argparse error naming what was expected."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (v >= low and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be {expected}, not {text!r}")
    return v


def _noise_ratio(text: str) -> float | str | None:
    if text in ("auto", "off"):
        return None if text == "off" else text
    return _finite_at_least(text, 1.0, "auto, off or a number >= 1 (e.g. 1.2)")


def _position_weight(text: str) -> float | str:
    if text == "auto":
        return text
    return _finite_at_least(text, 0.0, "auto or a number >= 0 (e.g. 3; 0 is the paper's D1 alone)")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="splice",
        description="Splice a hand capture's finger motion onto a full-body capture: the output keeps the "
                    "body take's skeleton, frames and timing, with the fingers (and optionally the wrists) "
                    "driven by the hands take, aligned by two-pass dynamic time warping.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("body", help="full-body BVH or FBX (its timing is kept; FBX needs splicer[blender])")
    p.add_argument("hands", help="hand BVH or FBX: a full skeleton, a forearm-rooted or a wrist-rooted hand")
    p.add_argument("-o", "--output", required=True, help="output BVH or FBX, by suffix (written atomically; never an input file)")
    p.add_argument("--constraints", metavar="YAML", help="matching frames pinned by the animator, joint mappings")
    p.add_argument("--report", metavar="JSON", help="write the alignment report (time map per side, costs, timings)")
    p.add_argument("--plot", metavar="PNG", help="write cost matrices, bands, constraints and paths")
    p.add_argument("--side", choices=("left", "right", "both"), default="both", help="sides to splice (default both)")
    p.add_argument("--hands-side", choices=("left", "right"), help="side of a hand-only file whose joint names do not say")
    p.add_argument("--band", "--band1", dest="band1", default=None, type=_band_text,
                   help="pass-1 band width: frames (120), share of the body take (30%%) or seconds (20s); default 3s "
                        "around the located overlap with open ends, 30%% with fixed ends (takes over 2 minutes: 4s around "
                        "the guide path)")
    p.add_argument("--ends", choices=("auto", "open", "fixed"), default=None,
                   help="open: find where the takes overlap (the hands take may start early, stop late or cover part "
                        "of the body); fixed: first frames match, last frames match (the paper); auto (default): open, "
                        "but end to end when the takes are found to start and end together, when the hands material "
                        "the open ends leave continues the performance (slower hands near an end), or when the overlap "
                        "found is implausibly short (with a note)")
    p.add_argument("--offset", type=float, default=None, metavar="SECONDS",
                   help="open ends: body frame 0 shows this hands time (a starting guess, e.g. from timecode)")
    p.add_argument("--noise-ratio", type=_noise_ratio, default="auto", metavar="R",
                   help="when one take's arm is noisier (a second performance), smooth both more until their "
                        f"direction changes agree within this factor: auto (default: when they differ over "
                        f"{D.NOISE_TRIGGER:g}x, until within {D.NOISE_RATIO:g}x), a number R (whenever over R), or off")
    p.add_argument("--position-weight", type=_position_weight, default="auto", metavar="W",
                   help="pass 1 weighs where the wrists and hands are (shoulder-relative, normalised per take) "
                        f"beside D1's direction signs: auto (default: {D.POSITION_WEIGHT_NOISY:g} where a noisier "
                        f"take's markers are smoothed, else {D.POSITION_WEIGHT:g} with fixed ends and 0 open-ended; "
                        f"0 against hand-only files; optical markers: the hand's turns in the forearm alone, "
                        f"{D.OPTICAL_SIGN_WEIGHT:g}), a number W, or 0 (D1 alone, the paper)")
    p.add_argument("--pass1-arms", choices=("both", "each"), default=D.PASS1_ARMS,
                   help="both (default): one pass 1 weighs both arms, as both hands of the hands take share its "
                        "clock (pass 2 stays per side); each: every side its own pass 1 (the paper)")
    p.add_argument("--band2", default=None, type=_band_text, help="pass-2 band width (default: a third of --band)")
    p.add_argument("--theta", choices=("window", "heading"), default="window",
                   help="vertical-axis alignment: per frame pair from marker windows (paper) or root heading")
    p.add_argument("--passes", choices=("auto", "both", "pass1"), default="auto",
                   help="auto (default): both passes, but pass 1 alone for a side aligned on optical markers; "
                        "both; or pass 1 only")
    p.add_argument("--merge", choices=("timemap", "median"), default="timemap",
                   help="smooth time map with slerp (default) or the paper's median + blend")
    p.add_argument("--wrist", choices=("body", "hands"), default="body", help="wrist rotation from the body (default) or the hands take")
    p.add_argument("--mirror-hands", choices=("auto", "yes", "no"), default=None,  
                   help="mirror the hands take (a left-handed export) so its fingers flex toward the palm: auto "
                        "(the default: when its geometry is the other hand's), yes or no")
    p.add_argument("--body-holds", choices=("on", "off"), default="on",
                   help="where the body holds still (every arm, at least 0.5 s), keep the time map on one hands "
                        "frame: on (default) or off")
    p.add_argument("--both-skip", choices=("auto", "on", "off"), default="auto",
                   help="open ends: the takes may overlap partly, the alignment skipping both takes' first (last) "
                        "frames at once: auto (default: where the hand's motion in the forearm compares, checked "
                        "against starting and ending on one take's first and last frames), on, or off")
    p.add_argument("--no-repair", action="store_true", help="keep dropouts/gaps of the hands capture as they are "
                   "(default: repair them before aligning, listed in the report)")  # issue 9 (c-handonly)
    p.add_argument("--hands-markers", metavar="C3D", help="optical markers of the hands session (C3D, TRC, CSV), "
                   "sharing the hands BVH's timeline: the alignment uses them instead of virtual markers")
    p.add_argument("--body-markers", metavar="C3D", help="optical markers of the body session, likewise")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress, no summary (errors still go to stderr)")
    p.add_argument("--version", action="version", version=f"%(prog)s (splicer) {__version__}")
    return p


class _Progress:
    """A one-line bar on a terminal; silent otherwise."""

    def __init__(self, stream, enabled: bool):
        self.stream = stream
        self.enabled = enabled and stream.isatty()
        self.stage = None
        self.t0 = time.perf_counter()
        self.longest = 0  # characters of the longest line written: a shorter one must cover it

    def __call__(self, stage: str, fraction: float) -> None:
        if not self.enabled:
            return
        width = 28
        filled = int(round(width * max(0.0, min(1.0, fraction))))
        line = (f"{stage:<18} [{'#' * filled}{'.' * (width - filled)}] {100 * fraction:5.1f}%  "
                f"{time.perf_counter() - self.t0:6.1f}s")
        self.stream.write("\r" + line.ljust(self.longest))
        self.longest = max(self.longest, len(line))
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\r" + " " * self.longest + "\r")
            self.stream.flush()


def _same_file(a, b) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _check_output(path: Path, inputs) -> None:
    if len(os.fsencode(path.name)) > 255:
        raise SplicerError(f"{shorten(str(path))}: the file name is {len(path.name)} characters long; "
                           "a file system allows at most 255 bytes")
    for i in inputs:
        if i is not None and Path(i).exists() and path.exists() and os.path.samefile(i, path):
            raise SplicerError(f"{path}: the output would overwrite an input file; choose another name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise SplicerError(f"{path}: cannot write the output: folder {parent} does not exist")
    if path.is_dir():
        raise SplicerError(f"{path}: is a folder; give a file name for the output")
    if path.exists() and not path.is_file():
        raise SplicerError(f"{path}: exists and is not a regular file (a device or a pipe); give a file name "
                           "for the output")
    if not os.access(parent, os.W_OK):
        raise SplicerError(f"{path}: cannot write the output: folder {parent} is not writable")


def _write_json(obj, path: Path) -> None:
    """A report (``splice``, ``splice-markers``) as :func:`splicer.report.json_text`, atomically."""
    from .report import json_text

    write_text_atomic(path, json_text(obj), what="report")


def _check_distinct(outputs: list[tuple[str, str]]) -> None:
    """Refuse two outputs naming the same file (same path, symbolic or hard link)."""
    for k, (a, pa) in enumerate(outputs):
        for b, pb in outputs[:k]:
            if _same_file(pa, pb):
                raise SplicerError(f"{pa}: {a} and {b} name the same file; give each output its own name")


class _Signalled(BaseException):
    """SIGTERM or SIGHUP received (raised by the handler ``main`` installs)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: Signals the handlers ``main`` installs have seen in this run (one raised inside a weakref
#: callback or a ``__del__`` is only printed by Python as "Exception ignored", and lost: ``main``
#: then acts on it before committing its outputs).
_RECEIVED: list[int] = []


def _raise_signalled(signum, frame):
    _RECEIVED.append(signum)
    raise _Signalled(signum)


def _interrupt(signum, frame):
    _RECEIVED.append(signum)
    raise KeyboardInterrupt


def _forget_caught_interrupt() -> None:
    """Call where a command has caught Ctrl-C's KeyboardInterrupt and reports it itself.

    CPython remembers a KeyboardInterrupt that left code run by ``exec`` of a string (dataclasses,
    namedtuples and numba build functions that way), and under ``python -m`` kills the process
    with SIGINT when it exits, even after the command caught the interrupt and returned 130: the
    caller then sees a signal death after the command's own message.  Running an empty string the
    same way clears that record.
    """
    exec("None", {})


def _act_on_lost_signal() -> None:
    """Raise for a signal whose exception was swallowed (``_RECEIVED`` without the exception seen)."""
    if _RECEIVED:
        if _RECEIVED[0] == signal.SIGINT:
            raise KeyboardInterrupt
        raise _Signalled(_RECEIVED[0])


def _quiet_unraisable(previous):
    """A ``sys.unraisablehook`` that drops the interrupts ``_RECEIVED`` records (no "Exception
    ignored" on stderr) and passes anything else on to ``previous``."""

    def hook(unraisable):
        if _RECEIVED and isinstance(unraisable.exc_value, (_Signalled, KeyboardInterrupt)):
            return  # recorded: main acts on it
        previous(unraisable)

    return hook


def _install_handlers() -> dict:
    """SIGTERM and SIGHUP raise :class:`_Signalled` (so the outputs are cleaned up) while main runs,
    and SIGINT raises KeyboardInterrupt as Python's own handler does; each is recorded in
    :data:`_RECEIVED` first.

    Only in the main thread, and only where the signal has its default action (a SIGHUP
    ignored by ``nohup`` stays ignored).  Returns the previous handlers.
    """
    old = {}
    if threading.current_thread() is not threading.main_thread():
        return old
    _RECEIVED.clear()
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) == signal.SIG_DFL:
            old[sig] = signal.signal(sig, _raise_signalled)
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # Ctrl-C: KeyboardInterrupt, recorded
        old[signal.SIGINT] = signal.signal(signal.SIGINT, _interrupt)
    return old


def _summary(result, out: Path, elapsed: float, after: dict | None = None, before: dict | None = None) -> str:
    """The one-paragraph summary; ``before``, ``after``: times of the steps before the splice (starting
    numba) and after it (write, plot), seconds."""
    rep = result.report
    b, h = rep["body"], rep["hands"]
    sides = ", ".join(rep["sides"]) or "none"
    times = dict(before or {}) | {k: v for k, v in rep["timings_s"].items() if k != "total"} | dict(after or {})
    stages = ", ".join(f"{k} {v:.2f}s" for k, v in times.items())
    joints = sum(len(s["joints"]) for s in rep["sides"].values())
    text = (f"Spliced {h['frames']} hand frames at {h['fps']:.4g} fps onto {b['frames']} body frames at "
            f"{b['fps']:.4g} fps; sides: {sides}; {joints} joints driven by the hands take. "
            f"Wrote {out} in {elapsed:.1f}s ({stages}).")
    if rep["warnings"]:
        text += f" {len(rep['warnings'])} warning(s): " + " | ".join(rep["warnings"])
    return text


def _start_numba_without_scipy() -> None:
    """Start numba's compiler without importing scipy: 0.2 s of a warm run's 1.2 s on the sample.

    numba imports scipy to check its version (``numba/__init__``), and when it loads or compiles its
    first kernel, ``scipy.linalg`` to find a BLAS for ``np.dot`` and ``np.linalg`` inside kernels (which
    pulls in ``numpy.testing`` and ``numpy.f2py``).  No kernel of splicer calls either.  So the command
    (which owns its process) starts numba while ``import scipy`` fails: numba records that this process
    has no BLAS for kernels, and scipy stays importable for everything else (gap filling imports it
    when a take has gaps).  Skipped when numba or scipy is already loaded (``main`` called by a program
    that uses them): the result is the same either way, byte for byte.
    """
    if "numba" in sys.modules or "scipy" in sys.modules:
        return
    sys.modules["scipy"] = None  # `import scipy` raises ImportError, which numba takes as "no scipy"
    try:
        from numba.core.registry import cpu_target

        cpu_target.target_context.refresh()  # what numba's first kernel load would do (once per process)
    finally:
        del sys.modules["scipy"]


def main(argv=None) -> int:
    """The ``splice`` command in this process (``argv``: its arguments, default ``sys.argv[1:]``); returns
    the exit status.  The ``splice`` script and ``python -m splicer.cli`` first offer the run to a running
    ``splice-server`` (:func:`splicer.server_client.main`)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    progress = _Progress(sys.stderr, not args.quiet)
    old_handlers = _install_handlers()
    old_hook, sys.unraisablehook = sys.unraisablehook, _quiet_unraisable(sys.unraisablehook)
    tx = Transaction()
    helper = None
    try:
        from . import _warmup
        from .io.atomic import _signals_held

        with _signals_held():  # a signal during the imports takes effect after them, not half-way through
            from .io.motion_io import write_motion
            from .pipeline import splice

        out = Path(args.output)
        outputs = [("-o", args.output)] + [(o, v) for o, v in (("--report", args.report), ("--plot", args.plot)) if v]
        for _, o in outputs:
            _check_output(Path(o), [args.body, args.hands, args.constraints, args.hands_markers, args.body_markers])
        _check_distinct(outputs)
        t1 = time.perf_counter()
        with _signals_held():  # numba half-initialised by an interrupt can crash the interpreter's exit
            _start_numba_without_scipy()
            helper = _warmup.start()  # a first run: a second process compiles the kernels from the end
        before = {"numba": time.perf_counter() - t1}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # warnings are collected into the report and the summary
            result = splice(args.body, args.hands, config=args.constraints, progress=progress,
                            side=args.side, band1=args.band1, band2=args.band2, theta=args.theta,
                            passes=args.passes, merge=args.merge, wrist=args.wrist, hands_side=args.hands_side,
                            mirror_hands=args.mirror_hands, repair="off" if args.no_repair else "on",
                            hands_markers=args.hands_markers, body_markers=args.body_markers, ends=args.ends,
                            offset_s=args.offset, noise_ratio=args.noise_ratio,
                            position_weight=args.position_weight, pass1_arms=args.pass1_arms,
                            body_holds=args.body_holds, both_skip=args.both_skip)
        after = {}
        with tx:  # every output is staged, and appears only at tx.commit()
            progress("write", 0.0)
            t1 = time.perf_counter()
            write_motion(result.motion, out, progress=lambda f: progress("write", f))  # BVH or FBX by suffix
            if args.report:
                progress("report", 0.0)  # a long take's report (per-frame confidence) takes a second or two
                _write_json(result.report.to_dict(), Path(args.report))
            after["write"] = time.perf_counter() - t1
            if args.plot:
                progress("plot", 0.5)
                t1 = time.perf_counter()  # the plot's time includes importing what draws it
                with _signals_held():  # an interrupt inside Pillow's C extensions (start-up, drawing) is an ImportError or worse
                    import PIL.Image  # noqa: F401
                    import PIL.ImageDraw  # noqa: F401

                    from .plot import plot_alignment

                    plot_alignment(result, args.plot)
                after["plot"] = time.perf_counter() - t1
            progress.close()
            _act_on_lost_signal()
            tx.commit()
        _act_on_lost_signal()
        if not args.quiet:
            print(_summary(result, out, time.perf_counter() - t0, after, before))
    except SplicerError as e:
        progress.close()
        print(f"splice: error: {one_line(str(e))}", file=sys.stderr)
        return 1
    except MemoryError:
        progress.close()
        print("splice: error: out of memory", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, _Signalled) as e:
        progress.close()
        signum = e.signum if isinstance(e, _Signalled) else signal.SIGINT
        name = signal.Signals(signum).name
        if tx.committed:
            what = f"after writing {', '.join(str(p) for p in tx.committed)} (complete)"
        else:
            what = "nothing was written"
        print(f"splice: interrupted ({name}); {what}", file=sys.stderr)
        _forget_caught_interrupt()
        return 128 + int(signum)
    finally:
        if helper is not None:
            _warmup.stop(helper)
        for sig, handler in old_handlers.items():
            signal.signal(sig, handler)
        sys.unraisablehook = old_hook
    return 0


if __name__ == "__main__":  # pragma: no cover
    from splicer.server_client import main as command

    sys.exit(command())
