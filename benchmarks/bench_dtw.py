"""Banded DTW with path: splicer vs dtaidistance (C), tslearn (numba) and dtw-python (C).

Run ``python benchmarks/bench_dtw.py`` (all sizes) or ``--quick`` (n = 600 and 5,000 only);
``--open`` runs only the open-ended (subsequence) cases against dtw-python's open_begin/open_end.
Prints one markdown table: median milliseconds per call (path included) on identical inputs.

Band mapping (n = m, so the band is a Sakoe-Chiba strip): splicer's band of perpendicular
width W has vertical half-width Delta = W * sqrt(2) / 2 and admits |i - j| <= r with
r = floor(Delta) (``band.hi[0]``).  Peers get the same cells: dtaidistance ``window = r + 1``
(it admits |i - j| < window), tslearn ``sakoe_chiba_radius = r``, dtw-python
``window_size = r``; dtw-python uses ``step_pattern="symmetric1"`` (our recurrence).  The
script checks that every peer returns the same cost (dtaidistance and tslearn return the
square root of the squared-Euclidean total).  dtaidistance's n-dimensional path ignores
``inner_dist="euclidean"``, so it has no Euclidean row.
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import sys
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from splicer.align.dtw import band_frames, dtw_features, make_band  # noqa: E402

LIMIT_GB = 4.0
D = 12  # 4 markers x 3 coordinates


def random_walk(rng, n):
    return np.cumsum(rng.normal(size=(n, D)), axis=0)


def marker_like(rng, n):
    """4 markers x 3 coords: smooth periodic arm motion (cm), slow drift, 0.1 cm noise."""
    t = np.arange(n) / 120.0
    phase = np.cumsum(1.0 + 0.3 * np.sin(2 * np.pi * 0.05 * t)) / 120.0
    out = np.empty((n, D))
    for k in range(D):
        f, p, a = rng.uniform(0.3, 1.5), rng.uniform(0, 2 * np.pi), rng.uniform(5, 30)
        out[:, k] = a * np.sin(2 * np.pi * f * phase + p) + 2 * np.sin(2 * np.pi * 0.01 * t + k)
    return out + rng.normal(scale=0.1, size=out.shape)


_MEM_SNIPPET = """
import sys, numpy as np
sys.path.insert(0, {root!r})
from splicer.align.dtw import make_band, dtw_features
def hwm():
    return [int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM')][0]
n, W = {n}, {W}
rng = np.random.default_rng(0)
X = np.cumsum(rng.normal(size=(n, 12)), 0); Y = np.cumsum(rng.normal(size=(n, 12)), 0)
dtw_features(X[:50], Y[:50], make_band(50, 50, 10))
h0 = hwm(); band = make_band(n, n, W); res = dtw_features(X, Y, band)
print((hwm() - h0) / 1024, band.n_cells / 2**20)
"""


def splicer_peak_mb(n, W):
    """Peak RSS growth (VmHWM, MB) of one dtw_features call in a fresh process."""
    import subprocess
    code = _MEM_SNIPPET.format(root=str(Path(__file__).resolve().parents[1]), n=n, W=W)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return tuple(float(v) for v in out.stdout.split())


def timed(fn, repeats):
    fn()  # warm-up (JIT compile, caches)
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts) * 1e3, out


def peers(X, Y, r, metric):
    """name -> (bytes estimate, callable returning the comparable total cost), or reason str."""
    n, m = len(X), len(Y)
    out = {}
    from dtaidistance import dtw_ndim
    if metric == "sqeuclidean":
        est = 8 * (n + 1) * (min(m, 2 * r + 1) + 2)
        out["dtaidistance"] = (est, lambda: dtw_ndim.warping_path(
            X, Y, window=r + 1, use_c=True, include_distance=True)[1] ** 2)
    else:
        out["dtaidistance"] = "n/a (ndim path is sq. Euclidean only)"
    from tslearn.metrics import dtw_path, dtw_path_from_metric
    if metric == "sqeuclidean":
        f = lambda: dtw_path(X, Y, global_constraint="sakoe_chiba",  # noqa: E731
                             sakoe_chiba_radius=r)[1] ** 2
    else:
        f = lambda: dtw_path_from_metric(X, Y, metric="euclidean",  # noqa: E731
                                         global_constraint="sakoe_chiba",
                                         sakoe_chiba_radius=r)[1]
    out["tslearn"] = (8 * (n + 1) * (m + 1) * (1 if metric == "sqeuclidean" else 2), f)
    import dtw as dtwpy
    out["dtw-python"] = (40 * n * m, lambda: dtwpy.dtw(
        X, Y, dist_method=metric, step_pattern="symmetric1", window_type="sakoechiba",
        window_args={"window_size": r}).distance)
    for k, v in list(out.items()):
        if not isinstance(v, str) and v[0] > LIMIT_GB * 2**30:
            out[k] = f"n/a (needs {v[0] / 2**30:.0f} GB)"
    return out


def planted(rng, n, m, gen):
    """Body X (n frames) planted, time-warped (0.8-1.25x), inside unrelated hands material Y (m frames).

    Returns X, Y and the true first / last hands frame of the planted span."""
    X = gen(rng, n)
    span = int(round(n * rng.uniform(0.8, 1.25)))
    span = min(span, m - 2)
    t = np.linspace(0.0, n - 1, span) + 0.02 * n * np.sin(np.linspace(0, 2 * np.pi, span)) * rng.uniform(0.5, 1)
    t = np.clip(np.maximum.accumulate(t), 0, n - 1)
    mid = np.stack([np.interp(t, np.arange(n), X[:, k]) for k in range(X.shape[1])], axis=1)
    a = int(rng.integers(1, m - span))
    Y = np.concatenate([gen(rng, a), mid, gen(rng, m - span - a)])
    return X, Y, a, a + span - 1


def open_cases(quick: bool) -> int:
    """Open-ended (subsequence) DTW: splicer (open_begin + open_end over the whole matrix, an
    uncovered-row penalty large enough that every body row is covered) vs dtw-python's
    subsequence search (open_begin + open_end, step pattern "asymmetric": its open begin needs
    an N-normalisable pattern, so the recurrence and the cost differ from ours; we compare the
    located span instead of the cost)."""
    import dtw as dtwpy
    from splicer.align.band import full_band
    print("\n### Open ends: locate a warped body span inside a longer hands take (full matrix, with path)\n")
    print("| n | m | splicer ms | dtw-python ms | true span | splicer span | dtw-python span | splicer steps MB |")
    print("|---|---|---|---|---|---|---|---|")
    sizes = [(600, 900), (2000, 3000)] + ([] if quick else [(5000, 7500)])
    for n, m in sizes:
        rng = np.random.default_rng(n)
        X, Y, a, b = planted(rng, n, m, marker_like)
        band = full_band(n, m)
        u = 1e12
        ms, res = timed(lambda: dtw_features(X, Y, band, open_begin=True, open_end=True, uncovered_cost=u), 2)
        est = 40 * n * m
        if est <= LIMIT_GB * 2**30:
            pms, al = timed(lambda: dtwpy.dtw(X, Y, dist_method="sqeuclidean", step_pattern="asymmetric",
                                              open_begin=True, open_end=True), 1)
            pspan, pcell = f"{al.index2[0]}..{al.index2[-1]}", f"{pms:,.1f}"
        else:
            pspan, pcell = "-", f"n/a (needs {est / 2**30:.0f} GB)"
        print(f"| {n:,} | {m:,} | {ms:,.1f} | {pcell} | {a}..{b} | {res.path[0, 1]}..{res.path[-1, 1]} | {pspan} "
              f"| {band.n_cells / 2**20:,.1f} |", flush=True)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only n = 600 and 5,000")
    ap.add_argument("--open", action="store_true", help="only the open-ended (subsequence) cases")
    args = ap.parse_args(argv)
    if args.open:
        return open_cases(args.quick)
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo")
                if ln.startswith("model name")), "?")
    import os
    print(f"CPU: {cpu}, {os.cpu_count()} cores; Python {platform.python_version()}; "
          + ", ".join(f"{p} {version(p)}" for p in
                      ("numpy", "numba", "dtaidistance", "tslearn", "dtw-python")))
    print(f"d = {D} features; banded DTW *with path*; median ms per call after one warm-up.\n")
    cases = [(600, "30%", 5), (5000, "30%", 3)] + ([] if args.quick else [(72000, 1700, 2)])
    names = ["splicer", "dtaidistance", "tslearn", "dtw-python"]
    print("| data | n = m | W (frames) | r | metric | " + " | ".join(names)
          + " | splicer steps MB | costs agree |")
    print("|---|---|---|---|---|" + "---|" * len(names) + "---|---|")
    notes = []
    for n, wspec, reps in cases:
        W = band_frames(wspec, n=n)
        band = make_band(n, n, W)
        r = int(band.hi[0])
        for data in ("random walk", "marker-like"):
            rng = np.random.default_rng(n)
            gen = random_walk if data == "random walk" else marker_like
            X, Y = gen(rng, n), gen(rng, n)
            for metric in ("sqeuclidean", "euclidean"):
                ms, res = timed(lambda: dtw_features(X, Y, band, metric=metric), reps)
                cells = [f"{ms:,.1f}"]
                agree = True
                for name, v in peers(X, Y, r, metric).items():
                    if isinstance(v, str):
                        cells.append(v)
                        continue
                    pms, pcost = timed(v[1], 1 if n > 10000 else reps)
                    agree &= math.isclose(pcost, res.cost, rel_tol=1e-9)
                    cells.append(f"{pms:,.1f}")
                print(f"| {data} | {n:,} | {W:g} | {r} | {metric} | " + " | ".join(cells)
                      + f" | {band.n_cells / 2**20:,.1f} | {'yes' if agree else 'NO'} |",
                      flush=True)
    for n, wspec, _ in cases:
        W = band_frames(wspec, n=n)
        peak, steps = splicer_peak_mb(n, W)
        notes.append(f"splicer, n = m = {n:,}, W = {W:g}: peak RSS growth of one dtw_features "
                     f"call (VmHWM, fresh process) {peak:,.1f} MB; step array {steps:,.1f} MB")
    print()
    for note in notes:
        print("- " + note)
    open_cases(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
