"""Start-up of the ``splice`` command on the bundled sample (issue 12).

Wall and CPU (user + system) times of fresh processes, min over ``--repeat`` runs (the machine is
shared: the minimum is the least disturbed run), with numba's cache warm and splicer's byte code
compiled first (as an installed package has it):

* ``import numpy``: ``python -c "import numpy"``, the yardstick (target: warm run <= 5x this);
* ``--help``, ``--version``: the parser alone;
* ``warm run``: the README's quick-start command without ``--plot``;
* ``with --plot``: the same with ``--plot``; ``--plot added`` is the difference (target <= 0.5 s);
* ``import Pillow``: what ``--plot`` pays before drawing anything (0.6.0 and before drew with
  matplotlib: ``import matplotlib`` is printed beside it for that comparison);
* ``first run`` (``--first``): the warm-run command with ``NUMBA_CACHE_DIR`` set to a new, empty
  folder, so every kernel the run calls is compiled (once; min over ``--first-repeat`` runs), with
  the helper process that compiles the kernels from the end (``splicer._warmup``), and beside it,
  interleaved, the same without the helper (``SPLICER_NO_WARMUP=1``: one process compiles them all);
* ``on splice-server``: the warm-run command as the ``splice`` script runs it
  (:func:`splicer.server_client.main`) with a ``splice-server`` running (its own socket in a
  temporary folder); between runs the script waits until the server's spare run is ready again,
  as it is when a user types the next command (the wait is not timed);
  ``on splice-server, --plot`` likewise with ``--plot``.

Run from the repository root: ``python benchmarks/bench_startup.py [--repeat 10] [--first]``.
"""

from __future__ import annotations

import argparse
import compileall
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))  # splicer.server's query, for the server rows
M = ROOT / "motions"


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _wall(cmd: list[str], env: dict | None = None, check: bool = True) -> tuple[float, float]:
    """(wall, CPU) seconds of one run of ``cmd``; CPU (user + system) is less disturbed by other processes."""
    c0, t0 = _cpu(), time.perf_counter()
    subprocess.run(cmd, check=check, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    return time.perf_counter() - t0, _cpu() - c0


def _min(cmd, repeat, env=None, check=True) -> tuple[float, float]:
    runs = [_wall(cmd, env, check) for _ in range(repeat)]
    return min(w for w, _ in runs), min(c for _, c in runs)


def _served(sock: str, runs: int | None = None, timeout: float = 120.0) -> int:
    """Wait until the server at ``sock`` has served ``runs`` runs (if given), runs none and its spare
    is ready; returns its count of runs."""
    from splicer.server import _query

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        info = _query("ping", sock)
        if info is None:
            raise SystemExit("splice-server stopped")
        if info["running"] == 0 and info["spare"] != "warming" and (runs is None or info["runs"] >= runs):
            return info["runs"]
        time.sleep(0.05)
    raise SystemExit("splice-server: the spare run never got ready")


def _min_served(cmd, repeat, env, sock) -> tuple[float, float]:
    """:func:`_min` of ``cmd`` with the server ready before each run; checks that it served each."""
    runs = []
    for _ in range(repeat):
        n = _served(sock)
        runs.append(_wall(cmd, env))
        if _served(sock, n + 1) != n + 1:
            raise SystemExit("splice-server did not serve the run")
    return min(w for w, _ in runs), min(c for _, c in runs)


def _sub(a, b):
    return a[0] - b[0], a[1] - b[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--first", action="store_true", help="also time a first run in a new numba cache")
    ap.add_argument("--first-repeat", type=int, default=2)
    args = ap.parse_args(argv)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        base = [py, "-m", "splicer.cli", str(M / "sample_body.bvh"), str(M / "sample_hands.bvh"),
                "-o", f"{tmp}/out.bvh", "--constraints", str(M / "sample_sync.yaml"), "--report", f"{tmp}/r.json"]
        compileall.compile_dir(ROOT / "splicer", quiet=1)  # byte code, as an installed package has it
        _wall(base, env)  # fill numba's cache (if cold) and the OS file cache
        rows = {}
        rows["import numpy"] = _min([py, "-c", "import numpy"], args.repeat, env)
        rows["import Pillow"] = _sub(_min([py, "-c", "import numpy, PIL.Image, PIL.ImageDraw, PIL.ImageFont"],
                                          args.repeat, env), rows["import numpy"])
        rows["import matplotlib"] = _sub(_min([py, "-c", "import numpy, matplotlib.figure, matplotlib.backends.backend_agg"],
                                              args.repeat, env), rows["import numpy"])
        rows["--help"] = _min([py, "-m", "splicer.cli", "--help"], args.repeat, env)
        rows["--version"] = _min([py, "-m", "splicer.cli", "--version"], args.repeat, env, check=False)
        rows["warm run"] = _min(base, args.repeat, env)
        rows["with --plot"] = _min(base + ["--plot", f"{tmp}/p.png"], args.repeat, env)
        rows["--plot added"] = _sub(rows["with --plot"], rows["warm run"])
        sock_dir = tempfile.mkdtemp(prefix="spl-")
        sock = os.path.join(sock_dir, "s.sock")
        senv = dict(env, SPLICER_SERVER_SOCKET=sock)
        senv.pop("SPLICER_SERVER", None)
        subprocess.run([py, "-m", "splicer.server", "start", "-q", "--socket", sock], env=senv, check=True, cwd=ROOT)
        try:
            script = [py, "-c", "import sys; from splicer.server_client import main; sys.exit(main())"] + base[3:]
            rows["on splice-server"] = _min_served(script, args.repeat, senv, sock)
            rows["on splice-server, --plot"] = _min_served(script + ["--plot", f"{tmp}/p.png"], args.repeat, senv, sock)
        finally:
            subprocess.run([py, "-m", "splicer.server", "stop", "-q", "--socket", sock], env=senv, cwd=ROOT)
            os.rmdir(sock_dir) if os.path.isdir(sock_dir) and not os.listdir(sock_dir) else None
        if args.first:
            def first(**more):
                with tempfile.TemporaryDirectory() as cache:
                    return _wall(base, dict(env, NUMBA_CACHE_DIR=cache, **more))
            env.pop("SPLICER_NO_WARMUP", None)
            runs, one = [], []
            for _ in range(args.first_repeat):  # interleaved: the machine's speed drifts
                runs.append(first())
                one.append(first(SPLICER_NO_WARMUP="1"))
            rows["first run"] = min(w for w, _ in runs), min(c for _, c in runs)
            rows["first run, one process (SPLICER_NO_WARMUP=1)"] = min(w for w, _ in one), min(c for _, c in one)
    print(f"| what | wall s (min of {args.repeat}) | CPU s (min) |\n|---|---|---|")
    for k, (w, c) in rows.items():
        print(f"| {k} | {w:.3f} | {c:.3f} |")
    for i, unit in enumerate(("wall", "CPU")):
        ratio = rows["warm run"][i] / rows["import numpy"][i]
        added = rows["--plot added"][i]
        print(f"{unit}: warm run / import numpy {ratio:.1f}x (target 5x: {'met' if ratio <= 5 else 'not met'}); "
              f"--plot adds {added:.2f} s (target 0.5 s: {'met' if added <= 0.5 else 'not met'})")
    served = rows["on splice-server"][0] / rows["import numpy"][0]
    added = rows["on splice-server, --plot"][0] - rows["on splice-server"][0]
    print(f"wall, on splice-server: warm run / import numpy {served:.1f}x (target 5x: "
          f"{'met' if served <= 5 else 'not met'}); --plot adds {added:.2f} s (CPU: the server's run is not this "
          f"process's child, so only the command's own CPU time is counted above)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
