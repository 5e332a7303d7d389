"""``splice-server`` (issue 12, warm runs): a command handed to a running server behaves as the
command run by itself — the same bytes, messages, exit status, files — and signals reach the run.

Each test reads the server's own count of runs (``ping``), so a test cannot pass by the command
quietly running itself.  Linux/macOS only (fork, Unix sockets)."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from fault_helpers import SAMPLE_BODY, SAMPLE_HANDS, SAMPLE_SYNC, one_error_line, small_files, temporaries

ROOT = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not (hasattr(os, "fork") and hasattr(socket, "AF_UNIX")),
                                 reason="splice-server needs fork and Unix sockets")]

# the `splice` console script's code (splicer.server_client.main), runnable without installing
SPLICE = [sys.executable, "-c", "import sys; from splicer.server_client import main; sys.exit(main())"]


@pytest.fixture(autouse=True, scope="module")
def _hangup_at_its_default():
    """The commands start as from a terminal, with SIGHUP at its default.  A suite run under
    ``nohup`` would hand its ignored SIGHUP to every command, whose run then rightly ignores it
    too (the ``nohup splice`` test below), and the hang-up tests would find runs that finish."""
    if not hasattr(signal, "SIGHUP"):
        yield
        return
    before = signal.getsignal(signal.SIGHUP)
    if before == signal.SIG_IGN:
        signal.signal(signal.SIGHUP, signal.SIG_DFL)
    try:
        yield
    finally:
        signal.signal(signal.SIGHUP, before)


def _env(sock: str, **extra) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               SPLICER_SERVER_SOCKET=sock)
    env.pop("SPLICER_SERVER", None)
    env.update(extra)
    return env


def _server(args, sock, **kw):
    return subprocess.run([sys.executable, "-m", "splicer.server", *args], env=_env(sock), capture_output=True,
                          text=True, timeout=600, **kw)


def _ping(sock: str) -> dict | None:
    from splicer.server import _query

    return _query("ping", sock)


class Server:
    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="spl-")  # short: a Unix socket's path is at most ~100 bytes
        os.chmod(self.dir, 0o700)
        self.sock = os.path.join(self.dir, "s.sock")
        r = _server(["start", "--socket", self.sock, "--idle", "10"], self.sock)  # an orphan stops on its own
        assert r.returncode == 0, r.stdout + r.stderr
        assert "ready" in r.stdout

    def runs(self) -> int:
        info = _ping(self.sock)
        assert info is not None, "the server is not running"
        return info["runs"]

    def wait_spare(self, timeout: float = 120.0) -> None:
        """Until the spare run is ready (as after `start`), so runs take the path users see."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            info = _ping(self.sock)
            if info is not None and info["spare"] != "warming" and info["running"] == 0:
                return
            time.sleep(0.05)
        raise AssertionError("the spare run never got ready")

    def splice(self, args, cwd=None, **kw):
        return subprocess.run([*SPLICE, *map(str, args)], env=_env(self.sock, **kw.pop("env", {})), cwd=cwd,
                              capture_output=True, text=True, timeout=600, **kw)

    def stop(self):
        _server(["stop", "--socket", self.sock], self.sock)
        shutil.rmtree(self.dir, ignore_errors=True)


@pytest.fixture(scope="module")
def server():
    s = Server()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def long_pair(tmp_path_factory):
    """A 40-s pair of the evaluation protocol: a run long enough to be interrupted in the middle."""
    from splicer.evaluation.separate import separate
    from splicer.evaluation.synth import make_gesture_take
    from splicer.io.bvh import write_bvh

    d = tmp_path_factory.mktemp("long")
    sep = separate(make_gesture_take(40.0, 30.0, np.random.default_rng(5)), rng=np.random.default_rng(5))
    write_bvh(sep.body, d / "body.bvh")
    write_bvh(sep.hands, d / "hands.bvh")
    return d / "body.bvh", d / "hands.bvh"


def test_a_run_on_the_server_writes_what_the_command_writes(server, tmp_path):
    """The bundled sample through the server and by the command itself: the same BVH bytes, the same
    report apart from its timings, the same summary apart from the times; served by the server."""
    args = [SAMPLE_BODY, SAMPLE_HANDS, "--constraints", SAMPLE_SYNC]
    server.wait_spare()
    before = server.runs()
    on = server.splice([*args, "-o", tmp_path / "a.bvh", "--report", tmp_path / "a.json", "--plot", tmp_path / "a.png"])
    assert on.returncode == 0, on.stderr
    assert server.runs() == before + 1
    off = server.splice([*args, "-o", tmp_path / "b.bvh", "--report", tmp_path / "b.json"], env={"SPLICER_SERVER": "off"})
    assert off.returncode == 0, off.stderr
    assert server.runs() == before + 1  # SPLICER_SERVER=off: the command ran itself
    assert (tmp_path / "a.bvh").read_bytes() == (tmp_path / "b.bvh").read_bytes()
    import json

    a, b = (json.loads((tmp_path / f"{n}.json").read_text()) for n in "ab")
    for r in (a, b):
        r.pop("timings_s")
    assert a == b
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert on.stdout.startswith("Spliced 1985 hand frames") and off.stdout.startswith("Spliced 1985 hand frames")
    assert on.stdout.split(" warning(s): ")[1] == off.stdout.split(" warning(s): ")[1]  # the times differ


def test_relative_paths_and_umask_are_the_commands(server, tmp_path):
    body, hands = small_files(tmp_path)
    server.wait_spare()
    before = server.runs()
    r = server.splice(["body.bvh", "hands.bvh", "-o", "out.bvh", "-q"], cwd=tmp_path,
                      preexec_fn=lambda: os.umask(0o077))
    assert r.returncode == 0 and r.stdout == "" and r.stderr == "", r.stderr
    assert server.runs() == before + 1
    assert (os.stat(tmp_path / "out.bvh").st_mode & 0o777) == 0o600


def test_bad_input_on_the_server_is_one_line_and_writes_nothing(server, tmp_path):
    body, _ = small_files(tmp_path)
    (tmp_path / "bad.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n")
    before = server.runs()
    r = server.splice([body, tmp_path / "bad.bvh", "-o", tmp_path / "out.bvh", "--report", tmp_path / "r.json"])
    assert r.returncode == 1
    line = one_error_line(r.stderr)
    assert line.startswith("splice: error: ") and "bad.bvh" in line and "line 4" in line, line
    assert server.runs() == before + 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.bvh", "body.bvh", "hands.bvh"]


def test_usage_errors_help_and_version_are_the_parsers(server, tmp_path):
    r = server.splice(["a.bvh", "b.bvh", "-o", "o.bvh", "--band", "x" * 50])
    assert r.returncode == 2 and r.stderr.startswith("splice: error: argument --band"), r.stderr
    r = server.splice(["--version"])
    assert r.returncode == 0 and "splice (splicer)" in r.stdout
    r = server.splice(["--help"])
    assert r.returncode == 0 and r.stdout.startswith("usage: splice")


def _wait_running(server, n: int, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        info = _ping(server.sock)
        if info is not None and info["running"] == n:
            return
        time.sleep(0.01)
    raise AssertionError(f"never {n} run(s) on the server")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_to_the_command_interrupts_the_run(server, long_pair, tmp_path, sig):
    body, hands = long_pair
    server.wait_spare()
    outs = [tmp_path / "out.bvh", tmp_path / "r.json"]
    p = subprocess.Popen([*SPLICE, str(body), str(hands), "-o", str(outs[0]), "--report", str(outs[1]), "-q"],
                         env=_env(server.sock), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_running(server, 1)
    time.sleep(0.2)  # past the run's start, well before its end (the pair takes over a second)
    p.send_signal(sig)
    out, err = p.communicate(timeout=300)
    assert p.returncode == 128 + int(sig), (p.returncode, err)
    assert one_error_line(err) == f"splice: interrupted ({signal.Signals(sig).name}); nothing was written"
    assert list(tmp_path.iterdir()) == []
    _wait_running(server, 0)


def test_a_command_killed_outright_hangs_up_its_run(server, long_pair, tmp_path):
    body, hands = long_pair
    server.wait_spare()
    p = subprocess.Popen([*SPLICE, str(body), str(hands), "-o", str(tmp_path / "out.bvh"), "-q"],
                         env=_env(server.sock), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _wait_running(server, 1)
    time.sleep(0.2)
    p.kill()
    p.wait()
    _wait_running(server, 0)  # the run got SIGHUP when the command's connection closed, and cleaned up
    assert list(tmp_path.iterdir()) == [] and temporaries(tmp_path) == []


def test_no_server_or_a_dead_socket_runs_the_command_itself(tmp_path):
    body, hands = small_files(tmp_path)
    d = tempfile.mkdtemp(prefix="spl-")
    try:
        dead = os.path.join(d, "s.sock")
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.bind(dead)
        s.close()  # a socket file nobody listens at (a server killed outright)
        for sock in (dead, os.path.join(d, "none.sock")):
            r = subprocess.run([*SPLICE, str(body), str(hands), "-o", str(tmp_path / "o.bvh"), "-q"], env=_env(sock),
                               capture_output=True, text=True, timeout=300)
            assert r.returncode == 0 and r.stderr == "", r.stderr
            assert (tmp_path / "o.bvh").exists()
            (tmp_path / "o.bvh").unlink()
    finally:
        shutil.rmtree(d, ignore_errors=True)


def test_other_code_is_refused_and_stops_the_server(tmp_path, monkeypatch):
    """A command of another install runs itself and leaves the server running; one of the same install
    whose code differs (an edit, an upgrade) runs itself and stops the server."""
    from splicer import server_client

    s = Server()
    try:
        monkeypatch.setenv("SPLICER_SERVER_SOCKET", s.sock)
        monkeypatch.delenv("SPLICER_SERVER", raising=False)
        body, hands = small_files(tmp_path)
        argv = [str(body), str(hands), "-o", str(tmp_path / "o.bvh"), "-q"]
        real = server_client.fingerprint()
        exe, folder = real.split("|")[:2]
        monkeypatch.setattr(server_client, "fingerprint", lambda: f"/other/python|{folder}|0.0|1|1")
        assert server_client.delegate(argv) is None
        assert _ping(s.sock) is not None  # another install: still running
        monkeypatch.setattr(server_client, "fingerprint", lambda: real + "0")  # this install, edited
        assert server_client.delegate(argv) is None
        deadline = time.monotonic() + 30
        while _ping(s.sock) is not None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _ping(s.sock) is None and not os.path.exists(s.sock)
        assert not (tmp_path / "o.bvh").exists()
    finally:
        s.stop()


def test_start_status_stop(tmp_path):
    d = tempfile.mkdtemp(prefix="spl-")
    sock = os.path.join(d, "s.sock")
    try:
        r = _server(["status", "--socket", sock], sock)
        assert r.returncode == 3 and "not running" in r.stdout
        r = _server(["start", "--socket", sock, "--idle", "5"], sock)
        assert r.returncode == 0 and "ready (pid" in r.stdout, r.stdout + r.stderr
        r = _server(["start", "--socket", sock], sock)
        assert r.returncode == 0 and "already running" in r.stdout
        r = _server(["status", "--socket", sock], sock)
        assert r.returncode == 0 and "running (pid" in r.stdout and "0 run(s) served" in r.stdout, r.stdout
        r = _server(["stop", "--socket", sock], sock)
        assert r.returncode == 0 and "stopped" in r.stdout
        assert not os.path.exists(sock)
        r = _server(["stop", "--socket", sock], sock)
        assert r.returncode == 0 and "not running" in r.stdout
    finally:
        _server(["stop", "--socket", sock], sock)
        shutil.rmtree(d, ignore_errors=True)


def test_stop_lets_a_run_in_progress_finish(long_pair, tmp_path):
    body, hands = long_pair
    s = Server()
    try:
        s.wait_spare()
        p = subprocess.Popen([*SPLICE, str(body), str(hands), "-o", str(tmp_path / "out.bvh"), "-q"],
                             env=_env(s.sock), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _wait_running(s, 1)
        r = _server(["stop", "--socket", s.sock], s.sock)
        assert r.returncode == 0 and "stopped" in r.stdout
        assert not os.path.exists(s.sock)  # later commands run by themselves
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0 and err == "", err
        assert (tmp_path / "out.bvh").stat().st_size > 0
    finally:
        s.stop()


def _state(pid: int) -> str:
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rsplit(")", 1)[1].split()[0]


def _wait_stopped(*pids: int, timeout: float = 30) -> tuple:
    """The processes' states once all are stopped ("T"), or as they are after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while any(_state(p) != "T" for p in pids) and time.monotonic() < deadline:
        time.sleep(0.02)
    return tuple(_state(p) for p in pids)


def _long_splice(server, long_pair, tmp_path, **popen):
    """``splice`` of the long pair through the server, started and running in its run (``popen``:
    how the command's process group is set up)."""
    body, hands = long_pair
    server.wait_spare()
    p = subprocess.Popen([*SPLICE, str(body), str(hands), "-o", str(tmp_path / "out.bvh"), "-q"],
                         env=_env(server.sock), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **popen)
    _wait_running(server, 1)
    time.sleep(0.2)
    return p


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="reads process states from /proc")
def test_ctrl_z_stops_the_run_with_the_command_and_sigcont_resumes_both(server, long_pair, tmp_path):
    # its own process group, whose parent (this process) is in the session: a shell's job, which
    # SIGTSTP stops; in an orphaned group (pytest started by a shell that has exited) it would not
    p = _long_splice(server, long_pair, tmp_path, process_group=0)
    (run,) = _ping(server.sock)["run_pids"]
    p.send_signal(signal.SIGTSTP)
    assert _wait_stopped(p.pid, run) == ("T", "T")
    p.send_signal(signal.SIGCONT)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0 and err == "", err
    assert (tmp_path / "out.bvh").stat().st_size > 0


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="reads process states from /proc")
def test_ctrl_z_where_no_shell_controls_the_command_leaves_the_run_going(server, long_pair, tmp_path):
    """A command in a process group no shell controls (its own session here, as under setsid or a
    script whose shell has exited): the kernel drops SIGTSTP, so the command goes on, and its run
    must too (it was left stopped, and the command waited for it forever)."""
    p = _long_splice(server, long_pair, tmp_path, start_new_session=True)
    p.send_signal(signal.SIGTSTP)
    _, err = p.communicate(timeout=300)  # no SIGCONT is sent
    assert p.returncode == 0 and err == "", err
    assert (tmp_path / "out.bvh").stat().st_size > 0


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="reads process states from /proc")
def test_a_command_killed_while_suspended_does_not_leave_its_run_stopped(server, long_pair, tmp_path):
    """Ctrl-Z, then the command killed outright (`kill -9 %1`): the server hangs its run up, and a
    stopped run must also be continued to act on it (it stayed stopped, and the server with it)."""
    p = _long_splice(server, long_pair, tmp_path, process_group=0)
    (run,) = _ping(server.sock)["run_pids"]
    p.send_signal(signal.SIGTSTP)
    assert _wait_stopped(run) == ("T",)
    p.kill()
    p.wait(timeout=60)
    _wait_running(server, 0)                 # the run holds the command's pipes until it ends
    p.communicate(timeout=60)
    assert not (tmp_path / "out.bvh").exists() and temporaries(tmp_path) == []


def test_the_commands_resource_limits_hold_in_its_run(server, tmp_path):
    """`ulimit -f` of the command: the run cannot write a file over it (the command's own limit, not the
    server's), so the output is refused as when the command runs by itself; nothing is left."""
    import resource

    body, hands = small_files(tmp_path)

    def small_files_only():
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write over the limit fails instead of killing

    server.wait_spare()
    before = server.runs()
    r = server.splice([body, hands, "-o", tmp_path / "out.bvh", "-q"], preexec_fn=small_files_only)
    assert server.runs() == before + 1
    off = server.splice([body, hands, "-o", tmp_path / "out.bvh", "-q"], preexec_fn=small_files_only,
                        env={"SPLICER_SERVER": "off"})
    assert r.returncode == off.returncode == 1, (r.stderr, off.stderr)
    assert r.stderr == off.stderr and one_error_line(r.stderr).startswith("splice: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["body.bvh", "hands.bvh"]


def test_signals_the_command_ignores_stay_ignored_in_its_run(server, long_pair, tmp_path):
    """`nohup splice ...`: SIGHUP ignored by the command is ignored by its run too (as across exec)."""
    body, hands = long_pair
    server.wait_spare()
    p = subprocess.Popen([*SPLICE, str(body), str(hands), "-o", str(tmp_path / "out.bvh"), "-q"],
                         env=_env(server.sock), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    _wait_running(server, 1)
    time.sleep(0.2)
    (run,) = _ping(server.sock)["run_pids"]
    os.kill(run, signal.SIGHUP)  # as a hang-up of the terminal would reach it
    p.send_signal(signal.SIGHUP)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0 and err == "", err
    assert (tmp_path / "out.bvh").stat().st_size > 0
