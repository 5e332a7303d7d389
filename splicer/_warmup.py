"""A first run's kernels compiled two at a time: a helper process compiles them from the end.

The first ``splice`` in a new environment (or after an upgrade changed a kernel's source) compiles
every numba kernel it calls, one after the other: about 12 s of the sample's first run on a 2-core
machine, where the run itself takes 1 s.  Numba compiles in one thread per process, and a compiled
kernel is saved to numba's cache, which a process reads when it first calls that kernel.  So while
the command compiles its kernels in the order a splice calls them, :func:`start` starts this module
as a helper process that compiles the same kernels, for the same argument types, in the reverse
order: the two meet half-way, and the command loads the rest from the cache instead of compiling
them.  Only when some kernel's cache is cold (:func:`cold`); the command stops the helper when it
ends (:func:`stop`).

:func:`signatures` lists each kernel with the argument types the splice of the bundled sample calls
it with (``tests/test_warmup.py`` checks that, after the helper's work, the sample's splice
compiles nothing).  A kernel called with other types (D1 with the theta from root headings,
``--theta heading``, say) still compiles on first use, as before.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys

__all__ = ["signatures", "kernels", "compile_all", "cold", "start", "stop"]


def signatures() -> list:
    """``(module, kernel, argument types)`` of every kernel the helper compiles, in the order a splice
    first calls them (numba types, built here so that importing this module imports no numba)."""
    from numba import types as T

    F8, I8, F4, U1 = T.float64, T.int64, T.float32, T.uint8

    def a(dtype, ndim, readonly=False):
        return T.Array(dtype, ndim, "C", readonly=readonly)

    band = (a(I8, 1, True), a(I8, 1, True))  # a Band's lo and hi (frozen, read-only)
    return [
        ("splicer.align.costs", "_signs", (a(F8, 3), F8, F8, a(F8, 3))),
        ("splicer.align.costs", "_d1_rows_window",
         (I8, I8) + band + (a(F8, 3), a(F8, 3), a(F8, 3), a(F8, 2), a(F8, 2), a(F8, 3), a(F8, 3), F8, F8, F8, F8,
                            a(F8, 3), I8, a(F8, 2))),
        ("splicer.align.kernels", "_dp_rows",
         (a(F8, 2), T.boolean, I8, I8) + band + (a(I8, 1), a(F8, 2), a(U1, 1), a(F8, 1), a(F8, 1), a(F8, 1), F8, F8,
                                                 a(U1, 1), I8, F8)),
        ("splicer.align.kernels", "_backtrack", (a(I8, 1, True), a(I8, 1), a(U1, 1), I8, I8)),
        ("splicer.align.costs", "_position_rows", (I8, I8) + band + (a(F8, 2), a(F8, 2), F8, a(F8, 2))),
        ("splicer.align.posterior", "_forward",
         (a(F4, 1),) + band + (a(I8, 1), I8, I8, F8, F8, F8, a(U1, 1), a(F4, 1), a(F8, 1))),
        ("splicer.align.posterior", "_backward",
         (a(F4, 1),) + band + (a(I8, 1), I8, I8, I8, I8, F8, F8, F8, a(U1, 1), a(F4, 1), a(F8, 1), a(F8, 1),
                               a(F8, 1), a(F8, 1), a(F8, 1))),
        ("splicer.align.costs", "_d2_rows", (I8, I8) + band + (I8, a(F8, 2), a(F8, 2), a(F8, 2), a(F8, 2), a(F8, 2))),
        ("splicer.transfer.trend", "_rts", (a(F8, 1), a(F8, 1), a(F8, 1), F8, F8, F8)),
        ("splicer.align.wrist", "_offset_costs", (a(F8, 2), a(F8, 2), a(F8, 1), a(F8, 1), a(F8, 1), a(F8, 2))),
        ("splicer.align.wrist", "_expected_offsets", (a(F8, 2), a(F8, 1), F8, I8, F8)),
    ]


def kernels() -> list:
    """``(dispatcher, argument types)`` of every kernel of :func:`signatures`, in its order."""
    return [(getattr(importlib.import_module(m), name), sig) for m, name, sig in signatures()]


def compile_all(reverse: bool = False) -> None:
    """Compile (or load from numba's cache) every kernel of :func:`signatures` for its argument
    types; ``reverse``: from the last."""
    ks = kernels()
    for disp, sig in (reversed(ks) if reverse else ks):
        disp.compile(sig)


def _is_cold(disp) -> bool:
    """Whether numba's cache holds no valid entry of the kernel ``disp`` (its index missing, or stale:
    its source changed).  Reads numba's cache index (internal API): anything unexpected counts as
    warm (no helper: the run as before)."""
    try:
        return not disp._cache._cache_file._load_index()
    except Exception:  # noqa: BLE001 - another numba version
        return False


def cold() -> bool:
    """Whether any kernel of :func:`signatures` has no valid entry in numba's cache (a few ms: one
    small index file read per kernel)."""
    try:
        ks = kernels()
    except Exception:  # noqa: BLE001
        return False
    return any(_is_cold(disp) for disp, _ in ks)


def start():
    """The helper process (:func:`compile_all` from the end) when :func:`cold`, else None.  Its
    output is discarded; it never writes anything but numba's own cache files."""
    if os.environ.get("SPLICER_NO_WARMUP") or os.environ.get("NUMBA_DISABLE_JIT") == "1" or not cold():
        return None
    # this splicer, not one that the folder the command runs in may hold (``-m`` would look there first)
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    code = f"import sys; sys.path.insert(0, {here!r}); from splicer._warmup import compile_all; compile_all(reverse=True)"
    try:
        return subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, close_fds=True)
    except OSError:
        return None


def stop(proc) -> None:
    """End the helper (the command's own kernels are compiled by now); None: nothing to do."""
    if proc is None:
        return
    try:
        if proc.poll() is None:
            proc.terminate()
        proc.wait(timeout=5)
    except Exception:  # noqa: BLE001 - it may already be gone
        try:
            proc.kill()
        except Exception:  # noqa: BLE001
            pass

