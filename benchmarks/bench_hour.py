"""The hour-long pair end to end: a 60-minute body at 60 fps and a 70-minute hands take at 120 fps.

Usage::

    nice python benchmarks/bench_hour.py [--minutes 60] [--hands-minutes 70] [--dir /tmp/splicer_hour]

The pair (made once, kept in ``--dir``, never in the repository): the synthetic speaker
(:func:`splicer.evaluation.synth.make_gesture_take`, seed ``--seed``) for ``--minutes`` at 60
fps, separated (:func:`splicer.evaluation.separate.separate`, ALGORITHM.md section 8, local
speed of the hands clock 0.8-1.25x) into a body take and a hands take at 120 fps; the hands
take is then padded to ``--hands-minutes`` with unrelated gestures (another speaker, seed + 1)
before and after, so its ends are open (the splice runs with the default ``ends=auto``).

The ``splice`` command runs in a child process under ``/usr/bin/time -v`` (peak memory: its
maximum resident set size) inside a pseudo-terminal (``script``), so the progress bar is
drawn as a user sees it; every bar update is parsed (stage, percentage, the bar's own clock)
to show how long each stage held the bar and the longest wait without an update.
"""

from __future__ import annotations

import argparse
import json
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

_BAR = re.compile(r"^(?P<stage>\S.*?)\s+\[[#.]+\]\s+(?P<pct>[\d.]+)%\s+(?P<t>[\d.]+)s")


def make_pair(directory: Path, minutes: float, hands_minutes: float, seed: int) -> tuple[Path, Path]:
    """Write body.bvh and hands.bvh into ``directory`` (skipped when both exist)."""
    from splicer.evaluation.separate import separate
    from splicer.evaluation.synth import make_gesture_take
    from splicer.io.bvh import write_bvh
    from splicer.model.motion import Motion

    body_p, hands_p = directory / "body.bvh", directory / "hands.bvh"
    if body_p.is_file() and hands_p.is_file():
        return body_p, hands_p
    directory.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    take = make_gesture_take(60.0 * minutes, 60.0, rng)
    sep = separate(take, rng=rng, hands_fps=120.0, warp_speed=(0.8, 1.25))
    del take
    hands = sep.hands
    want = int(round(60.0 * hands_minutes * hands.fps))
    extra = max(want - hands.n_frames, 0)
    pre = extra // 2
    filler = make_gesture_take((extra + 2) / hands.fps, hands.fps, np.random.default_rng(seed + 1))
    if filler.skeleton.names != hands.skeleton.names or filler.skeleton.channels != hands.skeleton.channels:
        raise RuntimeError("the filler take does not have the hands take's skeleton")
    channels = np.concatenate([filler.channels[:pre], hands.channels, filler.channels[pre:extra]])
    hands = Motion(hands.skeleton, channels, hands.frame_time, source="hands")
    del filler, channels
    print(f"made the pair in {time.perf_counter() - t0:.0f} s: body {sep.body.n_frames:,} frames @ "
          f"{sep.body.fps:g} fps, hands {hands.n_frames:,} frames @ {hands.fps:g} fps "
          f"({pre:,} unrelated frames before, {extra - pre:,} after)", flush=True)
    for m, p in ((sep.body, body_p), (hands, hands_p)):
        t0 = time.process_time()
        write_bvh(m, p)
        dt = time.process_time() - t0
        print(f"wrote {p} ({p.stat().st_size / 1e6:,.0f} MB) in {dt:.1f} CPU s: "
              f"{p.stat().st_size / 1e6 / dt:,.0f} MB/s", flush=True)
    return body_p, hands_p


def bar_updates(text: str) -> list[tuple[str, float, float]]:
    """(stage, percent, seconds on the bar's clock) of every progress-bar update in ``text``."""
    out = []
    for piece in re.split(r"[\r\n]", text):
        m = _BAR.match(piece.strip())
        if m:
            out.append((m["stage"], float(m["pct"]), float(m["t"])))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0, help="body length, minutes (default 60)")
    ap.add_argument("--hands-minutes", type=float, default=70.0, help="hands length, minutes (default 70)")
    ap.add_argument("--dir", default="/tmp/splicer_hour", help="where the pair and the output go")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    d = Path(args.dir)
    body, hands = make_pair(d, args.minutes, args.hands_minutes, args.seed)
    out, rep, tfile = d / "out.bvh", d / "report.json", d / "time.txt"
    code = (f"import sys; sys.path.insert(0, {str(REPO)!r}); from splicer.cli import main; "
            f"sys.exit(main({[str(body), str(hands), '-o', str(out), '--report', str(rep)]!r}))")
    cmd = ["/usr/bin/time", "-v", "-o", str(tfile), sys.executable, "-c", code]
    t0 = time.perf_counter()
    res = subprocess.run(["script", "-q", "-e", "-c", shlex.join(cmd), "/dev/null"],
                         capture_output=True, text=True, errors="replace", check=False)
    wall = time.perf_counter() - t0
    timing = tfile.read_text() if tfile.is_file() else ""
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", timing)
    peak_mb = int(rss.group(1)) / 1024 if rss else float("nan")
    print(f"\nsplice {body.name} ({body.stat().st_size / 1e6:,.0f} MB) {hands.name} "
          f"({hands.stat().st_size / 1e6:,.0f} MB): exit {res.returncode}, wall {wall:.0f} s, "
          f"peak RSS {peak_mb:,.0f} MB (/usr/bin/time -v)")
    tail = [ln for ln in res.stdout.replace("\r", "\n").splitlines() if ln.strip() and not _BAR.match(ln.strip())]
    print("\n".join(tail[-6:]))
    ups = bar_updates(res.stdout)
    if ups:
        print(f"\nprogress bar: {len(ups)} updates; stage, bar clock at its first and last update, percent")
        stages: dict[str, list] = {}
        for s, pct, t in ups:
            stages.setdefault(s, []).append((t, pct))
        for s, v in stages.items():
            print(f"  {s:18s} {v[0][0]:7.1f} s .. {v[-1][0]:7.1f} s   {v[0][1]:5.1f}% .. {v[-1][1]:5.1f}%")
        gaps = [(ups[k + 1][2] - ups[k][2], ups[k][0], ups[k][1]) for k in range(len(ups) - 1)]
        g = max(gaps) if gaps else (0.0, "", 0.0)
        print(f"  longest wait without an update: {g[0]:.1f} s (at {g[1]} {g[2]:.1f}%); after the last update "
              f"({ups[-1][0]} {ups[-1][1]:.0f}% at {ups[-1][2]:.1f} s) the command ran until {wall:.1f} s")
    if rep.is_file():
        r = json.loads(rep.read_text())
        print("report timings_s:", {k: round(v, 1) for k, v in r.get("timings_s", {}).items()})
        print("report warnings:", r.get("warnings"))
    return res.returncode


if __name__ == "__main__":
    raise SystemExit(main())
