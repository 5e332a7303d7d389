"""``splice-server``: a warm process that runs ``splice`` commands, so that repeated runs skip
starting Python's numeric stack and numba and loading the compiled kernels (issue 12: over half of
a warm run on the bundled sample).

``splice-server start`` starts it in the background; while it runs, every ``splice`` command of the
same user and the same installed code hands its run to it (:mod:`splicer.server_client`).  Each
run is a process forked from the server: it starts in the command's folder, with its environment,
umask, resource limits (the lower of its and the server's), standard input, output and error, so
it behaves as the command would (the same files,
messages and exit status; Ctrl-C, SIGTERM and SIGHUP reach it through the command; a command
killed outright hangs the run up, which then cleans up as on SIGHUP), and nothing of one run
stays in the server for the next.  One run is forked ahead of time, the *spare*: it loads the
kernels and repeats a warm-up splice, then waits for the next command.  The server stops after
``--idle`` minutes without a run (default 30), at ``splice-server stop``, or at the first command
of the same install (interpreter and package folder) whose code differs from the one it loaded (an
edited or upgraded package: that command, and every later one, runs itself; a command of another
install runs itself and leaves the server running).  ``SPLICER_SERVER=off`` makes ``splice`` ignore it.

The server itself never runs a parallel kernel: once numba's OpenMP threads have started in a
process, a process forked from it cannot use them.  Linux and macOS (``fork``, Unix sockets).
"""

from __future__ import annotations

import argparse
import os
import selectors
import signal
import socket
import sys
import time

from . import __version__
from .server_client import apply_limits, connect, fingerprint, recv_message, send_message, socket_path

#: Minutes without a run after which the server stops.
IDLE_MINUTES = 30.0
#: Seconds of the pair each spare run splices to load the kernels.
WARM_UP_S = 12.0
#: Seconds ``start`` waits for the server to be ready (the first start in a new environment compiles
#: numba's kernels).
START_TIMEOUT_S = 300.0


def _prepare(folder: str) -> list[str]:
    """Import what a run uses (splicer's modules, numba, the compiled BVH parser and formatter, Pillow)
    and write a short pair of the evaluation protocol to ``folder``; returns the arguments of the
    warm-up run each spare makes on it (:class:`_Server`), with a report and a plot.

    Runs no parallel kernel: once numba's OpenMP threads have started, a forked process cannot use
    them, so only the forked runs load the kernels."""
    import warnings

    from . import cli

    cli._start_numba_without_scipy()  # as the command does
    import numpy as np

    from . import pipeline, plot, report  # noqa: F401
    from .evaluation.separate import separate
    from .evaluation.synth import make_gesture_take
    from .io import fastformat, fastparse, motion_io  # noqa: F401  (loaded: they read and write every BVH block)
    from .io.bvh import write_bvh
    import PIL.Image  # noqa: F401
    import PIL.ImageDraw  # noqa: F401

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sep = separate(make_gesture_take(WARM_UP_S, 30.0, np.random.default_rng(0)), rng=np.random.default_rng(0))
    write_bvh(sep.body, os.path.join(folder, "body.bvh"))
    write_bvh(sep.hands, os.path.join(folder, "hands.bvh"))
    return [os.path.join(folder, "body.bvh"), os.path.join(folder, "hands.bvh"), "-o", os.path.join(folder, "out.bvh"),
            "--report", os.path.join(folder, "r.json"), "--plot", os.path.join(folder, "p.png"), "-q"]


def _threads_started() -> bool:
    """Whether numba's parallel threads have started in this process (then it must not fork runs)."""
    mod = sys.modules.get("numba.np.ufunc.parallel")
    return bool(mod is not None and getattr(mod, "_is_initialized", False))


def _peer_uid(conn: socket.socket) -> int | None:
    opt = getattr(socket, "SO_PEERCRED", None)
    if opt is None:
        return None
    import struct

    pid, uid, gid = struct.unpack("3i", conn.getsockopt(socket.SOL_SOCKET, opt, struct.calcsize("3i")))
    return uid


class _Server:
    """The accept loop.  Each run is a process forked from the server.  The server cannot load the
    parallel kernels itself (:func:`_prepare`), and a run that loads them from numba's disk cache
    takes about twice as long on the bundled sample; so one run, the *spare*, is forked ahead of
    time and makes the warm-up splice (loading every kernel) before it waits for a command.  A
    command that arrives while the spare is still warming up is forked directly.  After a run ends
    (and at the start) the next spare is forked."""

    def __init__(self, path: str, idle_s: float):
        self.path = path
        self.idle_s = idle_s
        self.print_ = fingerprint()
        self.started = time.time()
        self.runs = 0
        self.children: dict[int, socket.socket] = {}  # run's pid -> the command's connection
        self.spare: tuple[int, socket.socket] | None = None  # pid, the server's end of its socket pair
        self.spare_ready = False
        self.spare_failed = 0  # spares that died before they were ready
        self.warm_argv: list[str] | None = None
        self.stop = False
        self.last = time.monotonic()

    # -- the loop -------------------------------------------------------------------------------------
    def listen(self) -> None:
        folder = os.path.dirname(self.path)
        os.makedirs(folder, mode=0o700, exist_ok=True)
        st = os.stat(folder)
        if st.st_uid != os.getuid() or st.st_mode & 0o077:
            raise SystemExit(f"splice-server: error: {folder} must belong to you and be private (mode 700)")
        other = connect(self.path, timeout=1.0)
        if other is not None:
            other.close()
            raise SystemExit(f"splice-server: error: a server already listens at {self.path}")
        if os.path.lexists(self.path):
            os.unlink(self.path)  # left by a server that did not stop cleanly
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)
        try:
            self.sock.bind(self.path)
        finally:
            os.umask(old)
        self.inode = os.stat(self.path).st_ino
        self.sock.listen(16)
        self.sock.setblocking(False)

    def serve(self, warm_argv: list[str] | None = None) -> None:
        self.warm_argv = warm_argv
        r, w = os.pipe()
        os.set_blocking(w, False)
        os.set_blocking(r, False)
        self.wake_r, self.wake_w = r, w
        signal.set_wakeup_fd(w)
        signal.signal(signal.SIGCHLD, lambda s, f: None)
        for s in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(s, self._on_stop)
        self.sel = selectors.DefaultSelector()
        self.sel.register(self.sock, selectors.EVENT_READ, "accept")
        self.sel.register(r, selectors.EVENT_READ, "wake")
        self._fork_spare()
        try:
            while not self.stop:
                timeout = None
                if not self.children:
                    timeout = max(0.0, self.idle_s - (time.monotonic() - self.last))
                    if timeout == 0.0:
                        break
                for key, _ in self.sel.select(timeout):
                    if key.data == "accept":
                        self._accept()
                    elif key.data == "spare":
                        self._spare_says()
                    else:
                        self._wake_or_hang_up(key)
                self._reap()
        finally:
            self._shutdown()

    def _on_stop(self, signum, frame):
        self.stop = True

    def _shutdown(self) -> None:
        """Stop taking commands (later ones run by themselves), then let the runs in progress finish."""
        try:
            if os.stat(self.path).st_ino == self.inode:  # not a newer server's socket
                os.unlink(self.path)
        except OSError:
            pass
        self.sel.unregister(self.sock)
        self.sock.close()
        self.stop = True  # no new spare
        self._drop_spare()
        while self.children:
            for key, _ in self.sel.select(0.5):
                self._wake_or_hang_up(key)
            self._reap()

    def _wake_or_hang_up(self, key) -> None:
        """The signal pipe readable: empty it (:meth:`_reap` follows).  A command's connection readable:
        the command went away mid-run, so its run (``key.data``, its pid) gets SIGHUP, and SIGCONT: a run
        stopped with its command (Ctrl-Z, then the command killed) would keep the SIGHUP pending forever."""
        if key.data == "wake":
            try:
                while os.read(self.wake_r, 512):
                    pass
            except BlockingIOError:
                pass
            return
        self.sel.unregister(key.fileobj)
        try:
            os.kill(key.data, signal.SIGHUP)
            os.kill(key.data, signal.SIGCONT)
        except ProcessLookupError:
            pass

    # -- the spare run ------------------------------------------------------------------------------
    def _fork_spare(self) -> None:
        if self.warm_argv is None or self.spare is not None or self.stop:
            return
        mine, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
        pid = os.fork()
        if pid == 0:  # the spare
            code = 1
            conn = None
            try:
                mine.close()
                self._become_run()
                from .cli import main

                with open(os.devnull, "w") as null:  # the warm-up run's output goes nowhere
                    saved = sys.stdout, sys.stderr
                    sys.stdout = sys.stderr = null
                    try:
                        main(list(self.warm_argv))
                    finally:
                        sys.stdout, sys.stderr = saved
                theirs.sendall(b"R")
                msg, fds = recv_message(theirs, maxfds=4)
                if msg is None or len(fds) != 4:
                    os._exit(0)  # the server stopped
                theirs.close()
                conn = socket.socket(fileno=fds[0])
                code = self._run(conn, msg, fds[1:])
            except BaseException:  # noqa: BLE001 - a child never returns into the server's loop
                code = self._crashed()
            self._exit(conn, code)
        theirs.close()
        self.spare = (pid, mine)
        self.spare_ready = False
        self.sel.register(mine, selectors.EVENT_READ, "spare")

    def _spare_says(self) -> None:
        pid, mine = self.spare
        try:
            said = mine.recv(1)
        except OSError:
            said = b""
        if said == b"R":
            self.spare_ready = True
        else:  # it died while warming up: runs are forked directly until the next spare
            self.spare_failed += 1
            self._drop_spare(kill=False)

    def _drop_spare(self, kill: bool = True) -> None:
        if self.spare is None:
            return
        pid, mine = self.spare
        self.spare, self.spare_ready = None, False
        try:
            self.sel.unregister(mine)
        except (KeyError, ValueError):
            pass
        mine.close()
        if kill:
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass

    # -- runs -----------------------------------------------------------------------------------------
    def _reap(self) -> None:
        while True:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                self.children.clear()
                return
            if pid == 0:
                return
            if self.spare is not None and pid == self.spare[0]:
                if not self.spare_ready:
                    self.spare_failed += 1
                self._drop_spare(kill=False)
                continue
            conn = self.children.pop(pid, None)
            if conn is None:
                continue
            try:
                self.sel.unregister(conn)
            except (KeyError, ValueError):
                pass
            if os.WIFSIGNALED(status):
                try:
                    send_message(conn, {"signal": os.WTERMSIG(status)})
                except OSError:
                    pass
            conn.close()
            self.last = time.monotonic()
            if not self.children:
                self._fork_spare()  # warms up while the machine is free

    def _accept(self) -> None:
        try:
            conn, _ = self.sock.accept()
        except (BlockingIOError, InterruptedError):
            return
        conn.setblocking(True)
        conn.settimeout(5.0)
        fds: list[int] = []
        try:
            uid = _peer_uid(conn)
            if uid is not None and uid != os.getuid():
                conn.close()
                return
            msg, fds = recv_message(conn, maxfds=3)
            if msg is None:
                conn.close()
                return
            cmd = msg.get("cmd")
            if cmd == "ping":
                send_message(conn, {"pid": os.getpid(), "version": __version__, "fingerprint": self.print_,
                                    "started": self.started, "runs": self.runs, "running": len(self.children), "run_pids": sorted(self.children),
                                    "spare": "ready" if self.spare_ready else "failed" if self.spare_failed else "warming", "idle_s": self.idle_s, "socket": self.path})
                conn.close()
            elif cmd == "stop":
                send_message(conn, {"stopping": os.getpid()})
                conn.close()
                self.stop = True
            elif cmd == "splice":
                theirs = str(msg.get("fingerprint"))
                if theirs != self.print_:
                    send_message(conn, {"refused": "the installed splicer differs from the one this server loaded"})
                    conn.close()
                    # the same install (interpreter and folder) with other code: an edit or upgrade, so every
                    # later command would be refused too; another install's command leaves it running
                    self.stop = theirs.split("|")[:2] == self.print_.split("|")[:2]
                    return
                if len(fds) != 3:
                    send_message(conn, {"refused": "standard input, output and error were not passed"})
                    conn.close()
                    return
                self._start_run(conn, msg, fds)
            else:
                conn.close()
        except (OSError, ValueError):
            conn.close()
        finally:
            for fd in fds:
                os.close(fd)

    def _start_run(self, conn: socket.socket, msg: dict, fds: list[int]) -> None:
        pid = None
        if self.spare is not None and self.spare_ready:
            spare_pid, mine = self.spare
            try:
                send_message(mine, msg, [conn.fileno(), *fds])
                pid = spare_pid
            except OSError:
                pass
            self._drop_spare(kill=pid is None)
        if pid is None:
            pid = os.fork()
            if pid == 0:  # the run
                code = 1
                try:
                    self._become_run()
                    code = self._run(conn, msg, fds)
                except BaseException:  # noqa: BLE001 - a child never returns into the server's loop
                    code = self._crashed()
                self._exit(conn, code)
        self.runs += 1
        self.last = time.monotonic()
        conn.settimeout(None)
        self.children[pid] = conn
        self.sel.register(conn, selectors.EVENT_READ, pid)

    def _become_run(self) -> None:
        """In a process just forked: drop the server's signal handlers, sockets and pipes."""
        signal.set_wakeup_fd(-1)
        for s in (signal.SIGCHLD, signal.SIGTERM, signal.SIGHUP):
            signal.signal(s, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        self.sel.close()
        self.sock.close()
        for other in self.children.values():
            other.close()
        if self.spare is not None:
            self.spare[1].close()
        os.close(self.wake_r)
        os.close(self.wake_w)

    @staticmethod
    def _crashed() -> int:
        try:
            import traceback

            traceback.print_exc()
        except BaseException:  # noqa: BLE001
            pass
        return 1

    @staticmethod
    def _exit(conn: socket.socket | None, code: int) -> None:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except BaseException:  # noqa: BLE001
            pass
        if conn is not None:
            try:
                send_message(conn, {"exit": int(code)})
            except BaseException:  # noqa: BLE001
                pass
        os._exit(int(code) & 0xFF)

    @staticmethod
    def _run(conn: socket.socket, msg: dict, fds: list[int]) -> int:
        """The command's run, in its folder, environment, umask and standard streams."""
        import io

        conn.settimeout(None)
        for target, fd in enumerate(fds):
            os.dup2(fd, target)
        for fd in set(fds) - {0, 1, 2}:
            os.close(fd)
        os.umask(int(msg["umask"]))
        apply_limits(msg.get("limits") or {})
        for signum in msg.get("ignored") or ():  # as across exec: `nohup splice ...` keeps SIGHUP ignored
            signal.signal(int(signum), signal.SIG_IGN)
        os.chdir(msg["cwd"])
        os.environ.clear()
        os.environ.update(msg["env"])
        enc, errs = msg["encoding"], msg["errors"]
        sys.stdin = io.TextIOWrapper(io.FileIO(0, "r", closefd=False))
        sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), encoding=enc[0], errors=errs[0],
                                      line_buffering=os.isatty(1))
        sys.stderr = io.TextIOWrapper(io.FileIO(2, "w", closefd=False), encoding=enc[1], errors=errs[1],
                                      line_buffering=True)
        sys.argv = [msg.get("prog") or "splice", *msg["argv"]]
        from .cli import main

        try:
            send_message(conn, {"pid": os.getpid()})  # from now on the command passes its signals on
            return main(list(msg["argv"]))
        except KeyboardInterrupt:  # before the command's own handlers were in place
            print("splice: interrupted (SIGINT); nothing was written", file=sys.stderr)
            return 128 + int(signal.SIGINT)
        except SystemExit as e:
            if e.code is None:
                return 0
            if isinstance(e.code, int):
                return e.code
            print(e.code, file=sys.stderr)
            return 1


def _query(cmd: str, path: str) -> dict | None:
    sock = connect(path)
    if sock is None:
        return None
    try:
        sock.settimeout(10.0)
        send_message(sock, {"cmd": cmd})
        msg, _ = recv_message(sock)
        return msg
    except (OSError, ValueError):
        return None
    finally:
        sock.close()


def run(path: str, idle_minutes: float) -> int:
    """The server in this process (``splice-server run``): warm up, then serve until stopped."""
    if "numba" in sys.modules:
        raise SystemExit("splice-server: error: numba is already loaded in this process; run the server in its own")
    server = _Server(path, idle_minutes * 60.0)
    server.listen()  # refuse early when another server listens
    import tempfile

    folder = tempfile.mkdtemp(prefix="splicer-server-")
    try:
        warm_argv = _prepare(folder)
        if _threads_started():
            raise SystemExit("splice-server: error: numba's parallel threads started while loading; cannot fork runs")
        import gc

        gc.collect()
        gc.freeze()  # the forked runs share the server's objects' pages instead of copying them
        server.serve(warm_argv)
    finally:
        if getattr(server, "sel", None) is None:
            server.sock.close()
            try:
                os.unlink(path)
            except OSError:
                pass
        import shutil

        shutil.rmtree(folder, ignore_errors=True)
    return 0


def start(path: str, idle_minutes: float, quiet: bool = False) -> int:
    import subprocess

    info = _query("ping", path)
    if info is not None and info.get("fingerprint") == fingerprint():
        if not quiet:
            print(f"splice-server: already running (pid {info['pid']}, socket {path})")
        return 0
    if info is not None:
        _query("stop", path)
        _wait_gone(path, 10.0)
    folder = os.path.dirname(path)
    os.makedirs(folder, mode=0o700, exist_ok=True)
    log = os.path.join(folder, "server.log")
    with open(log, "w") as f:
        proc = subprocess.Popen([sys.executable, "-m", "splicer.server", "run", "--socket", path,
                                 "--idle", str(idle_minutes)], stdin=subprocess.DEVNULL, stdout=f, stderr=f,
                                start_new_session=True, close_fds=True)
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        info = _query("ping", path)
        if info is not None and info.get("pid") == proc.pid and info.get("spare") != "warming":
            if info.get("spare") == "failed":
                print(f"splice-server: warning: its warm-up run failed (log: {log}); runs start cold", file=sys.stderr)
            if not quiet:
                print(f"splice-server: ready (pid {proc.pid}, socket {path}); `splice` runs go through it "
                      f"until `splice-server stop` or {idle_minutes:g} minutes without a run")
            return 0
        if proc.poll() is not None:
            with open(log) as f:
                last = [line for line in f.read().splitlines() if line.strip()][-1:] or ["no message"]
            print(f"splice-server: error: the server exited ({proc.returncode}) before it was ready: {last[0]} "
                  f"(log: {log})", file=sys.stderr)
            return 1
        time.sleep(0.1)
    proc.terminate()
    print(f"splice-server: error: not ready after {START_TIMEOUT_S:g} s (log: {log})", file=sys.stderr)
    return 1


def _wait_gone(path: str, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if _query("ping", path) is None:
            return True
        time.sleep(0.05)
    return False


def stop(path: str, quiet: bool = False) -> int:
    info = _query("stop", path)
    if info is None:
        if not quiet:
            print("splice-server: not running")
        return 0
    ok = _wait_gone(path, 15.0)
    if not quiet:
        print(f"splice-server: stopped (pid {info['stopping']})" if ok else
              f"splice-server: pid {info['stopping']} is still finishing its runs")
    return 0 if ok else 1


def status(path: str) -> int:
    info = _query("ping", path)
    if info is None:
        print(f"splice-server: not running (socket {path})")
        return 3
    same = info.get("fingerprint") == fingerprint()
    up = time.time() - float(info["started"])
    print(f"splice-server: running (pid {info['pid']}, splicer {info['version']}, socket {path}); up {up:.0f} s, "
          f"{info['runs']} run(s) served, {info['running']} running; stops after {float(info['idle_s']) / 60:g} "
          f"idle minutes" + ("" if same else "; it loaded other code than this splicer: `splice` runs itself, "
                                            "and the server stops at its next run"))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="splice-server", description="Keep a warm process that runs `splice` "
                                "commands, so repeated runs skip start-up (see the README, section Speed).")
    p.add_argument("--version", action="version", version=f"%(prog)s (splicer) {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True)
    for name, helptext in (("start", "start in the background (returns when ready)"),
                           ("run", "run in the foreground"),
                           ("stop", "stop a running server"), ("status", "say whether one runs")):
        s = sub.add_parser(name, help=helptext)
        s.add_argument("--socket", default=None, help="its Unix socket (default: $SPLICER_SERVER_SOCKET, else "
                                                      "splicer-<uid>/server.sock in $XDG_RUNTIME_DIR or /tmp)")
        if name in ("start", "run"):
            s.add_argument("--idle", type=float, default=IDLE_MINUTES, metavar="MINUTES",
                           help=f"stop after this many minutes without a run (default {IDLE_MINUTES:g})")
        if name in ("start", "stop"):
            s.add_argument("-q", "--quiet", action="store_true")
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if not (hasattr(os, "fork") and hasattr(socket, "AF_UNIX") and hasattr(socket, "send_fds")):
        print("splice-server: error: needs fork and Unix sockets (Linux, macOS)", file=sys.stderr)
        return 1
    path = os.path.abspath(args.socket or socket_path())
    if args.cmd == "run":
        return run(path, args.idle)
    if args.cmd == "start":
        return start(path, args.idle, args.quiet)
    if args.cmd == "stop":
        return stop(path, args.quiet)
    return status(path)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
