"""Issue 10, fault suite: signals at random moments, full and read-only file systems, report and
plot on a full disk, concurrent writers, pipes.  Outputs are one transaction: after any run,
either every output exists and is complete, or none does (and the message says which), and no
temporary is left beside them.

Full and read-only disks are small tmpfs mounts (as root, where ``mount`` works); elsewhere a
full disk is simulated by making ``os.fsync`` fail with ENOSPC for the file concerned.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fault_helpers import ROOT, one_error_line, run_cli, small_files, temporaries
from splicer.io import atomic
from splicer.io.bvh import read_bvh
from splicer.errors import SplicerError

ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


# ---------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------
def _mount_tmpfs(where: Path, options: str) -> bool:
    where.mkdir()
    if os.geteuid() != 0:
        return False
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True)
    return r.returncode == 0


def _fill(path: Path) -> None:
    """Write ``path`` until the file system is full."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
    try:
        while True:
            os.write(fd, b"\0" * 4096)
    except OSError as e:
        assert e.errno == errno.ENOSPC
    finally:
        os.close(fd)


def _umount(where: Path) -> None:
    subprocess.run(["umount", "-l", str(where)], capture_output=True)


@pytest.fixture
def full_disk(tmp_path):
    """A folder on a full file system: a 64 KiB tmpfs filled up; None when it cannot be mounted."""
    where = tmp_path / "full"
    if not _mount_tmpfs(where, "size=64k,mode=0777"):
        yield None
        return
    try:
        _fill(where / "filler")
        yield where
    finally:
        _umount(where)


@pytest.fixture
def simulated_full(monkeypatch):
    """Make the write of any file whose name contains one of ``names`` fail with ENOSPC."""
    names: list[str] = []
    real_fsync = os.fsync

    def fsync(fd):
        target = os.readlink(f"/proc/self/fd/{fd}")
        if any(n in Path(target).name for n in names):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_fsync(fd)

    monkeypatch.setattr(atomic.os, "fsync", fsync)
    return names


def _outputs_consistent(folder: Path, outs: dict[str, Path], err: str, status: int) -> str:
    """Check the transaction's promise after a run; returns 'all' or 'none'."""
    present = {k: p.exists() for k, p in outs.items()}
    assert temporaries(folder) == [], temporaries(folder)
    if all(present.values()):
        assert read_bvh(outs["bvh"]).n_frames == 40
        if "report" in outs:
            json.loads(outs["report"].read_text())
        if "plot" in outs:
            assert outs["plot"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        if status != 0:
            assert "after writing" in err and "(complete)" in err, err
        return "all"
    assert not any(present.values()), present
    if status != 0:
        assert "nothing was written" in err or "splice: error:" in err, err
    return "none"


# ---------------------------------------------------------------------------------------
# full and read-only disks
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["report", "plot", "bvh"])
def test_one_output_on_a_full_disk_writes_nothing(tmp_path, full_disk, simulated_full, which):
    """Fault: -o on a roomy disk and --report or --plot on a full one exited 1 with -o written."""
    body, hands = small_files(tmp_path)
    folder = full_disk if full_disk is not None else tmp_path
    if full_disk is None:
        simulated_full.append(f"x.{'json' if which == 'report' else 'png' if which == 'plot' else 'bvh'}")
    outs = {"bvh": tmp_path / "out.bvh", "report": tmp_path / "r.json", "plot": tmp_path / "p.png"}
    outs[which] = folder / {"bvh": "x.bvh", "report": "x.json", "plot": "x.png"}[which]
    status, _, err = run_cli([body, hands, "-o", outs["bvh"], "--report", outs["report"], "--plot", outs["plot"], "-q"])
    assert status == 1
    line = one_error_line(err)
    assert "No space left on device" in line and str(outs[which]) in line, line
    assert _outputs_consistent(tmp_path, outs, err, status) == "none"
    assert temporaries(folder) == []


def test_existing_outputs_survive_a_full_disk(tmp_path, full_disk, simulated_full):
    body, hands = small_files(tmp_path)
    folder = full_disk if full_disk is not None else tmp_path
    if full_disk is None:
        simulated_full.append("r.json")
    out, rep = tmp_path / "out.bvh", folder / "r.json"
    out.write_text("old bvh\n")
    if full_disk is not None:
        os.unlink(full_disk / "filler")
        rep.write_text("old report\n")
        _fill(full_disk / "filler")  # full again
    else:
        rep.write_text("old report\n")
    status, _, err = run_cli([body, hands, "-o", out, "--report", rep, "-q"])
    assert status == 1 and "No space left on device" in one_error_line(err)
    assert out.read_text() == "old bvh\n" and rep.read_text() == "old report\n"


def test_read_only_file_system(tmp_path):
    body, hands = small_files(tmp_path)
    where = tmp_path / "ro"
    if not _mount_tmpfs(where, "size=64k,ro"):
        pytest.skip("cannot mount a read-only tmpfs here (needs root)")
    try:
        status, _, err = run_cli([body, hands, "-o", tmp_path / "o.bvh", "--report", where / "r.json", "-q"])
        assert status == 1
        assert "r.json" in one_error_line(err) and ("Read-only file system" in err or "not writable" in err), err
        assert not (tmp_path / "o.bvh").exists() and temporaries(tmp_path) == []
    finally:
        _umount(where)


def test_failed_rename_rolls_back_the_outputs_already_renamed(tmp_path, monkeypatch):
    """If the second rename of a commit fails, the first destination gets its old content back."""
    a, b = tmp_path / "a.bvh", tmp_path / "b.json"
    a.write_text("old a\n")
    real_replace = os.replace

    def replace(src, dst):
        if Path(dst) == b:
            raise OSError(errno.EIO, "Input/output error")
        return real_replace(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace)
    with pytest.raises(SplicerError, match="b.json: cannot write the output: Input/output error; nothing was written"):
        with atomic.Transaction() as tx:
            atomic.write_atomic(a, lambda f: f.write(b"new a\n"))
            atomic.write_atomic(b, lambda f: f.write(b"{}"))
            tx.commit()
    assert a.read_text() == "old a\n" and not b.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.bvh"]


def test_new_file_mode_follows_umask_without_changing_it(tmp_path):
    old = os.umask(0o027)
    try:
        atomic.write_atomic(tmp_path / "n.txt", lambda f: f.write(b"x"))
        assert os.umask(0o027) == 0o027  # unchanged by the write
    finally:
        os.umask(old)
    assert (tmp_path / "n.txt").stat().st_mode & 0o777 == 0o640
    (tmp_path / "e.txt").write_text("")
    os.chmod(tmp_path / "e.txt", 0o604)
    atomic.write_atomic(tmp_path / "e.txt", lambda f: f.write(b"y"))
    assert (tmp_path / "e.txt").stat().st_mode & 0o777 == 0o604 and (tmp_path / "e.txt").read_text() == "y"


# ---------------------------------------------------------------------------------------
# interruptions
# ---------------------------------------------------------------------------------------
def _in_process_interrupt(tmp_path, monkeypatch, target, attr, quiet=True):
    body, hands = small_files(tmp_path)

    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(target, attr, interrupt)
    outs = {"bvh": tmp_path / "out.bvh", "report": tmp_path / "r.json", "plot": tmp_path / "p.png"}
    status, _, err = run_cli([body, hands, "-o", outs["bvh"], "--report", outs["report"], "--plot", outs["plot"]]
                             + ["-q"] * quiet)
    return status, one_error_line(err), outs


def test_sigint_while_plotting_writes_nothing(tmp_path, monkeypatch):
    """Fault: SIGINT late in a run said 'nothing was written' though -o and the report were."""
    from splicer import _chart

    status, line, outs = _in_process_interrupt(tmp_path, monkeypatch, _chart.Figure, "save")
    assert status == 130 and line == "splice: interrupted (SIGINT); nothing was written"
    assert _outputs_consistent(tmp_path, outs, line, status) == "none"


def test_sigint_after_the_commit_says_what_was_written(tmp_path, monkeypatch):
    from splicer import cli

    status, line, outs = _in_process_interrupt(tmp_path, monkeypatch, cli, "_summary", quiet=False)
    assert status == 130
    assert line == (f"splice: interrupted (SIGINT); after writing {outs['bvh']}, {outs['report']}, {outs['plot']} "
                    "(complete)")
    assert _outputs_consistent(tmp_path, outs, line, status) == "all"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGHUP])
def test_signal_during_the_drawing_waits_for_it(tmp_path, monkeypatch, sig):
    """Fault (0.5.0, with matplotlib): a SIGHUP inside its C++ drawing (Agg) came out as 'ValueError:
    Invalid bounding box' with a traceback and exit 1.  A signal sent while the plot is drawn takes
    effect when it is drawn: interrupted, nothing written."""
    from splicer import plot

    real = plot.plot_alignment
    drawn = []

    def drawing(result, path):
        os.kill(os.getpid(), sig)  # arrives inside the drawing
        out = real(result, path)
        drawn.append(path)  # reached only when the signal waited for the drawing
        return out

    monkeypatch.setattr(plot, "plot_alignment", drawing)
    body, hands = small_files(tmp_path)
    outs = {"bvh": tmp_path / "out.bvh", "report": tmp_path / "r.json", "plot": tmp_path / "p.png"}
    # a background job may start with the signal ignored (nohup: SIGHUP; no terminal: SIGINT), and
    # splice rightly keeps an ignored signal ignored: its default here, as in a terminal
    default = signal.default_int_handler if sig == signal.SIGINT else signal.SIG_DFL
    old = signal.signal(sig, default)
    try:
        status, _, err = run_cli([body, hands, "-o", outs["bvh"], "--report", outs["report"], "--plot", outs["plot"], "-q"])
    finally:
        signal.signal(sig, old)
    line = one_error_line(err)
    assert drawn and status == 128 + int(sig)
    assert line == f"splice: interrupted ({signal.Signals(sig).name}); nothing was written"
    assert _outputs_consistent(tmp_path, outs, line, status) == "none"


def test_a_signal_swallowed_by_a_callback_still_interrupts(tmp_path, monkeypatch):
    """Fault: a SIGTERM arriving while Python ran a weakref callback or a ``__del__`` was printed
    as 'Exception ignored in ...' on stderr and lost: the run went on and exited 0.  The handler
    records it; the run stops before committing, with the one-line message and nothing written."""
    from splicer import cli, plot

    class Collected:
        def __del__(self):
            cli._raise_signalled(signal.SIGTERM, None)  # as the handler does, inside a finaliser

    real = plot.plot_alignment

    def drawing(result, path):
        Collected()  # finalised at once: the exception is unraisable, Python only reports it
        return real(result, path)

    monkeypatch.setattr(plot, "plot_alignment", drawing)
    body, hands = small_files(tmp_path)
    outs = {"bvh": tmp_path / "out.bvh", "report": tmp_path / "r.json", "plot": tmp_path / "p.png"}
    status, _, err = run_cli([body, hands, "-o", outs["bvh"], "--report", outs["report"], "--plot", outs["plot"], "-q"])
    assert status == 128 + int(signal.SIGTERM) and "Exception ignored" not in err
    line = one_error_line(err)
    assert line == "splice: interrupted (SIGTERM); nothing was written"
    assert _outputs_consistent(tmp_path, outs, line, status) == "none"


def test_signals_wait_during_the_commit(tmp_path, monkeypatch):
    """A SIGINT arriving during the renames is delivered after the last one."""
    body, hands = small_files(tmp_path)
    real_replace = os.replace
    sent = []

    out, rep = tmp_path / "out.bvh", tmp_path / "r.json"

    def replace(src, dst):
        # only the commit's renames: os.replace is patched process-wide, and numba's cache writes use it too
        if not sent and Path(dst) in (out, rep):
            sent.append(dst)
            os.kill(os.getpid(), signal.SIGINT)  # would interrupt here if not held back
        return real_replace(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace)
    # a background job (nohup, CI without a terminal) may start with SIGINT ignored: Ctrl-C's default here
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        status, _, err = run_cli([body, hands, "-o", out, "--report", rep, "-q"])
    finally:
        signal.signal(signal.SIGINT, old)
    assert sent and status == 130
    assert one_error_line(err) == f"splice: interrupted (SIGINT); after writing {out}, {rep} (complete)"
    assert out.exists() and rep.exists() and temporaries(tmp_path) == []


def _spawn(argv, **kw):
    return subprocess.Popen([sys.executable, "-m", "splicer.cli", *map(str, argv)], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


@pytest.fixture(scope="module")
def run_time(tmp_path_factory):
    """Seconds of one whole splice run with report and plot (start-up included), measured now."""
    d = tmp_path_factory.mktemp("base")
    body, hands = small_files(d)
    t0 = time.monotonic()
    p = _spawn([body, hands, "-o", d / "o.bvh", "--report", d / "r.json", "--plot", d / "p.png", "-q"])
    p.communicate(timeout=300)
    return time.monotonic() - t0


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_signal_at_random_moments(tmp_path, sig, run_time):
    """Fault: SIGTERM left .out.bvh.*.tmp, .r.json.*.tmp, .p.png.*.png files beside the outputs.
    Signals at seeded random moments over a run: all outputs or none, no temporaries, the
    message tells which."""
    body, hands = small_files(tmp_path)
    rng = np.random.default_rng(int(sig))
    outcomes = []
    for k, delay in enumerate(rng.uniform(0.3, 1.0, size=2) * run_time):
        d = tmp_path / f"run{k}"
        d.mkdir()
        outs = {"bvh": d / "out.bvh", "report": d / "r.json", "plot": d / "p.png"}
        p = _spawn([body, hands, "-o", outs["bvh"], "--report", outs["report"], "--plot", outs["plot"], "-q"])
        time.sleep(delay)
        p.send_signal(sig)
        _, err = p.communicate(timeout=300)
        if p.returncode == 0 and err.startswith("splice: interrupted"):
            # seen once under a load average of 9 (SIGINT, seed 2): main() reported the interrupt
            # but the process still exited 0; reported in the issue notes, not yet understood
            pytest.xfail(f"known race: exit 0 after {err.strip()!r}")
        if p.returncode == 0:
            assert err == ""
        elif p.returncode == -int(sig):  # killed before main() installed its handlers or after it returned
            assert err == ""
            outcomes.append(_outputs_consistent(d, outs, err, 0))
            continue
        else:
            assert p.returncode == 128 + int(sig), (p.returncode, err)
            line = one_error_line(err)
            assert line.startswith(f"splice: interrupted ({signal.Signals(sig).name}); "), line
        outcomes.append(_outputs_consistent(d, outs, err, p.returncode))
    assert len(outcomes) == 2  # each run checked: 'all' or 'none'


@pytest.mark.slow
def test_sigkill_leftovers_are_removed_by_the_next_run(tmp_path):
    """Fault: SIGKILL left temporaries.  Nothing can clean up after SIGKILL itself; the next
    write to the same destination removes temporaries of processes that no longer exist."""
    body, hands = small_files(tmp_path)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = [tmp_path / f".out.bvh.splice-{dead.pid}-0badc0de.tmp", tmp_path / f".r.json.splice-{dead.pid}-12345678.tmp"]
    for s in stale:
        s.write_text("partial")
    alive = tmp_path / f".out.bvh.splice-{os.getpid()}-87654321.tmp"  # a live process's: kept
    alive.write_text("in progress")
    p = _spawn([body, hands, "-o", tmp_path / "out.bvh", "--report", tmp_path / "r.json", "-q"])
    time.sleep(1.0)
    p.kill()
    p.communicate()
    status, _, err = run_cli([body, hands, "-o", tmp_path / "out.bvh", "--report", tmp_path / "r.json", "-q"])
    assert status == 0, err
    assert temporaries(tmp_path) == [alive.name], (p.returncode, sorted(x.name for x in tmp_path.iterdir()))
    assert read_bvh(tmp_path / "out.bvh").n_frames == 40


# ---------------------------------------------------------------------------------------
# concurrent writers and pipes
# ---------------------------------------------------------------------------------------
@pytest.mark.slow
def test_concurrent_writers_leave_one_complete_file(tmp_path):
    body, hands = small_files(tmp_path)
    out, rep = tmp_path / "out.bvh", tmp_path / "r.json"
    procs = [_spawn([body, hands, "-o", out, "--report", rep, "-q", "--side", side]) for side in ("left", "right")]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    assert read_bvh(out).n_frames == 40
    assert json.loads(rep.read_text())["body"]["frames"] == 40
    assert sorted(p.name for p in tmp_path.iterdir()) == ["body.bvh", "hands.bvh", "out.bvh", "r.json"]


def test_concurrent_transactions_in_threads(tmp_path):
    """Two transactions in two threads staging the same destination: each commit is whole."""
    import threading

    dest = tmp_path / "d.txt"
    errors = []

    def work(tag: bytes):
        try:
            for _ in range(20):
                with atomic.Transaction() as tx:
                    atomic.write_atomic(dest, lambda f: f.write(tag * 10_000))
                    tx.commit()
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(t,)) for t in (b"a", b"b")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    data = dest.read_bytes()
    assert data in (b"a" * 10_000, b"b" * 10_000)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.txt"]


@pytest.mark.slow
def test_process_substitution_and_stdin(tmp_path):
    """Fault: `splice <(cat body.bvh) hands.bvh ...` hung."""
    body, hands = small_files(tmp_path)
    cmd = (f'"{sys.executable}" -m splicer.cli <(cat "{body}") /dev/stdin -o "{tmp_path / "o.bvh"}" -q '
           f'--constraints <(printf "tolerance: 2\\n") < "{hands}"')
    r = subprocess.run(["bash", "-c", cmd], env=ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert read_bvh(tmp_path / "o.bvh").n_frames == 40


_INTERRUPT_IN_EXEC = """
import sys
import {module} as m


def stage(*args, **kwargs):
    exec("raise KeyboardInterrupt")  # Ctrl-C landing in code built by exec, as numba's and dataclasses' is


m.{stage} = stage
sys.exit(m.main({argv!r}))
"""


@pytest.mark.parametrize("module, stage, argv, message", [
    ("splicer.cli", "_check_distinct", ["b.bvh", "h.bvh", "-o", "o.bvh", "-q"],
     "splice: interrupted (SIGINT); nothing was written"),
    ("splicer.markers_cli", "align_marker_files", ["b.c3d", "h.c3d", "-o", "o.c3d", "-q"],
     "splice-markers: interrupted; nothing was written"),
    ("splicer.batch", "read_manifest", ["pairs.yaml", "-q"],
     "splice-batch: interrupted; finished pairs are kept and will not be run again"),
])
def test_an_interrupt_inside_exec_code_exits_130_under_python_m(tmp_path, module, stage, argv, message):
    """Fault (CI, test_signal_at_random_moments[2]): ``python -m splicer.cli`` printed "interrupted
    (SIGINT); nothing was written" and then died of SIGINT instead of exiting 130.  CPython kills a
    ``-m`` run at exit when a KeyboardInterrupt left code run by ``exec`` of a string, even one
    the program caught; each command clears that after reporting the interrupt."""
    if module == "splicer.batch":
        pytest.importorskip("dask.distributed")
    (tmp_path / "interrupted_run.py").write_text(_INTERRUPT_IN_EXEC.format(module=module, stage=stage, argv=argv))
    p = subprocess.run([sys.executable, "-m", "interrupted_run"], cwd=tmp_path, capture_output=True, text=True,
                       env={**ENV, "PYTHONPATH": f"{tmp_path}{os.pathsep}{ROOT}"}, timeout=300)
    assert (p.returncode, p.stderr) == (130, message + "\n")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["interrupted_run.py"]


@pytest.mark.parametrize("suffix", [".c3d", ".TRC"])
def test_a_marker_file_given_as_a_take_says_where_it_goes(tmp_path, suffix):
    """Fault: the shared C3D given as the hands take was refused as "binary data (NUL byte):
    expected a text BVH file", which does not say that splice takes markers, elsewhere."""
    body, hands = small_files(tmp_path)
    markers = tmp_path / f"hands{suffix}"
    markers.write_bytes(b"\x02\x50\x00binary")
    out = tmp_path / "out.bvh"
    for argv in ([body, markers, "-o", out], [markers, hands, "-o", out]):
        status, _, err = run_cli(argv)
        assert status == 1 and not out.exists()
        assert one_error_line(err) == (f"splice: error: {markers}: optical markers ({suffix[1:].upper()}), not a motion: "
                                       "give the take's BVH or FBX here, and the markers with --hands-markers or "
                                       "--body-markers (hands_markers= or body_markers= in Python)")
    assert markers.read_bytes() == b"\x02\x50\x00binary"
