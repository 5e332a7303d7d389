"""Speed of the splice, stage by stage and side by side, with peak memory.

Pairs (made by :func:`splicer.evaluation.separate.separate`, ALGORITHM.md section 8):

* ``zeggs``: ``../shared/motions/zeggs/067_Speech_2_x_1_0.bvh`` separated with seed 0 (body
  30 fps, hands 60 fps); skipped with a note when the shared folder is absent;
* ``synthetic 20 min``: ``make_gesture_take(1200 s, 60 fps)`` separated with ``hands_fps=120``,
  spliced with the default options (a guided long take: a 4 s pass-1 band around the coarse
  path, ``splicer.defaults.GUIDED_BAND1``) and again with ``band1="20s"`` (the band the README
  suggested for long takes before), with the alignment error against the separation's truth
  (hands frames, mean and 95th percentile per side).

The ``splice`` command runs end to end on the pair written as BVH, both ways (default and
``--band 20s``).

Each case runs in its own child process (the pair is handed over as a pickle, so the child's
memory is the splice's): stage times come from the splice's progress callback (per side),
peak memory is the child's ``VmHWM`` (``ru_maxrss`` where ``/proc`` is missing), with the
resident size after loading the pair shown beside it.  Numba kernels are warmed up on a
tiny pair first, so compile/cache-load time is not counted.

Usage::

    python benchmarks/bench_splice.py [--out benchmarks/results_splice.md] [--minutes 20] [--no-long]

Reference: the paper reports 569 frames in 10.95 s (Matlab, 2006 hardware).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
ZEGGS = REPO.parent / "shared" / "motions" / "zeggs" / "067_Speech_2_x_1_0.bvh"
PAPER_FRAMES, PAPER_SECONDS = 569, 10.95


def _status_kb(key: str) -> float | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return float(line.split()[1])
    except OSError:
        return None
    return None


def child(pickle_path: str, options_json: str) -> None:
    """Run in a child process: load the pair, warm up, splice, print one JSON line."""
    sys.path.insert(0, str(REPO))
    from splicer.evaluation.separate import separate
    from splicer import splice
    from splicer.evaluation.synth import make_gesture_take

    rng = np.random.default_rng(1)
    tiny = separate(make_gesture_take(4, 30, rng), rng=rng)
    splice(tiny.body, tiny.hands)  # numba warm-up
    with open(pickle_path, "rb") as f:
        body, hands, truth = pickle.load(f)
    rss_loaded = _status_kb("VmRSS")
    options = json.loads(options_json)
    marks: list[tuple[str, float]] = []

    def progress(stage: str, fraction: float) -> None:
        if not marks or marks[-1][0] != stage:
            marks.append((stage, time.perf_counter()))

    t0 = time.perf_counter()
    res = splice(body, hands, progress=progress, **options)
    total = time.perf_counter() - t0
    stages = {}
    for (name, t), (_, t_next) in zip(marks, marks[1:]):
        stages[name] = stages.get(name, 0.0) + (t_next - t)
    peak = _status_kb("VmHWM")
    if peak is None:
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    error = {}
    if truth is not None:
        for s, r in res.sides.items():
            e = np.abs(r.hands_frame - truth)
            error[s] = [float(np.nanmean(e)), float(np.nanpercentile(e, 95))]
    print(json.dumps({"error": error, "stages": stages, "total": total, "timings_s": res.report["timings_s"],
                      "peak_mb": peak / 1024, "loaded_mb": (rss_loaded or float("nan")) / 1024,
                      "band1": {s: r.pass1.band.width for s, r in res.sides.items() if r.pass1 is not None},
                      "band2": {s: r.pass2.band.width for s, r in res.sides.items() if r.pass2 is not None}}))


def run_case(name: str, body, hands, options: dict, tmp: Path, truth=None) -> dict:
    p = tmp / f"{name.replace(' ', '_')}.pkl"
    with open(p, "wb") as f:
        pickle.dump((body, hands, truth), f, protocol=pickle.HIGHEST_PROTOCOL)
    out = subprocess.run([sys.executable, __file__, "--child", str(p), json.dumps(options)],
                         capture_output=True, text=True, check=False)
    p.unlink()
    if out.returncode != 0:
        last = out.stderr.strip().splitlines()[-1] if out.stderr.strip() else f"exit status {out.returncode}"
        raise RuntimeError(last)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    r.update(name=name, n_body=body.n_frames, body_fps=body.fps, n_hands=hands.n_frames, hands_fps=hands.fps,
             options=options)
    return r


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def cli_child(body: str, hands: str, out: str, report: str, band: str) -> None:
    """Run in a child process: the ``splice`` command in-process (``--band band`` unless empty),
    then print wall time and VmHWM."""
    sys.path.insert(0, str(REPO))
    from splicer.cli import main

    t0 = time.perf_counter()
    code = main([body, hands, "-o", out, "--quiet", "--report", report] + (["--band", band] if band else []))
    wall = time.perf_counter() - t0
    peak = _status_kb("VmHWM") or resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"code": code, "wall": wall, "peak_mb": peak / 1024}))


def run_cli(sep, tmp: Path, band: str = "") -> dict:
    from splicer.io.bvh import write_bvh

    body, hands, out, rep = tmp / "body.bvh", tmp / "hands.bvh", tmp / "out.bvh", tmp / "report.json"
    if not body.exists():
        write_bvh(sep.body, body)
        write_bvh(sep.hands, hands)
    # warm the numba cache in this environment first (a user's second run)
    subprocess.run([sys.executable, "-c", "import numpy as np; from splicer.evaluation.synth import make_gesture_take; "
                    "from splicer.evaluation.separate import separate; from splicer import splice; "
                    "r = np.random.default_rng(1); s = separate(make_gesture_take(4, 30, r), rng=r); "
                    "splice(s.body, s.hands, band1='2s', coarse='on')"], check=True, cwd=str(REPO))
    res = subprocess.run([sys.executable, __file__, "--cli", str(body), str(hands), str(out), str(rep), band],
                         capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise RuntimeError(res.stderr.strip().splitlines()[-1] if res.stderr.strip() else "splice failed")
    r = json.loads(res.stdout.strip().splitlines()[-1])
    r["timings_s"] = json.loads(rep.read_text())["timings_s"]
    r["pandas_s"] = pandas_read_seconds([body, hands])
    r["body_mb"] = body.stat().st_size / 2**20
    r["hands_mb"] = hands.stat().st_size / 2**20
    return r


def pandas_read_seconds(paths) -> float:
    """Wall seconds pandas' C parser takes to read the motion blocks of ``paths`` (the yardstick)."""
    import pandas as pd

    t0 = time.perf_counter()
    for p in paths:
        with open(p, "rb") as f:
            skip = 0
            for line in f:
                skip += 1
                if line.startswith(b"Frame Time"):
                    break
        pd.read_csv(p, sep=" ", header=None, skiprows=skip, engine="c", dtype=np.float64).to_numpy()
    return time.perf_counter() - t0


def table(results: list[dict]) -> str:
    lines = []
    for r in results:
        lines.append(f"### {r['name']}: body {r['n_body']} frames @ {r['body_fps']:g} fps, hands {r['n_hands']} frames "
                     f"@ {r['hands_fps']:g} fps, options {r['options'] or 'default'}")
        lines.append(f"band widths (body frames): pass 1 {r['band1']}, pass 2 {r['band2']}\n")
        if r.get("error"):
            lines.append("alignment error against the truth (hands frames): " + "; ".join(
                f"{s} mean {e[0]:.2f}, p95 {e[1]:.2f}" for s, e in sorted(r["error"].items())) + "\n")
        lines.append("| side | markers (s) | pass 1 (s) | expected path (s) | arms' own paths (s) | pass 2 (s) "
                     "| confidence (s) | transfer (s) | total (s) |")
        lines.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for side in ("left", "right", "both hands"):  # "both hands": one pass 1 for both arms (0.5.0)
            st = {k.split(": ", 1)[1]: v for k, v in r["stages"].items() if k.startswith(side + ": ")}
            if not st:
                continue
            cells = [st.get(k, 0.0) for k in ("markers", "pass 1", "expected", "check", "pass 2", "confidence",
                                               "transfer")]
            lines.append(f"| {side} | " + " | ".join(f"{c:.2f}" for c in cells) + f" | {sum(cells):.2f} |")
        checks = sum(v for k, v in r["stages"].items() if k.startswith("checks"))
        lines.append(f"\nHands checks (dropouts, handedness) before the sides: {checks:.2f} s.")
        fps = r["n_body"] / r["total"]
        lines.append(f"\nSplice {r['total']:.2f} s (Euler-to-quaternion conversion of the joints it needs included): "
                     f"{fps:,.0f} body frames/s overall; peak memory (VmHWM of the child) "
                     f"{r['peak_mb']:,.0f} MB, of which {r['loaded_mb']:,.0f} MB resident after loading the pair.\n")
    lines.append(f"Paper (Matlab, 2006): {PAPER_FRAMES} frames in {PAPER_SECONDS} s "
                 f"({PAPER_FRAMES / PAPER_SECONDS:.0f} frames/s).")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=None, help="also write the tables to this markdown file")
    ap.add_argument("--minutes", type=float, default=20.0, help="length of the synthetic pair (default 20)")
    ap.add_argument("--no-long", action="store_true", help="skip the synthetic pair")
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    ap.add_argument("--cli", nargs=5, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(*args.child)
        return 0
    if args.cli:
        cli_child(*args.cli)
        return 0
    sys.path.insert(0, str(REPO))
    from splicer.io.bvh import read_bvh
    from splicer.evaluation.separate import separate
    from splicer.evaluation.synth import make_gesture_take

    results, notes = [], []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if ZEGGS.is_file():
            take = read_bvh(ZEGGS)
            sep = separate(take, rng=np.random.default_rng(0))
            results.append(run_case("zeggs 067_Speech_2_x_1_0 (seed 0)", sep.body, sep.hands, {}, tmp, sep.truth))
            print(f"zeggs done: {results[-1]['total']:.2f} s", file=sys.stderr, flush=True)
        else:
            notes.append(f"{ZEGGS} not found: the zeggs case was skipped.")
        if not args.no_long:
            rng = np.random.default_rng(0)
            t0 = time.perf_counter()
            take = make_gesture_take(60.0 * args.minutes, 60.0, rng)
            t1 = time.perf_counter()
            sep = separate(take, rng=rng, hands_fps=120.0)
            t2 = time.perf_counter()
            notes.append(f"Making the {args.minutes:g}-minute pair: make_gesture_take {t1 - t0:.1f} s, "
                         f"separate {t2 - t1:.1f} s (not counted above).")
            print(notes[-1], file=sys.stderr, flush=True)
            del take
            name = f"synthetic {args.minutes:g} min"
            for options, label in (({}, "default options"), ({"band1": "20s"}, "band1 20s")):
                results.append(run_case(f"{name}, {label}", sep.body, sep.hands, options, tmp, sep.truth))
                print(f"{name}, {label} done: {results[-1]['total']:.2f} s", file=sys.stderr, flush=True)
            for band in ("", "20s"):
                cli = run_cli(sep, tmp, band)
                command = "splice body.bvh hands.bvh -o out.bvh" + (f" --band {band}" if band else "")
                notes.append(
                    f"End to end, the command a user runs (`{command}`) on the "
                    f"{args.minutes:g}-minute pair written as BVH ({cli['body_mb']:.0f} MB + {cli['hands_mb']:.0f} MB): "
                    f"**{cli['wall']:.1f} s** wall (read {cli['timings_s'].get('read', 0):.1f} s, splice "
                    f"{cli['timings_s']['total'] - cli['timings_s'].get('read', 0):.1f} s, the rest writing the output), "
                    f"peak memory **{cli['peak_mb']:,.0f} MB** (VmHWM). pandas' C parser reads the two files' motion "
                    f"blocks in {cli['pandas_s']:.1f} s: the whole splice takes {cli['wall'] / cli['pandas_s']:.2f}x that.")
                print(notes[-1], file=sys.stderr, flush=True)
    text = (f"# Splice speed (benchmarks/bench_splice.py)\n\nMachine: {_cpu_model()}, "
            f"{os.cpu_count()} cores, Python {platform.python_version()}. Input pairs are in memory (no BVH read).\n\n"
            + table(results) + ("\n" + "\n".join(notes) + "\n" if notes else ""))
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")
        Path(args.out).with_suffix(".json").write_text(json.dumps(results, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
