"""Batch throughput: ``splice-batch`` on a 2-worker Dask LocalCluster against a serial loop.

Usage: ``python benchmarks/bench_batch.py [pairs] [seconds] [workers] [trials]`` (default 8 pairs
of 90-s takes, 2 workers, 3 interleaved trials).

The pairs are made by the evaluation protocol (:func:`splicer.evaluation.separate.separate` of
:func:`splicer.evaluation.synth.make_gesture_take` takes, seeds 0..), 30 fps body, 60 fps hands, in the
system temp folder.  Timings (wall clock):

* ``serial loop``: :func:`splicer.batch.run_pair` on each pair in turn, in this process,
  with the numba kernels already loaded and their own threads on all cores (the best a
  serial loop can do); also with 1 numba thread;
* ``serial CLI loop``: ``splice body hands -o out`` per pair in a shell-style loop (start-up each time);
* ``Dask, cold``: :func:`splicer.batch.run_batch` including starting the local cluster (its
  workers import splicer and load the compiled kernels);
* ``Dask, warm``: the same on the running cluster (``--scheduler`` to a running cluster).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from splicer.batch import PairJob, dask_client, run_batch, run_pair  # noqa: E402
from splicer.io.bvh import write_bvh  # noqa: E402
from splicer.evaluation.separate import separate  # noqa: E402
from splicer.evaluation.synth import make_gesture_take  # noqa: E402


def make_pairs(n: int, seconds: float) -> list[PairJob]:
    d = Path(tempfile.gettempdir()) / f"splicer_bench_batch_{n}x{seconds:g}s"
    (d / "in").mkdir(parents=True, exist_ok=True)
    jobs = []
    for k in range(n):
        b, h = d / "in" / f"body{k}.bvh", d / "in" / f"hands{k}.bvh"
        if not (b.exists() and h.exists()):
            take = make_gesture_take(seconds, 30.0, np.random.default_rng(1000 + k))
            sep = separate(take, rng=np.random.default_rng(k))
            write_bvh(sep.body, b)
            write_bvh(sep.hands, h)
        jobs.append(PairJob(f"pair{k}", str(b), str(h), str(d / "out" / f"pair{k}.bvh")))
    return jobs


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    n = int(argv[0]) if argv else 8
    seconds = float(argv[1]) if len(argv) > 1 else 90.0
    workers = int(argv[2]) if len(argv) > 2 else 2
    trials = int(argv[3]) if len(argv) > 3 else 3
    jobs = make_pairs(n, seconds)
    base = Path(jobs[0].output).parent.parent
    print(f"{n} pairs of {seconds:g}-s takes (30 fps body, 60 fps hands), {workers} workers, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")
    run_pair(jobs[0], str(base / "warm"))  # load the kernels in this process
    times: dict[str, list[float]] = {}

    def timed(name, fn):
        t = time.perf_counter()
        fn()
        times.setdefault(name, []).append(time.perf_counter() - t)

    def serial(threads):
        for j in jobs:
            r = run_pair(j, str(base / "serial"), threads=threads)
            assert r["status"] == "done", r["error"]

    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))

    def cli_loop():
        for j in jobs:
            subprocess.run([sys.executable, "-m", "splicer.cli", j.body, j.hands, "-o", j.output, "-q"],
                           check=True, env=env)

    t = time.perf_counter()
    with dask_client(workers=workers) as client:
        res = run_batch(jobs, base / "dask_cold", client, force=True)
        times["Dask LocalCluster, cold (incl. start)"] = [time.perf_counter() - t]
        assert all(r["status"] == "done" for r in res)
        # interleaved: the machine may be shared, so each configuration sees the same neighbours
        for _ in range(trials):
            timed("serial loop (in process, warm)", lambda: serial(None))
            timed("serial loop, 1 numba thread", lambda: serial(1))
            timed("Dask LocalCluster, warm", lambda: run_batch(jobs, base / "dask_warm", client, force=True))
    timed("serial CLI loop (splice per pair)", cli_loop)
    print(f"load average {os.getloadavg()[0]:.1f} at the end\n")
    med = {k: float(np.median(v)) for k, v in times.items()}
    ref = med["serial loop (in process, warm)"]
    print(f"median of {trials} interleaved trials for the warm rows")
    print(f"| {'run':40s} | {'seconds':>8s} | {'pairs/min':>9s} | {'speed-up vs serial loop':>23s} |")
    print(f"|{'-' * 42}|{'-' * 10}|{'-' * 11}|{'-' * 25}|")
    order = ["serial loop (in process, warm)", "serial loop, 1 numba thread", "serial CLI loop (splice per pair)",
             "Dask LocalCluster, cold (incl. start)", "Dask LocalCluster, warm"]
    for name in order:
        secs = med[name]
        print(f"| {name:40s} | {secs:8.1f} | {60 * n / secs:9.1f} | {ref / secs:22.2f}x |")
    import json

    # On a shared machine the wall clock measures the neighbours.  The CPU time of each pair's
    # thread does not: the serial loop needs the sum, the batch the busiest worker's sum.
    cpu = {}
    for d in ("serial", "dask_warm"):
        reps = [json.loads(f.read_text())["batch"] for f in sorted((base / d / "reports").glob("*.json"))]
        per_worker = {}
        for r in reps:
            per_worker[r["pid"]] = per_worker.get(r["pid"], 0.0) + r["cpu_seconds"]
        cpu[d] = (sum(per_worker.values()), max(per_worker.values()), len(per_worker))
    (s_sum, _, _), (d_sum, d_max, d_n) = cpu["serial"], cpu["dask_warm"]
    print(f"CPU seconds (last trial, 1 numba thread per pair): serial loop {s_sum:.1f}; Dask {d_sum:.1f} over "
          f"{d_n} workers, busiest worker {d_max:.1f} -> on dedicated cores {s_sum / d_max:.2f}x "
          f"(serial CPU / busiest worker's CPU; scheduling overhead not included)")
    w = times["Dask LocalCluster, warm"]
    s = times["serial loop (in process, warm)"]
    print("\nper trial (serial / Dask warm): " + ", ".join(f"{a:.1f}/{b:.1f} = {a / b:.2f}x" for a, b in zip(s, w)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
