"""Atomic output files: written to a temporary beside the destination, renamed when complete.

One writer for every output of splicer (BVH, report JSON, plot PNG).  :func:`write_atomic`
writes one file; inside ``with Transaction() as tx: ...; tx.commit()`` every
:func:`write_atomic` call is staged instead, and :meth:`Transaction.commit` renames them all
at the end, so that several outputs appear together or not at all:

- a failure while writing (full disk, an exception in the writer) or leaving the ``with``
  block without :meth:`~Transaction.commit` (an error, Ctrl-C, SIGTERM turned into an
  exception) removes every temporary and leaves every destination untouched;
- :meth:`~Transaction.commit` blocks SIGINT, SIGTERM and SIGHUP while it renames (the
  renames are quick), and if one rename fails, the destinations already replaced are rolled
  back (restored from a hard link, or removed when they did not exist before).

Temporaries are named ``.<name>.splice-<pid>-<random>.tmp`` in the destination's folder.
A process killed with SIGKILL cannot remove its own; the next write to the same destination
removes those whose process no longer exists.

A new file gets mode 0o666 minus the umask (applied by the kernel through ``os.open``; the
process umask is never changed); a replaced file keeps its mode.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import re
import secrets
import signal
import stat
import threading
from pathlib import Path
from typing import Callable

from ..errors import SplicerError

__all__ = ["Transaction", "write_atomic"]

_current: contextvars.ContextVar[Transaction | None] = contextvars.ContextVar("splicer_transaction", default=None)
_BLOCKED = {s for s in (getattr(signal, n, None) for n in ("SIGINT", "SIGTERM", "SIGHUP")) if s is not None}
_NAME_MAX = 255
_STEM_CHARS = 40  # the destination's name kept in its temporary's name


def _default_error(dest: Path):
    return lambda message: SplicerError(f"{dest}: {message}")


def _tmp_pattern(dest: Path) -> re.Pattern:
    return re.compile(r"\." + re.escape(dest.name[:_STEM_CHARS]) + r"\.splice-(\d+)-[0-9a-f]+\.(?:tmp|bak)")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


def _remove_stale(dest: Path) -> None:
    """Remove temporaries of ``dest`` left by processes that no longer exist (SIGKILL)."""
    pat = _tmp_pattern(dest)
    try:
        names = os.listdir(dest.parent)
    except OSError:
        return
    me = os.getpid()
    for name in names:
        m = pat.fullmatch(name)
        if m is None or int(m.group(1)) == me or _pid_alive(int(m.group(1))):
            continue
        p = dest.parent / name
        try:
            if p.lstat().st_uid == os.getuid() and stat.S_ISREG(p.lstat().st_mode):
                p.unlink()
        except OSError:
            pass


@contextlib.contextmanager
def _signals_held():
    """SIGINT, SIGTERM and SIGHUP arriving in the block take effect when it ends.

    In the main thread their handlers are swapped for one that only records the signal (the
    old handler is called, or the default action taken, after the block); the signals are
    also blocked in this thread (``pthread_sigmask``).
    """
    pending: list[int] = []
    swapped: dict = {}
    if threading.current_thread() is threading.main_thread():
        for sig in _BLOCKED:
            try:
                if signal.getsignal(sig) not in (signal.SIG_IGN, None):
                    swapped[sig] = signal.signal(sig, lambda signum, frame: pending.append(signum))
            except (ValueError, OSError):
                pass
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, _BLOCKED) if hasattr(signal, "pthread_sigmask") else None
    try:
        yield
    finally:
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for sig in swapped:  # function calls: the interpreter runs handlers of signals just unblocked
            signal.getsignal(sig)
        for sig, handler in swapped.items():
            signal.signal(sig, handler)
        if pending:
            handler = swapped.get(pending[0])
            if callable(handler):
                handler(pending[0], None)  # e.g. raises KeyboardInterrupt
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), pending[0])


def _unlink_quietly(path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


class Transaction:
    """Outputs written together: all of them appear, or none (see the module docstring).

    Examples
    --------
    >>> with Transaction() as tx:                          # doctest: +SKIP
    ...     write_bvh(motion, "out.bvh")                    # staged, not yet visible
    ...     write_atomic("r.json", lambda f: f.write(b"{}"), what="report")
    ...     tx.commit()                                     # both appear now
    """

    def __init__(self) -> None:
        self._staged: list[tuple[str, Path, Callable]] = []  # (temporary, destination, error)
        self.committed: list[Path] = []
        self._token = None

    def __enter__(self) -> Transaction:
        self._token = _current.set(self)
        return self

    def __exit__(self, *exc) -> None:
        _current.reset(self._token)
        self.discard()

    @property
    def staged(self) -> list[Path]:
        """Destinations written to temporaries and waiting for :meth:`commit`."""
        return [d for _, d, _ in self._staged]

    def stage(self, dest, write: Callable, *, what: str = "file", error: Callable | None = None) -> None:
        """Write ``dest``'s content to a temporary now; it replaces ``dest`` at :meth:`commit`.

        Parameters
        ----------
        dest : path of the output.
        write : callable
            ``write(f)`` writes the content to the binary file object ``f``.
        what : str
            The kind of output, for messages ("BVH file", "report", "plot").
        error : callable, optional
            ``error(message) -> Exception`` for a file that cannot be written; by default a
            :class:`~splicer.errors.SplicerError` naming ``dest``.
        """
        dest = Path(dest)
        err = error or _default_error(dest)
        if any(os.path.abspath(d) == os.path.abspath(dest) for d in self.staged):
            raise err("the same file is given for two outputs; give each output its own name")
        if len(os.fsencode(dest.name)) > _NAME_MAX:
            raise err(f"cannot write the {what}: the file name is {len(dest.name)} characters long, "
                      f"more than a file system allows ({_NAME_MAX} bytes)")
        try:
            st = os.stat(dest)
        except OSError:
            st = None
        if st is not None and not stat.S_ISREG(st.st_mode):  # never replace /dev/null, a FIFO...
            raise err(f"cannot write the {what}: the path exists and is not a regular file")
        directory = dest.parent
        _remove_stale(dest)
        tmp = str(directory / f".{dest.name[:_STEM_CHARS]}.splice-{os.getpid()}-{secrets.token_hex(4)}.tmp")
        mode = None if st is None else stat.S_IMODE(st.st_mode)
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0),
                         0o666 if mode is None else 0o600)
        except OSError as e:
            raise err(f"cannot write the {what}: {e.strerror or e}") from None
        self._staged.append((tmp, dest, err))
        try:
            if mode is not None:
                os.fchmod(fd, mode)
            with os.fdopen(fd, "wb") as f:
                fd = None
                write(f)
                f.flush()
                os.fsync(f.fileno())
        except OSError as e:
            self._drop(tmp)
            raise err(f"cannot write the {what}: {e.strerror or e}") from None
        except BaseException:
            self._drop(tmp)
            raise
        finally:
            if fd is not None:
                os.close(fd)

    def _drop(self, tmp: str) -> None:
        _unlink_quietly(tmp)
        self._staged = [s for s in self._staged if s[0] != tmp]

    def commit(self) -> list[Path]:
        """Rename every staged temporary onto its destination; all or nothing.

        SIGINT, SIGTERM and SIGHUP are held back until the renames are over (and then
        delivered).  Returns the destinations written.
        """
        with _signals_held():
            return self._commit()

    def _commit(self) -> list[Path]:
        backups: dict[Path, str | None] = {}
        existed: dict[Path, bool] = {}
        done: list[Path] = []
        try:
            for tmp, dest, err in self._staged:
                existed[dest] = os.path.lexists(dest)
                backups[dest] = self._backup(dest) if existed[dest] else None
            for tmp, dest, err in self._staged:
                try:
                    os.replace(tmp, dest)
                except OSError as e:
                    lost = self._rollback(done, backups, existed)
                    truth = ("nothing was written" if not lost else
                             ", ".join(str(p) for p in lost) + " already replaced (no copy to restore), "
                             "the other outputs not written")
                    raise err(f"cannot write the output: {e.strerror or e}; {truth}") from None
                done.append(dest)
        finally:
            for b in backups.values():
                if b is not None:
                    _unlink_quietly(b)
        self.committed = done
        self._staged = []
        return list(done)

    @staticmethod
    def _backup(dest: Path) -> str | None:
        """A hard link to the existing ``dest`` (for a rollback), or None where links fail."""
        b = str(dest.parent / f".{dest.name[:_STEM_CHARS]}.splice-{os.getpid()}-{secrets.token_hex(4)}.bak")
        try:
            os.link(dest, b, follow_symlinks=False)
        except OSError:
            return None
        return b

    @staticmethod
    def _rollback(done: list[Path], backups: dict, existed: dict) -> list[Path]:
        """Undo the renames in ``done``; returns the destinations that could not be restored."""
        lost = []
        for dest in done:
            b = backups.get(dest)
            try:
                if b is not None:
                    os.replace(b, dest)
                    backups[dest] = None
                elif not existed[dest]:
                    os.unlink(dest)
                else:  # replaced and no copy of the old content: say so
                    lost.append(dest)
            except OSError:
                lost.append(dest)
        return lost

    def discard(self) -> None:
        """Remove every staged temporary (destinations untouched); signals wait until done."""
        if not self._staged:
            return
        with _signals_held():
            for tmp, _, _ in self._staged:
                _unlink_quietly(tmp)
            self._staged = []


def write_atomic(dest, write: Callable, *, what: str = "file", error: Callable | None = None) -> None:
    """Write ``dest`` atomically with ``write(f)`` (``f`` a binary file object).

    Inside an open :class:`Transaction` the file is only staged (it appears at the
    transaction's :meth:`~Transaction.commit`); otherwise it replaces ``dest`` at once.
    Parameters as for :meth:`Transaction.stage`.
    """
    tx = _current.get()
    if tx is not None:
        tx.stage(dest, write, what=what, error=error)
        return
    with Transaction() as tx:
        tx.stage(dest, write, what=what, error=error)
        tx.commit()


def write_text_atomic(dest, text: str, *, what: str = "file", error: Callable | None = None) -> None:
    """:func:`write_atomic` of UTF-8 text (reports, summaries, tables)."""
    data = text.encode("utf-8")
    write_atomic(dest, lambda f: f.write(data), what=what, error=error)
