"""A first run's helper process (``splicer._warmup``, issue 12): its kernels and argument types are the
ones the sample's splice calls, it starts only with a cold cache, and the command stops it.

Each check runs in a child process with its own, new numba cache (``NUMBA_CACHE_DIR``: numba reads it
when it is imported), so nothing here depends on or changes the cache the other tests use."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MOTIONS = ROOT / "motions"


def _child(code: str, cache: Path, **env) -> dict:
    """Run ``code`` in a new interpreter with numba's cache in ``cache``; its last stdout line, as JSON."""
    full = dict(os.environ)
    full.pop("SPLICER_NO_WARMUP", None)
    full.update(NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
                **env)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=full, cwd=cache.parent,
                       timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


# records every top-level numba compilation (a kernel compiled, not loaded from the cache)
_LISTEN = """
import json, sys
from numba.core import event as ev
compiled, depth = [], [0]
class L(ev.Listener):
    def on_start(self, e):
        if depth[0] == 0:
            compiled.append(e.data["dispatcher"].py_func.__qualname__)
        depth[0] += 1
    def on_end(self, e):
        depth[0] -= 1
ev.register("numba:compile", L())
"""


@pytest.mark.slow
def test_the_helpers_kernels_are_the_ones_the_sample_compiles(tmp_path):
    # A new cache: every kernel is cold; the helper's list compiled, none is; the sample's splice then
    # compiles nothing (each kernel and argument type it calls was in the list).  A kernel added to the
    # pipeline, or called with other types, fails this until signatures() names it.
    code = _LISTEN + f"""
from splicer import _warmup
before = _warmup.cold()
_warmup.compile_all()
after = _warmup.cold()
helper = _warmup.start()
listed = len(compiled)
from splicer import splice
splice({str(MOTIONS / 'sample_body.bvh')!r}, {str(MOTIONS / 'sample_hands.bvh')!r},
       config={str(MOTIONS / 'sample_sync.yaml')!r})
print(json.dumps({{"before": before, "after": after, "helper": helper is not None, "listed": listed,
                  "more": compiled[listed:]}}))
"""
    out = _child(code, tmp_path / "cache")
    assert out["before"] is True and out["after"] is False
    assert out["helper"] is False  # a warm cache starts no helper
    assert out["listed"] == len(__import__("splicer._warmup", fromlist=["x"]).signatures())
    assert out["more"] == [], out["more"]


def _processes_with(marker: str) -> list[int]:
    """Pids of the processes whose environment holds ``marker`` (Linux: /proc)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if marker.encode() in (d / "environ").read_bytes():
                    pids.append(int(d.name))
            except OSError:
                pass
    return pids


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="reads other processes' environments in /proc")
def test_a_first_run_of_the_command_leaves_the_cache_warm_and_no_helper_behind(tmp_path):
    cache = tmp_path / "cache"
    marker = f"SPLICER_TEST_MARK={tmp_path.name}"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), SPLICER_TEST_MARK=tmp_path.name,
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("SPLICER_NO_WARMUP", None)
    env["SPLICER_SERVER"] = "off"
    argv = [sys.executable, "-m", "splicer.cli", str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"),
            "-q", "-o"]
    # bad input: the command fails reading the hands file, after starting the helper (with numba, before
    # reading), and stops it: nothing keeps compiling behind the error
    bad = subprocess.run(argv[:4] + [str(tmp_path / "missing.bvh")] + argv[5:] + [str(tmp_path / "bad.bvh")],
                         env=env, capture_output=True, text=True, timeout=600)
    assert bad.returncode == 1 and "missing.bvh" in bad.stderr and not (tmp_path / "bad.bvh").exists()
    assert _processes_with(marker) == []
    first = subprocess.run(argv + [str(tmp_path / "first.bvh")], env=env, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    assert _processes_with(marker) == []  # the helper was stopped (or had ended) with the command
    out = _child("import json; from splicer import _warmup; print(json.dumps({'cold': _warmup.cold()}))", cache)
    assert out == {"cold": False}
    again = subprocess.run(argv + [str(tmp_path / "again.bvh")], env=env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    assert (tmp_path / "first.bvh").read_bytes() == (tmp_path / "again.bvh").read_bytes()


def test_start_only_when_cold_and_stop_ends_it(tmp_path):
    code = """
import json, os
from splicer import _warmup
p = _warmup.start()
started = p is not None
running = started and p.poll() is None
_warmup.stop(p)
print(json.dumps({"started": started, "running": running, "ended": (p.returncode is not None) if started else None}))
"""
    out = _child(code, tmp_path / "cache")
    assert out == {"started": True, "running": True, "ended": True}
    out = _child(code, tmp_path / "cache2", SPLICER_NO_WARMUP="1")
    assert out["started"] is False


def test_the_helper_imports_this_splicer_not_one_in_the_commands_folder(tmp_path):
    # a user may run `splice` in a folder holding another splicer (a checkout): the helper must compile this
    # one's kernels; the stand-in here exits with status 3 as soon as it is imported
    fake = tmp_path / "elsewhere" / "splicer"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise SystemExit(3)\n")
    code = f"""
import json, os, time
from splicer import _warmup
os.chdir({str(fake.parent)!r})
p = _warmup.start()
try:
    p.wait(timeout=3)
except Exception:
    pass
code = p.poll()
_warmup.stop(p)
print(json.dumps({{"exited": code}}))
"""
    out = _child(code, tmp_path / "cache")
    assert out == {"exited": None}  # still compiling this splicer's kernels after 3 s


def test_one_cold_kernel_is_enough_to_start_it(tmp_path):
    # the last kernel compiled (the helper's first), the others still cold: cold() says so
    code = """
import json
from splicer import _warmup
disp, sig = _warmup.kernels()[-1]
before = _warmup._is_cold(disp)
disp.compile(sig)
print(json.dumps({"before": before, "after": _warmup._is_cold(disp), "any": _warmup.cold()}))
"""
    out = _child(code, tmp_path / "cache")
    assert out == {"before": True, "after": False, "any": True}


def test_stop_of_nothing_or_of_an_ended_process():
    from splicer import _warmup

    _warmup.stop(None)
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    _warmup.stop(p)  # already ended: no error
    assert p.returncode == 0
