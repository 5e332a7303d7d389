"""What a local Dask cluster's own housekeeping takes from a batch, back to back.

Usage: ``python benchmarks/bench_batch_overhead.py [rounds]`` (default 3).

The machine's speed moves by about 10 % from one batch to the next, more than the settings
compared here change, so wall time alone cannot show them.  This script also counts CPU
seconds per thread (``psutil``): the pairs' threads in the workers, every other thread of
the workers (event loop, heartbeats, monitors) and the main process (scheduler, nannies,
client).  In each round, two fresh 2-worker clusters from :func:`splicer.batch.dask_client`,
one with :data:`splicer.batch.LOCAL_CLUSTER_CONFIG` and one with a variant of it; each runs one
warm-up batch and two timed batches of ``bench_batch.py``'s 8 pairs.  The variant: Dask's own
event-loop check (20 ms) and system monitor (0.5 s) back in (what 0.27.1 ran).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
for p in (REPO, REPO / "benchmarks"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

import numpy as np  # noqa: E402

import splicer.batch as batch  # noqa: E402


def cpu_seconds() -> dict:
    """CPU seconds of this process and, per child process, of each of its threads (by thread id)."""
    import psutil

    me = psutil.Process()
    out = {"main": sum(t.user_time + t.system_time for t in me.threads())}
    for ch in me.children(recursive=True):
        try:
            out[ch.pid] = {t.id: t.user_time + t.system_time for t in ch.threads()}
        except psutil.Error:
            pass
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    rounds = int(argv[0]) if argv else 3
    from bench_batch import make_pairs

    jobs = make_pairs(8, 90.0)
    out = Path(jobs[0].output).parent.parent / "overhead"
    ours = dict(batch.LOCAL_CLUSTER_CONFIG)
    variants = {"splicer's local cluster": ours,
                "with Dask's 20-ms loop check, 0.5-s monitor": {
                    **ours, "distributed.admin.tick.interval": "20ms",
                    "distributed.admin.system-monitor.interval": "500ms"}}
    rows = {k: [] for k in variants}
    print(f"| round | cluster | wall s | main process CPU s | workers' other threads CPU s | pairs' threads CPU s |")
    print("|---|---|---:|---:|---:|---:|")
    for r in range(rounds):
        for name, cfg in variants.items():
            batch.LOCAL_CLUSTER_CONFIG = cfg
            try:
                with batch.dask_client(workers=2) as client:
                    batch.run_batch(jobs, out / "warm", client, force=True)
                    for k in range(2):
                        a, t = cpu_seconds(), time.perf_counter()
                        batch.run_batch(jobs, out / f"run{k}", client, force=True)
                        wall, b = time.perf_counter() - t, cpu_seconds()
                        main_cpu = b["main"] - a["main"]
                        # a worker's busiest thread over the batch is its pair thread
                        d = {p: np.array([v - a.get(p, {}).get(t, 0.0) for t, v in b[p].items()])
                             for p in b if p != "main"}
                        pairs = sum(float(v.max()) for v in d.values())
                        other = sum(float(v.sum() - v.max()) for v in d.values())
                        rows[name].append((wall, main_cpu, other, pairs))
                        print(f"| {r} | {name} | {wall:.2f} | {main_cpu:.2f} | {other:.2f} | {pairs:.2f} |", flush=True)
            finally:
                batch.LOCAL_CLUSTER_CONFIG = ours
    print("\n| cluster | median wall s | housekeeping CPU s (main + workers' other threads) | pairs' CPU s |")
    print("|---|---:|---:|---:|")
    for name, v in rows.items():
        v = np.array(v)
        print(f"| {name} | {np.median(v[:, 0]):.2f} | {np.median(v[:, 1] + v[:, 2]):.2f} | {np.median(v[:, 3]):.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
