"""The ``splice`` command's side of ``splice-server`` (:mod:`splicer.server`): hand a run to a warm
server when one is running for this user and this very code, else let the command run it itself.

Imports nothing numeric (the command's start-up stays what ``--help`` costs).  The protocol, on a
Unix stream socket: the client sends one message (a 4-byte big-endian length, then JSON) with its
standard input, output and error attached as file descriptors (``SCM_RIGHTS``); the run, forked
from the server, writes to those descriptors itself and sends ``{"pid": N}`` and, when done,
``{"exit": CODE}``; the server sends ``{"signal": S}`` when the run died of a signal, or
``{"refused": WHY}`` when it will not take the run (then the command runs it itself).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import sys

#: ``SPLICER_SERVER=off`` (or ``0``, ``no``): the ``splice`` command never hands its run to a server.
ENV_SWITCH = "SPLICER_SERVER"
#: The server's socket, when not the default (:func:`socket_path`).
ENV_SOCKET = "SPLICER_SERVER_SOCKET"
PACKAGE = os.path.dirname(os.path.abspath(__file__))


def socket_path() -> str:
    """``$SPLICER_SERVER_SOCKET``, else ``server.sock`` in ``splicer-<uid>`` of ``$XDG_RUNTIME_DIR``
    (or the temp folder)."""
    given = os.environ.get(ENV_SOCKET)
    if given:
        return given
    base = os.environ.get("XDG_RUNTIME_DIR") or os.environ.get("TMPDIR") or "/tmp"
    return os.path.join(base, f"splicer-{os.getuid()}", "server.sock")


def fingerprint() -> str:
    """What a server must match to run this command's job: the interpreter, the package's folder, its
    version, the newest modification time and number of its Python files, and the times of numpy's,
    numba's and llvmlite's files (an edited or upgraded package, or library, is not run by a server
    that loaded the old one)."""
    from importlib.util import find_spec

    from . import __version__

    libs = []
    for name in ("numpy", "numba", "llvmlite"):  # an upgrade of these (their files' times) counts as other code
        spec = find_spec(name)
        libs.append(f"{name}:{os.stat(spec.origin).st_mtime_ns if spec and spec.origin else None}")
    newest, count = 0, 0
    for root, dirs, files in os.walk(PACKAGE):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for f in files:
            if f.endswith(".py"):
                count += 1
                newest = max(newest, os.stat(os.path.join(root, f)).st_mtime_ns)
    return f"{sys.executable}|{PACKAGE}|{__version__}|{newest}|{count}|{','.join(libs)}"


def send_message(sock: socket.socket, obj: dict, fds: list[int] | None = None) -> None:
    data = json.dumps(obj).encode()
    data = struct.pack(">I", len(data)) + data
    if fds:
        socket.send_fds(sock, [data], fds)
    else:
        sock.sendall(data)


def recv_message(sock: socket.socket, maxfds: int = 0) -> tuple[dict | None, list[int]]:
    """One message (``None`` at end of stream) and the descriptors that came with it."""
    buf, fds, need = b"", [], 4  # the length first, then the message
    while len(buf) < need:
        if maxfds and not buf:
            chunk, got, _, _ = socket.recv_fds(sock, 1 << 16, maxfds)
            fds += got
        else:
            chunk = sock.recv(min(need - len(buf), 1 << 16))
        if not chunk:
            for fd in fds:
                os.close(fd)
            return None, []
        buf += chunk
        if len(buf) >= 4:
            need = 4 + struct.unpack(">I", buf[:4])[0]
            if need > 4 + (1 << 24):
                raise ValueError("message too long")
    return json.loads(buf[4:need]), fds


#: Resource limits a command's run keeps (``ulimit -v``, ``-f``, ``-t``, ``-n``...): the run takes
#: the lower of the command's and the server's.
LIMITS = ("RLIMIT_AS", "RLIMIT_DATA", "RLIMIT_RSS", "RLIMIT_FSIZE", "RLIMIT_CPU", "RLIMIT_NOFILE", "RLIMIT_CORE",
          "RLIMIT_STACK")


def limits() -> dict:
    """This process's resource limits named in :data:`LIMITS`, ``{name: [soft, hard]}`` (-1: none)."""
    import resource

    return {n: list(resource.getrlimit(getattr(resource, n))) for n in LIMITS if hasattr(resource, n)}


def apply_limits(given: dict) -> None:
    """Take the command's limits ``given`` (:func:`limits`): each hard limit the lower of the command's
    and this process's (a hard limit cannot be raised), each soft limit the command's within it."""
    import resource

    def low(a, b):
        return b if a == resource.RLIM_INFINITY else a if b == resource.RLIM_INFINITY else min(a, b)

    for name, (soft, hard) in given.items():
        which = getattr(resource, name, None)
        if which is None:
            continue
        s0, h0 = resource.getrlimit(which)
        h = low(int(hard), h0)
        s = low(int(soft), h)  # the command's soft limit, within the hard one
        if (s, h) != (s0, h0):
            try:
                resource.setrlimit(which, (s, h))
            except (ValueError, OSError):
                pass


def available() -> bool:
    return (hasattr(os, "fork") and hasattr(socket, "AF_UNIX") and hasattr(socket, "send_fds")
            and os.environ.get(ENV_SWITCH, "").lower() not in ("off", "0", "no", "false"))


def connect(path: str | None = None, timeout: float | None = 2.0) -> socket.socket | None:
    """A connection to the server at ``path`` (default :func:`socket_path`), or ``None`` when none
    listens there (no file, nobody listening, not a socket, not ours)."""
    path = path or socket_path()
    try:
        st = os.stat(path)
        if st.st_uid != os.getuid():
            return None
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    except OSError:
        return None
    try:
        sock.settimeout(timeout)
        sock.connect(path)
        sock.settimeout(None)
        return sock
    except OSError:
        sock.close()
        return None


def delegate(argv: list[str], prog: str = "splice") -> int | None:
    """Run ``splice ARGV`` on a running server: its exit status, or ``None`` when no server took it
    (none running, another version of the code, switched off), so the caller runs it itself.

    The run writes to this process's standard output and error; SIGINT, SIGTERM and SIGHUP sent to
    this process are passed on to it (it cleans up and exits as the command would), Ctrl-Z stops it
    with this process and SIGCONT resumes both; a run killed by a signal kills this process by the
    same signal.
    """
    if not available():
        return None
    sock = connect()
    if sock is None:
        return None
    try:
        fds = []
        for fd in (0, 1, 2):
            try:
                os.fstat(fd)
                fds.append(fd)
            except OSError:
                fds.append(-1)
        if fds[1] < 0 or fds[2] < 0:
            return None  # no standard output or error to hand over: run here
        null = None
        if fds[0] < 0:
            null = os.open(os.devnull, os.O_RDONLY)
            fds[0] = null
        mask = os.umask(0)
        os.umask(mask)
        request = {"cmd": "splice", "fingerprint": fingerprint(), "argv": list(argv), "prog": prog,
                   "cwd": os.getcwd(), "env": dict(os.environ), "umask": mask, "limits": limits(),
                   "ignored": [int(getattr(signal, n)) for n in ("SIGHUP", "SIGINT", "SIGTERM", "SIGQUIT")
                               if signal.getsignal(getattr(signal, n)) == signal.SIG_IGN],
                   "encoding": [getattr(s, "encoding", None) or "utf-8" for s in (sys.stdout, sys.stderr)],
                   "errors": [getattr(s, "errors", None) or "strict" for s in (sys.stdout, sys.stderr)]}
        sys.stdout.flush()
        sys.stderr.flush()
        try:
            send_message(sock, request, fds)
        finally:
            if null is not None:
                os.close(null)
    except (OSError, ValueError):
        sock.close()
        return None  # the server went away before taking the run: run it here
    try:
        return _wait(sock)
    finally:
        sock.close()


def _wait(sock: socket.socket) -> int | None:
    pid = None
    pending: list[int] = []

    def forward(signum, frame):
        if pid is None:
            pending.append(signum)
        else:
            try:
                os.kill(pid, signum)
            except ProcessLookupError:
                pass

    def suspend(signum, frame):  # Ctrl-Z: the run stops with the command, and goes on with it
        if pid is not None:
            try:
                os.kill(pid, signal.SIGSTOP)
            except ProcessLookupError:
                pass
        signal.signal(signal.SIGTSTP, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGTSTP)  # stopped here until SIGCONT
        signal.signal(signal.SIGTSTP, suspend)
        # running again: resumed, or never stopped (the kernel drops SIGTSTP in a process group no
        # shell controls, an orphaned one); either way the run goes on with this process
        resume(signal.SIGCONT, None)

    def resume(signum, frame):
        if pid is not None:
            try:
                os.kill(pid, signal.SIGCONT)
            except ProcessLookupError:
                pass

    old = {}
    for name, handler in (("SIGINT", forward), ("SIGTERM", forward), ("SIGHUP", forward), ("SIGTSTP", suspend),
                          ("SIGCONT", resume)):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) in (signal.SIG_DFL, signal.default_int_handler):
            old[sig] = signal.signal(sig, handler)
    try:
        while True:
            try:
                msg, _ = recv_message(sock)
            except (OSError, ValueError):
                msg = None
            if msg is None:
                if pid is None:
                    return None  # closed before the run started: run it here
                print(f"splice: error: the splice server's run (pid {pid}) ended without an exit status",
                      file=sys.stderr)
                return 1
            if "refused" in msg:
                return None
            if "pid" in msg:
                pid = int(msg["pid"])
                for s in pending:
                    forward(s, None)
            elif "exit" in msg:
                return int(msg["exit"])
            elif "signal" in msg:
                signum = int(msg["signal"])
                for sig, handler in old.items():
                    signal.signal(sig, handler)
                old = {}
                try:
                    signal.signal(signum, signal.SIG_DFL)
                    os.kill(os.getpid(), signum)
                except (OSError, ValueError):
                    pass
                return 128 + signum
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def main() -> int:
    """The ``splice`` command's entry point: the run goes to a running ``splice-server`` of this very
    code (without importing the command's parser), else :func:`splicer.cli.main` runs it here."""
    code = delegate(sys.argv[1:])
    if code is not None:
        return code
    from .cli import main as run

    return run()
