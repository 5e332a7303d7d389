"""Open-ended pass 1 on a long take: a body of N minutes inside a hands session 1.25x as long.

Run ``python benchmarks/bench_openend.py`` (20-minute body inside a 25-minute hands session,
30 fps) or ``--minutes 2`` for a quick check.  Synthetic gesture-like markers (random
targets, smooth moves, holds); the hands take is the body time-warped (local speed
0.8-1.25x) with unrelated motion before and after (1/8 of the body length each).  Prints
time, peak memory (VmHWM growth of this process) and the alignment error against the truth.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from splicer.align.passes import pass1, path_median, warp_markers  # noqa: E402
from splicer.align.confidence import pass_confidence  # noqa: E402
from splicer.rig.markers import Markers  # noqa: E402
from splicer.align.openend import OPEN_COARSE_FPS, locate_rates  # noqa: E402

FPS = 30.0


def hwm_mb() -> float:
    return [int(ln.split()[1]) for ln in open("/proc/self/status") if ln.startswith("VmHWM")][0] / 1024


def gesture_markers(rng, n, fps=FPS) -> Markers:
    """n frames of gesture-like arm markers (cm): moves of 0.3-1.5 s between random targets, holds of 0-1 s."""
    keys_t, keys_p = [0.0], [rng.uniform(-15, 15, 3)]
    t = 0.0
    while t < n / fps + 2:
        t += rng.uniform(0.3, 1.5)
        keys_t.append(t)
        keys_p.append(rng.uniform(-15, 15, 3))
        if rng.random() < 0.4:
            t += rng.uniform(0.1, 1.0)
            keys_t.append(t)
            keys_p.append(keys_p[-1])
    kt, kp = np.array(keys_t), np.array(keys_p)
    tt = np.arange(n) / fps
    base = np.stack([np.interp(tt, kt, kp[:, k]) for k in range(3)], axis=1)
    base = gaussian_filter1d(base, 0.08 * fps, axis=0, mode="nearest") + np.array([20.0, -30.0, 10.0])
    twist = gaussian_filter1d(rng.normal(size=n), 0.3 * fps) * 8.0
    side = np.stack([np.cos(twist), np.zeros(n), np.sin(twist)], axis=1) * 3.0
    pts = np.stack([base + side, base - side, 0.5 * base, base + np.array([0.0, -8.0, 0.0]) + 0.5 * side], axis=1)
    pts = pts + rng.normal(scale=0.05, size=pts.shape)
    return Markers(pts, np.zeros((n, 3)), np.zeros(n), 1, fps, "right")


def concat(parts) -> Markers:
    return Markers(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("points", "shoulder", "heading")),
                   parts[0].up, parts[0].fps, parts[0].side)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=20.0, help="body length in minutes (default 20)")
    ap.add_argument("--width-s", type=float, default=2.0, help="full-rate band width, seconds (default 2)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    n = int(args.minutes * 60 * FPS)
    body = gesture_markers(rng, n)
    span = int(n * rng.uniform(0.95, 1.05))
    speed = np.exp(0.2 * gaussian_filter1d(rng.normal(size=span), 5 * FPS) * np.sqrt(5 * FPS))
    t = np.concatenate([[0.0], np.cumsum(speed[:-1])])
    warp = t / t[-1] * (n - 1)
    pre = post = n // 8
    hands = concat([gesture_markers(rng, pre), warp_markers(body, warp), gesture_markers(rng, post)])
    m = hands.n_frames
    truth = pre + np.interp(np.arange(n), warp, np.arange(span))
    rates = locate_rates(n, m, FPS, OPEN_COARSE_FPS)
    levels = "; then ".join(f"{cf:.2f} fps ({int(n * cf / FPS):,} x {int(m * cf / FPS):,}"
                            + (" cells, all of them)" if k == 0 else " frames, in a band around the path before)")
                            for k, cf in enumerate(rates))
    print(f"body {n:,} frames ({n / FPS / 60:.1f} min), hands {m:,} frames ({m / FPS / 60:.1f} min), {FPS:g} fps; "
          f"locating pass at {levels}")
    h0 = hwm_mb()
    t0 = time.perf_counter()
    res = pass1(body, hands, width=args.width_s * FPS, ends="open")
    dt = time.perf_counter() - t0
    peak = hwm_mb() - h0
    err = np.abs(path_median(res.path, n) - truth)
    print(f"time {dt:.1f} s; peak RSS growth {peak:,.0f} MB; fine band {res.band.n_cells / 2**20:,.1f} M cells "
          f"(max row {res.band.max_row_width}); covered {res.covered}; start hands frame {res.path[0, 1]} "
          f"(true {truth[0]:.1f}), end {res.path[-1, 1]} (true {truth[-1]:.1f}); error mean "
          f"{np.nanmean(err):.2f} frames, p95 {np.nanquantile(err, 0.95):.2f}, max {np.nanmax(err):.1f}")
    h0 = hwm_mb()
    t0 = time.perf_counter()
    conf = pass_confidence(res, FPS)
    dt = time.perf_counter() - t0
    print(f"confidence (forward + backward over the fine band): {dt:.1f} s; peak RSS growth {hwm_mb() - h0:,.0f} MB "
          f"beyond the above; frames with estimated error > 0.1 s: {100 * conf.low().mean():.1f} %; "
          f"median estimated error {np.nanmedian(conf.est_error_s):.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
