"""Many pairs at once on Dask: the ``splice-batch`` command.

Two ways to say what to splice:

* a **manifest** (YAML or CSV) listing pairs: ``body``, ``hands``, optional ``constraints``,
  ``output``, optional ``name`` and ``options`` (fields of :class:`~splicer.options.SpliceOptions`);
  relative paths are relative to the manifest's folder;
* two **folders**: every hands take is paired with a body take by a coarse alignment cost
  (:mod:`splicer.pairing`); the cost table is written, ambiguous pairs are refused.

Each pair runs as one Dask task (a local cluster on all cores by default, or an existing
cluster by address).  Per pair: the output BVH (atomic), then its report
``<out>/reports/<name>.json`` (atomic, last), which records a hash of the pair's manifest
entry and of its inputs' sizes and modification times.  A pair whose output exists and
whose report carries the same hash is finished and is not run again: killing a batch and
starting it again redoes only the unfinished pairs.  A pair that fails (unreadable input,
no hand found, ...) is reported in the summary and the others go on.

The summary ``<out>/summary.{md,csv}`` (and ``summary.html`` with the alignment plots when
asked) has one row per pair: status, frames, seconds, confidence (the lowest side's mean over
covered frames, the shares of frames low confidence and uncovered, the check against the hands
played backwards), warnings.

The summary rows and files are :mod:`splicer.batch_summary`, the folders mode
:mod:`splicer.batch_folders`; this module keeps resuming, one pair, the Dask driver and the CLI.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
import uuid
from contextlib import contextmanager
from pathlib import Path
from types import MappingProxyType

# pair_folders, write_summary and the manifest names are re-exported: the batch API in one place
from .batch_folders import pair_folders
from .batch_summary import _write_atomic, summary_row, write_summary
from .errors import SplicerError
from .manifest import ManifestError, PairJob, read_manifest

__all__ = ["PairJob", "ManifestError", "read_manifest", "job_hash", "is_finished", "run_pair", "run_batch",
           "pair_folders", "dask_client", "LOCAL_CLUSTER_CONFIG", "write_summary", "job_size", "largest_first", "main"]


# ---------------------------------------------------------------- resume

def _stamp(path: str | None):
    if path is None:
        return None
    try:
        st = os.stat(path)
        return [st.st_size, st.st_mtime_ns]
    except OSError:
        return "missing"


def job_hash(job: PairJob) -> str:
    """Hash of the pair's entry (paths, options) and of its inputs' sizes and modification times."""
    from . import __version__

    doc = {"body": job.body, "hands": job.hands, "constraints": job.constraints, "output": job.output,
           "options": job.options, "stamps": [_stamp(job.body), _stamp(job.hands), _stamp(job.constraints)],
           "splicer": __version__}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:20]


def _report_path(out_dir: Path, job: PairJob) -> Path:
    return out_dir / "reports" / f"{job.name}.json"


def _plot_path(out_dir: Path, job: PairJob) -> Path:
    return out_dir / "plots" / f"{job.name}.png"


def is_finished(job: PairJob, out_dir: Path, digest: str | None = None) -> dict | None:
    """The stored report when the pair is finished (output present, report with the same hash), else None."""
    rp = _report_path(Path(out_dir), job)
    if not (Path(job.output).is_file() and rp.is_file()):
        return None
    try:
        rep = json.loads(rp.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    b = rep.get("batch", {}) if isinstance(rep, dict) else {}
    return rep if b.get("hash") == (digest or job_hash(job)) and b.get("status") == "done" else None


# ---------------------------------------------------------------- one pair (a Dask task)

def run_pair(job: PairJob, out_dir: str, plot: bool = False, digest: str | None = None,
             threads: int | None = None) -> dict:
    """Splice one pair, write output, plot and report (report last); never raises for bad input.

    ``threads``: numba threads of the calling thread for this pair (restored after); the
    batch runs one pair per worker with 1, so two workers on two cores do not fight over
    the cores with the cost kernels' own threads.

    Returns
    -------
    dict
        The summary row: ``status`` ``"done"`` or ``"failed"`` (with ``error``), frames,
        seconds, confidence, warnings.
    """
    import warnings

    from .io.bvh import write_bvh
    from .pipeline import splice
    from .report import json_text

    out = Path(out_dir)
    t0 = time.perf_counter()
    c0 = time.thread_time()
    started = time.time()
    digest = digest or job_hash(job)
    rp = _report_path(out, job)
    before = None
    if threads is not None:
        import numba

        before = numba.get_num_threads()
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # warnings are in the report
            res = splice(job.body, job.hands, config=job.constraints, **job.options)
        Path(job.output).parent.mkdir(parents=True, exist_ok=True)
        write_bvh(res.motion, job.output)
        pp = ""
        if plot:
            from .plot import plot_alignment

            pth = _plot_path(out, job)
            pth.parent.mkdir(parents=True, exist_ok=True)
            plot_alignment(res, pth)
            pp = str(pth)
        rep = res.report.to_dict()
        seconds = time.perf_counter() - t0
        rep["batch"] = {"name": job.name, "hash": digest, "status": "done", "output": job.output,
                        "started_unix_s": round(started, 3), "seconds": round(seconds, 3),
                        "cpu_seconds": round(time.thread_time() - c0, 3),
                        "pid": os.getpid(), "plot": pp}
        _write_atomic(rp, json_text(rep))
        return summary_row(job, "done", rep=rep, seconds=seconds, report=str(rp), plot=pp)
    except SplicerError as e:
        return summary_row(job, "failed", seconds=time.perf_counter() - t0, error=str(e))
    except OSError as e:  # the output folder or the report cannot be written
        return summary_row(job, "failed", seconds=time.perf_counter() - t0,
                    error=f"{e.filename or out}: cannot write ({e.strerror or e})")
    except Exception as e:  # noqa: BLE001 - a bug on one pair must not stop the batch; reported in full
        return summary_row(job, "failed", seconds=time.perf_counter() - t0, error=f"internal error: {type(e).__name__}: {e}")
    finally:
        if before is not None:
            import numba

            numba.set_num_threads(before)


def job_size(job: PairJob) -> int:
    """Bytes of a pair's two takes: the estimate of its work that orders a batch.  A missing or
    unreadable take counts 0 (the pair fails at once)."""
    total = 0
    for f in (job.body, job.hands):
        try:
            total += os.path.getsize(f)
        except OSError:
            pass
    return total


def largest_first(items: list, key=lambda j: j) -> list:
    """``items`` ordered by :func:`job_size` of ``key(item)``, largest first; ties keep their order.

    Pairs run as they are handed out, each on the first free worker: with the longest takes
    first, the short ones fill the gaps and no worker is left running a long take alone at the
    end (a batch of seven 30-s pairs and one 180-s pair on two workers: 4.3-5.0 s given in that
    order, 3.3 s largest first).

    >>> import tempfile
    >>> tmp = tempfile.TemporaryDirectory()
    >>> d = Path(tmp.name)
    >>> for name, n in (("a", 10), ("b", 300), ("c", 20)):
    ...     _ = (d / name).write_bytes(b"x" * n)
    >>> jobs = [PairJob(n, str(d / n), str(d / n), str(d / (n + ".out"))) for n in "abc"]
    >>> [j.name for j in largest_first(jobs)]  # b: 600 bytes of inputs, c: 40, a: 20
    ['b', 'c', 'a']
    >>> tmp.cleanup()
    """
    return sorted(items, key=lambda it: -job_size(key(it)))


# ---------------------------------------------------------------- Dask

#: Dask settings of ``dask_client``'s own local cluster (not of a cluster given by address).
#:
#: * Dask starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (memory back to the OS
#:   sooner); that fixes glibc's mmap threshold too, so every large array of a splice is
#:   mapped, faulted in and unmapped again: 12-15 % more CPU per pair (bench_batch.py).  Unset.
#: * Dask's sampling profiler (the dashboard's profile page) takes the GIL from the pair's
#:   thread every 10 ms; off, a warm batch of 8 pairs took 6-8 % less wall time (0.27.1).
#: * Every server (scheduler, nannies, workers) checks its event loop every 20 ms and samples
#:   its system monitor (psutil, for the dashboard) every 0.5 s: on two cores with two busy
#:   workers that took 1.3 s of CPU from the pairs per 14-s batch (0.27.2,
#:   ``benchmarks/bench_batch_overhead.py``).  At 1 s and 5 s a blocked event loop is still
#:   reported (after 3 s) and the nanny's memory limit (its own 0.1-s check) still holds.
LOCAL_CLUSTER_CONFIG = MappingProxyType({
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
})


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, *, processes: bool = True):
    """A ``distributed.Client``: to ``scheduler`` (an address) or to a new local cluster.

    The local cluster has ``workers`` single-threaded worker processes (all cores by default)
    and its HTTP server on a free port; it is shut down on exit, without the traceback a worker's
    last heartbeat may log while it closes (``splicer._dask_shutdown``).  It runs with
    :data:`LOCAL_CLUSTER_CONFIG` (glibc's default memory trimming, no sampling profiler, a
    quieter event loop and system monitor; why and how much each saves: there).
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SplicerError("splice-batch needs Dask: pip install 'splicer[batch]' (dask, distributed)") from None
    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise SplicerError(f"cannot reach the Dask scheduler at {scheduler} ({e})") from None
        try:
            yield client
        finally:
            client.close()
        return
    import logging

    import dask

    n = workers or os.cpu_count() or 1
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        # ":0": any free port (the scheduler serves HTTP even without the dashboard; the default
        # :8787 may be taken by another cluster on this machine)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        # a worker whose heartbeat meets the closing scheduler logs an ERROR with two tracebacks
        # after the batch is done (a race in distributed); drop that one record (_dask_shutdown)
        from ._dask_shutdown import QuietShutdown

        client.register_plugin(QuietShutdown())
        yield client


def _as_completed(client, futures):
    from distributed import as_completed

    return as_completed(futures)


def run_batch(jobs: list[PairJob], out_dir, client, *, plot: bool = False, force: bool = False,
              note=None, extra_rows: list[dict] = (), threads_per_pair: int | None = 1) -> list[dict]:
    """Run every unfinished pair on ``client``; write the summary; return its rows (in ``jobs`` order).

    Parameters
    ----------
    jobs : list of PairJob
    out_dir : path
        Receives ``reports/``, ``plots/`` and ``summary.*``.
    client : distributed.Client
    plot : bool
        Write each pair's alignment plot and ``summary.html``.
    force : bool
        Run finished pairs again.
    note : callable, optional
        ``note(message)`` as pairs finish.
    extra_rows : list of dict
        Rows for pairs that were not run (e.g. refused by pairing), added to the summary.
    threads_per_pair : int or None
        numba threads each pair's cost kernels use (None: numba's default, all cores).
        1 by default: the batch's parallelism is one pair per worker.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    note = note or (lambda msg: None)
    rows: dict[str, dict] = {}
    todo = []
    for j in jobs:
        digest = job_hash(j)
        rep = None if force else is_finished(j, out, digest)
        if rep is not None:
            rows[j.name] = summary_row(j, "done earlier", rep=rep, seconds=rep["batch"].get("seconds"),
                                report=str(_report_path(out, j)), plot=rep["batch"].get("plot", ""))
        else:
            todo.append((j, digest))
    if rows:
        note(f"{len(rows)} of {len(jobs)} pairs finished earlier; running {len(todo)}")
    # the largest pairs first (a long take started last would run alone at the end while the
    # other workers idle); a fresh key per run: a key seen before may hand back a result Dask
    # still holds from an earlier run
    todo = largest_first(todo, key=lambda t: t[0])
    futures = {client.submit(run_pair, j, str(out), plot, d, threads_per_pair, priority=len(todo) - k,
                             key=f"splice-{j.name}-{uuid.uuid4().hex}"): j for k, (j, d) in enumerate(todo)}
    done = 0
    for fut in _as_completed(client, list(futures)):
        j = futures[fut]
        try:
            row = fut.result()
        except Exception as e:  # noqa: BLE001 - a worker lost mid-pair: report, go on
            row = summary_row(j, "failed", error=f"task failed: {type(e).__name__}: {e}")
        rows[j.name] = row
        done += 1
        msg = row["error"] if row["status"] != "done" else f"{row['seconds']:.1f} s, {len(row['warnings'])} warning(s)"
        note(f"[{done}/{len(todo)}] {j.name}: {row['status']} ({msg})")
    ordered = [rows[j.name] for j in jobs] + list(extra_rows)
    write_summary(ordered, out, html_page=plot)
    return ordered


# ---------------------------------------------------------------- CLI

def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="splice-batch",
        description="Splice many body/hands pairs on Dask: from a manifest, or by pairing two folders of takes "
                    "automatically.  Finished pairs are not run again.",
        epilog="examples:\n  splice-batch day1.yaml -o day1_out\n"
               "  splice-batch --body-dir body/ --hands-dir hands/ -o out\n"
               "  splice-batch day1.csv -o out --scheduler tcp://10.0.0.5:8786 --plot\n\n"
               "manifest (YAML): pairs: [{body: b.bvh, hands: h.bvh, output: o.bvh, constraints: c.yaml, "
               "options: {side: left}}]\nmanifest (CSV): body,hands,output,constraints,name,options (options: "
               "key=value; key=value)", formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("manifest", nargs="?", help="YAML or CSV manifest of pairs")
    p.add_argument("--body-dir", help="folder of body takes (pair automatically with --hands-dir)")
    p.add_argument("--hands-dir", help="folder of hands takes")
    p.add_argument("-o", "--out-dir", help="reports, plots, summary (and outputs of paired folders); "
                                           "default: the manifest's folder")
    p.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster worker processes (default: all cores)")
    p.add_argument("--plot", action="store_true", help="alignment plot per pair and summary.html")
    p.add_argument("--force", action="store_true", help="run finished pairs again")
    p.add_argument("--margin", type=float, default=None,
                   help="pairing: least relative cost gap between best and runner-up (default 0.15)")
    p.add_argument("--max-cost", type=float, default=None,
                   help="pairing: refuse a best candidate costing more than this per step (D1, 0..96)")
    p.add_argument("--pair-fps", type=float, default=5.0, help="pairing: frame rate of the coarse cost (default 5)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    return p


def main(argv=None) -> int:
    """Exit status: 0 every pair done, 1 some pair failed or was refused (or bad input), 2 usage."""
    parser = build_parser()
    args = parser.parse_args(argv)
    folders = args.body_dir or args.hands_dir
    if bool(args.manifest) == bool(folders) or (folders and not (args.body_dir and args.hands_dir)):
        parser.error("give a manifest, or both --body-dir and --hands-dir")
    if folders and not args.out_dir:
        parser.error("pairing folders needs --out-dir")
    if args.margin is not None and not 0 <= args.margin < 1:
        parser.error("--margin must be in [0, 1)")
    note = (lambda msg: None) if args.quiet else (lambda msg: print(msg, flush=True))
    try:
        if args.manifest:
            jobs = read_manifest(args.manifest)
            out = Path(args.out_dir) if args.out_dir else Path(args.manifest).resolve().parent
        t0 = time.perf_counter()
        with dask_client(args.scheduler, args.workers) as client:
            extra = []
            if folders:
                out = Path(args.out_dir)
                jobs, decisions, _ = pair_folders(args.body_dir, args.hands_dir, out, client, fps=args.pair_fps,
                                                  margin=args.margin, max_cost=args.max_cost, note=note)
                extra = [summary_row(PairJob(Path(d.hands).stem, "", d.hands, ""), "refused", error=d.reason)
                         for d in decisions if d.body is None]
            rows = run_batch(jobs, out, client, plot=args.plot, force=args.force, note=note, extra_rows=extra)
    except SplicerError as e:
        print(f"splice-batch: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        from .cli import _forget_caught_interrupt

        print("splice-batch: interrupted; finished pairs are kept and will not be run again", file=sys.stderr)
        _forget_caught_interrupt()
        return 130
    bad = [r for r in rows if r["status"] in ("failed", "refused")]
    note(f"{len(rows) - len(bad)} of {len(rows)} pairs done in {time.perf_counter() - t0:.1f} s; "
         f"summary: {out / 'summary.md'}")
    return 1 if bad else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
