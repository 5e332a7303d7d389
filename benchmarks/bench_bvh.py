"""Time read_bvh and write_bvh on every .bvh file in ../shared/motions and print a table.

Usage: ``python benchmarks/bench_bvh.py [repeats]`` (default 5; the best time is shown).
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # run from a checkout without `pip install -e .`
    sys.path.insert(0, str(REPO))

from splicer.io.bvh import read_bvh, write_bvh  # noqa: E402
from splicer.errors import SplicerWarning  # noqa: E402

SHARED = REPO.parent / "shared" / "motions"


def best_of(repeats: int, fn) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    repeats = int(argv[0]) if argv else 5
    if not SHARED.is_dir():
        print(f"{SHARED} not found: the benchmark needs the shared data folder")
        return 1
    warnings.simplefilter("ignore", SplicerWarning)
    read_bvh(next(SHARED.rglob("*.bvh")))  # import bvhio once, outside the timings
    print(f"{'file':40s} {'frames':>6s} {'joints':>6s} {'chans':>5s} {'MB':>5s} {'read ms':>8s} {'write ms':>8s}")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.bvh"
        for f in sorted(SHARED.rglob("*.bvh")):
            m = read_bvh(f)
            tr = best_of(repeats, lambda: read_bvh(f))
            tw = best_of(repeats, lambda: write_bvh(m, out))
            print(f"{str(f.relative_to(SHARED)):40s} {m.n_frames:6d} {m.skeleton.n_joints:6d} "
                  f"{m.skeleton.n_channels:5d} {f.stat().st_size / 1e6:5.2f} {tr * 1e3:8.1f} {tw * 1e3:8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
