"""Seeded mutational fuzzing of the ``splice`` command (issue 10), shared by tests/test_fuzz.py
and benchmarks/fuzz_nightly.py.

A case is a set of small input files (BVH takes of a few dozen frames, a constraints file)
and an argument list; one to three seeded mutations are applied to a file or to the options.
Cases run in-process through :func:`splicer.cli.main` -- inside a worker process with a
memory cap (``RLIMIT_AS``) and a per-case time limit (``SIGALRM``); a worker that dies or stops
answering is replaced and its case classified.  Classes:

==================  ===================================================================
``ok``              exit 0 and a valid output (reads back with the body's frame count)
``refused``         exit 1 or 2, exactly one line ``splice: error: ...`` of <= 500
                    characters, and nothing written (no output, no temporary)
``traceback``       an exception escaped ``main``                           (failure)
``hang``            the case ran past the time limit                        (failure)
``memory``          MemoryError / "out of memory" under the memory cap      (failure)
``bad-message``     exit 1/2 with no line, several lines or a long line     (failure)
``left-output``     exit 1/2 but an output or a temporary exists            (failure)
``bad-output``      exit 0 but the output is missing or unreadable          (failure)
``crash``           the worker process died                                 (failure)
``known-geometry``  ``LinAlgError: SVD did not converge`` on coincident joints: the
                    issue's first row, fixed in rotations/markers by the hand-geometry
                    work; counted apart until that is merged (see KNOWN_GEOMETRY_ALLOWED)
==================  ===================================================================
"""

from __future__ import annotations

import contextlib
import io
import multiprocessing as mp
import os
import random
import resource
import shutil
import signal
import tempfile
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from fault_helpers import SAMPLE_BODY, SAMPLE_HANDS, SMALL_SYNC, TEMP_NAME, truncate_bvh

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "motions"
OK_CLASSES = ("ok", "refused")
#: The SVD failure on coincident joints is issue 10's first row, fixed with the hand-geometry
#: work (splicer/rotations.py, markers.py); set to False once that is merged.
KNOWN_GEOMETRY_ALLOWED = False
TIME_LIMIT_S = 20  # per case (SIGALRM in the worker); the parent waits 3x that before killing
MEMORY_HEADROOM = 2 << 30  # RLIMIT_AS = the worker's address space at start + 2 GiB


@dataclass
class Case:
    """Input files (name -> bytes), the argument list (``{name}`` = path of that file) and
    what was mutated."""

    files: dict
    argv: list
    body_frames: int
    mutations: list = field(default_factory=list)


# ---------------------------------------------------------------------------------------
# base inputs
# ---------------------------------------------------------------------------------------
def _truncate_to(text: str, seconds: float, max_frames: int) -> str:
    ft = float(next(line for line in text.split("\n") if line.startswith("Frame Time:")).split(":")[1])
    return truncate_bvh(text, max(3, min(max_frames, int(round(seconds / ft)))))


def base_pairs(shared: bool = True) -> list[tuple[str, str, str]]:
    """(label, body text, hands text): the small sample takes and, when ``../shared/motions``
    exists, small cuts (about 1.3 s) of the real takes."""
    pairs = [("sample", truncate_bvh(SAMPLE_BODY.read_text(), 40), truncate_bvh(SAMPLE_HANDS.read_text(), 80))]
    if not (shared and SHARED.is_dir()):
        return pairs
    bodies = [p for p in (SHARED / "zeggs" / "067_Speech_2_x_1_0.bvh", SHARED / "movin" / "test1.bvh",
                          SHARED / "cmu" / "01_01.bvh") if p.exists()]
    hands = [p for p in (SHARED / "leap-hands" / "hello-world.bvh", SHARED / "manipnet-hands" / "teapot3_rightHand.bvh")
             if p.exists()]
    sample_hands = truncate_bvh(SAMPLE_HANDS.read_text(), 80)
    for b in bodies:
        bt = _truncate_to(b.read_text(encoding="latin-1"), 1.3, 60)
        pairs.append((f"{b.stem}+sample", bt, sample_hands))
        for h in hands:
            pairs.append((f"{b.stem}+{h.stem}", bt, _truncate_to(h.read_text(encoding="latin-1"), 1.3, 60)))
    return pairs


# ---------------------------------------------------------------------------------------
# mutations
# ---------------------------------------------------------------------------------------
NUMBERS = ["0", "-0", "1", "-1", "2", "1e30", "-1e30", "1e7", "1e-9", "5e-324", "1e308", "1e400", "nan", "inf",
           "-inf", "NaN", "³", "١", "1_0", "0x10", "", "99999999999999999999", "9" * 5000, "0.0000001", "100",
           "1.5", "abc", "1e", "--1", "+3", ".5", "5.", "\u200b", "1,5"]
NAMES = ["Sp\u200bine", "X" * 300, "L" * 255, "Hips", "LeftHand", "RightHand", "a b", "é", "日本", "", "{", "}",
         "End Site", "JOINT", "\t", "LeftHandIndex1"]
CHANNEL_LINES = ["CHANNELS 4 Zrotation Xrotation Yrotation", "CHANNELS 3 Zrotation Zrotation Yrotation",
                 "CHANNELS 3 zrotation xrotation yrotation", "CHANNELS 0", "CHANNELS 7 " + "Xrotation " * 7,
                 "CHANNELS 2 Xposition Yrotation", "CHANNELS ³ Zrotation Xrotation Yrotation", "CHANNELS",
                 "CHANNELS 3 Wrotation Xrotation Yrotation", "CHANNELS 99999999999999999999 Xrotation",
                 "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
YAML_VALUES = ["!foo 1", "!!float x", "!!bool maybe", "!!timestamp 2001-13-45", "2001-13-45", "&a [*a]", "*nope",
               "1e308s", "-5", "1.5", "x", "null", "[]", "{}", "true", ".inf", ".nan", "0x10", "1_000",
               "99999999999999999999999", "'" + "v" * 10_000 + "'", "[" * 100 + "]" * 100, "2s", "0.5s", "-1s",
               "1e-300s", "{body: 1, hands: 2}", "[1, 2]", "left", "both", "z", "\"\\u200b\"", "|\n  block",
               "? [a]\n: b", "!!python/object:os.system [echo]", "&x [a, a, a, a, a, a, a, a, a, a]"]
BAND_VALUES = ["30%", "0", "-1", "1e308s", "200%", "nan", "abc", "5", "0.5s", "100000", "1", "0%", "inf", "3s",
               "1e-300", "2", "10%", "９", "", "1" * 5000 + "x"]
OPTIONS = {"--side": ["left", "right", "both", "up"], "--hands-side": ["left", "right", "middle"],
           "--theta": ["window", "heading"], "--passes": ["auto", "both", "pass1", "pass2"], "--merge": ["timemap", "median"],
           "--wrist": ["body", "hands"], "--band": BAND_VALUES, "--band2": BAND_VALUES}


def _lines_where(lines, pred):
    return [k for k, line in enumerate(lines) if pred(line)]


def _header_end(lines) -> int:
    ks = _lines_where(lines, lambda s: s.startswith("Frame Time"))
    return ks[0] + 1 if ks else len(lines)


def mutate_bvh(text: str, rng: random.Random) -> tuple[str, str]:
    """One mutation of a BVH text: (new text, description)."""
    lines = text.split("\n")
    h = _header_end(lines)
    kind = rng.choice(["token", "token", "token", "data", "data", "delete", "duplicate", "swap", "truncate", "byte",
                       "frames", "frame_time", "channels", "name", "offset0", "brace", "crlf", "extra_row",
                       "drop_column"])
    if kind in ("token", "data"):
        pool = range(h) if kind == "token" else range(h, len(lines))
        pool = [k for k in pool if lines[k].split()]
        if not pool:
            return text, "noop"
        k = rng.choice(pool)
        toks = lines[k].split()
        i = rng.randrange(len(toks))
        new = rng.choice(NUMBERS)
        toks[i] = new
        lines[k] = " ".join(toks)
        return "\n".join(lines), f"{kind} line {k + 1} token {i}={new[:12]!r}"
    if kind == "delete":
        k = rng.randrange(len(lines))
        del lines[k]
        return "\n".join(lines), f"delete line {k + 1}"
    if kind == "duplicate":
        k = rng.randrange(len(lines))
        lines.insert(k, lines[k])
        return "\n".join(lines), f"duplicate line {k + 1}"
    if kind == "swap":
        k = rng.randrange(max(1, len(lines) - 1))
        lines[k:k + 2] = lines[k:k + 2][::-1]
        return "\n".join(lines), f"swap lines {k + 1}, {k + 2}"
    if kind == "truncate":
        k = rng.randrange(len(text) + 1)
        return text[:k], f"truncate at {k}"
    if kind == "byte":
        data = bytearray(text.encode("utf-8", "surrogateescape"))
        if not data:
            return text, "noop"
        k = rng.randrange(len(data))
        data[k] = rng.choice([0, 0xFF, 0x0D, 0x0A, 0x09, 0x20, 0x7B, 0x7D, 0xC3, rng.randrange(256)])
        return data.decode("utf-8", "replace"), f"byte {k}"
    if kind == "frames":
        new = rng.choice(["0", "1", "2", "3", "39", "41", "1000000", "1000001", "-1", "³", "1e3", "", "2.5",
                          "9" * 30, "0x10"])
        return "\n".join(f"Frames: {new}" if s.startswith("Frames:") else s for s in lines), f"Frames: {new}"
    if kind == "frame_time":
        new = rng.choice(["0", "-1", "1e-9", "5e-324", "1e-300", "0.0000001", "0.0001", "10", "10.5", "100",
                          "nan", "inf", "0.0333x", "", "1/30", "0.00833", "1"])
        return "\n".join(f"Frame Time: {new}" if s.startswith("Frame Time") else s for s in lines), f"Frame Time: {new}"
    if kind == "channels":
        pool = _lines_where(lines, lambda s: s.strip().startswith("CHANNELS"))
        if not pool:
            return text, "noop"
        k = rng.choice(pool)
        new = rng.choice(CHANNEL_LINES)
        lines[k] = new
        return "\n".join(lines), f"line {k + 1}: {new[:30]}"
    if kind == "name":
        pool = _lines_where(lines, lambda s: s.strip().startswith(("JOINT", "ROOT")))
        if not pool:
            return text, "noop"
        k = rng.choice(pool)
        new = rng.choice(NAMES)
        lines[k] = lines[k].split()[0] + " " + new
        return "\n".join(lines), f"name line {k + 1}={new[:12]!r}"
    if kind == "offset0":
        pool = _lines_where(lines, lambda s: s.strip().startswith("OFFSET"))
        if not pool:
            return text, "noop"
        k = rng.choice(pool)
        lines[k] = "OFFSET 0 0 0"
        return "\n".join(lines), f"offset0 line {k + 1}"
    if kind == "brace":
        pool = _lines_where(lines[:h], lambda s: s.strip() in ("{", "}"))
        if not pool:
            return text, "noop"
        k = rng.choice(pool)
        if rng.random() < 0.5:
            del lines[k]
        else:
            lines.insert(k, lines[k])
        return "\n".join(lines), f"brace line {k + 1}"
    if kind == "crlf":
        return text.replace("\n", rng.choice(["\r\n", "\r", "\n\n", " \n\t"])), "line endings"
    if kind == "extra_row":
        return text + rng.choice([lines[h] if h < len(lines) else "0", "0 0 0", "x"]) + "\n", "extra row"
    rows = [k for k in range(h, len(lines)) if lines[k].split()]
    if not rows:
        return text, "noop"
    k = rng.choice(rows)
    lines[k] = " ".join(lines[k].split()[:-1])
    return "\n".join(lines), f"drop column line {k + 1}"


def mutate_yaml(text: str, rng: random.Random) -> tuple[str, str]:
    lines = text.split("\n")
    kind = rng.choice(["value", "value", "value", "delete", "duplicate", "truncate", "byte", "key", "append"])
    if kind == "value":
        pool = [k for k, s in enumerate(lines) if ":" in s and not s.lstrip().startswith("#")]
        if not pool:
            return text + "tolerance: 1\n", "noop"
        k = rng.choice(pool)
        s = lines[k]
        new = rng.choice(YAML_VALUES)
        if "{" in s:  # flow pair: replace one of its values
            parts = s.split(",")
            i = rng.randrange(len(parts))
            key = parts[i].split(":")[0]
            parts[i] = f"{key}: {new}" + ("}" if parts[i].rstrip().endswith("}") else "")
            lines[k] = ",".join(parts)
        else:
            lines[k] = s.split(":")[0] + ": " + new
        return "\n".join(lines), f"value line {k + 1}={new[:16]!r}"
    if kind == "delete":
        k = rng.randrange(len(lines))
        del lines[k]
        return "\n".join(lines), f"delete line {k + 1}"
    if kind == "duplicate":
        k = rng.randrange(len(lines))
        lines.insert(k, lines[k])
        return "\n".join(lines), f"duplicate line {k + 1}"
    if kind == "truncate":
        k = rng.randrange(len(text) + 1)
        return text[:k], f"truncate at {k}"
    if kind == "byte":
        data = bytearray(text.encode())
        if not data:
            return text, "noop"
        k = rng.randrange(len(data))
        data[k] = rng.choice([0, 0xFF, 0x09, 0x3A, 0x26, 0x2A, 0x21, 0x5B, rng.randrange(256)])
        return bytes(data).decode("latin-1"), f"byte {k}"
    if kind == "key":
        new = rng.choice(["joints", "up", "hands_side", "side", "unknown", "pairs", "tolerance"])
        return text + f"\n{new}: {rng.choice(YAML_VALUES)}\n", f"key {new}"
    extra = rng.choice(["joints: {body: {left: {wrist: LeftHand, elbow: LeftForeArm}}}",
                        "joints: {hands: {right: {wrist: RightHand, fingers: {index: [RightHandIndex1]}}}}",
                        "joints: {body: {left: {wrist: [x]}}}", "up: {body: y, hands: q}", "up: z",
                        "hands_side: left", "side: right", "pairs: [{body: 0, hands: 0}, {body: 39, hands: 79}]"])
    return text + "\n" + extra + "\n", f"append {extra[:20]}"


def mutate_argv(argv: list, rng: random.Random) -> tuple[list, str]:
    argv = list(argv)
    kind = rng.choice(["option", "option", "option", "collide", "missing_dir", "long_name", "input_missing"])
    if kind == "option":
        opt = rng.choice(sorted(OPTIONS))
        val = rng.choice(OPTIONS[opt])
        return argv + [opt, val], f"{opt} {val!r}"
    if kind == "collide":
        which = rng.choice([["--report", "{out}"], ["--plot", "{out}"], ["-o", "{body}"], ["-o", "{hands}"],
                            ["--report", "{body}"], ["--report", "{r}", "--plot", "{r}"]])
        return argv + which, "collide " + " ".join(which)
    if kind == "missing_dir":
        return argv + ["--report", "{dir}/nope/r.json"], "missing dir"
    if kind == "long_name":
        return argv + ["-o", "{dir}/" + "o" * rng.choice([250, 256, 300]) + ".bvh"], "long name"
    return [a if a != "{hands}" else "{dir}/absent.bvh" for a in argv], "input missing"


def make_cases(seed: int, n: int, pairs=None) -> list[Case]:
    """``n`` seeded cases; a third of the bases are real files when they are available."""
    rng = random.Random(seed)
    pairs = pairs if pairs is not None else base_pairs()
    cases = []
    for _ in range(n):
        label, body, hands = rng.choice(pairs) if rng.random() < 0.6 or len(pairs) == 1 else pairs[0]
        files = {"body": body, "hands": hands}
        argv = ["{body}", "{hands}", "-o", "{out}", "-q"]
        if "rightHand" in label:  # ManipNet's joint names do not tell the side; its file name does
            argv += ["--hands-side", "right"]
        if rng.random() < 0.5:  # lighter runs: one side, pass 1 only
            argv += ["--side", rng.choice(["left", "right"])]
        if rng.random() < 0.3:
            argv += ["--passes", "pass1"]
        if label == "sample" and rng.random() < 0.4:
            files["sync"] = SMALL_SYNC
            argv += ["--constraints", "{sync}"]
        if rng.random() < 0.15:
            argv += ["--report", "{r}"]
        muts = [label]
        for _ in range(rng.choice([1, 1, 1, 2, 3])):
            target = rng.choices(["body", "hands", "sync", "argv"], weights=[35, 35, 15, 15])[0]
            if target == "sync":
                if "sync" not in files:
                    files["sync"] = SMALL_SYNC
                    argv += ["--constraints", "{sync}"]
                files["sync"], what = mutate_yaml(files["sync"], rng)
            elif target == "argv":
                argv, what = mutate_argv(argv, rng)
            else:
                files[target], what = mutate_bvh(files[target], rng)
            muts.append(f"{target}: {what}")
        frames = int(next(s for s in body.split("\n") if s.startswith("Frames:")).split()[1])
        cases.append(Case({k: v.encode("utf-8", "surrogateescape") for k, v in files.items()}, argv, frames, muts))
    return cases


# ---------------------------------------------------------------------------------------
# running and classifying
# ---------------------------------------------------------------------------------------
class _Timeout(BaseException):
    pass


def _on_alarm(signum, frame):
    raise _Timeout


def _scratch_root() -> str:
    shm = Path("/dev/shm")
    return str(shm) if shm.is_dir() and os.access(shm, os.W_OK) else tempfile.gettempdir()


def run_case(case: Case, root: str) -> tuple[str, str]:
    """Run one case in this process; returns (class, detail)."""
    from splicer.io.bvh import read_bvh
    from splicer.cli import main

    d = tempfile.mkdtemp(prefix="fuzz-", dir=root)
    try:
        paths = {"dir": d, "out": f"{d}/out.bvh", "r": f"{d}/r.json"}
        for name, data in case.files.items():
            paths[name] = f"{d}/{name}.{'yaml' if name == 'sync' else 'bvh'}"
            with open(paths[name], "wb") as f:
                f.write(data)
        argv = [a.format(**paths) for a in case.argv]
        inputs = {paths[k] for k in case.files}
        before = set(os.listdir(d))
        out, err = io.StringIO(), io.StringIO()
        old_alarm = signal.signal(signal.SIGALRM, _on_alarm)
        signal.alarm(TIME_LIMIT_S)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
                warnings.simplefilter("always")  # a warning is printed, as in a real run
                try:
                    code = main(argv)
                except SystemExit as e:
                    code = e.code if isinstance(e.code, int) else 2
        except _Timeout:
            return "hang", f"> {TIME_LIMIT_S} s"
        except MemoryError:
            return "memory", "MemoryError"
        except Exception as e:
            tb = traceback.extract_tb(e.__traceback__)
            where = f"{Path(tb[-1].filename).name}:{tb[-1].lineno}" if tb else "?"
            detail = f"{type(e).__name__}: {str(e)[:150]} at {where}"
            if "SVD did not converge" in str(e):
                return "known-geometry", detail
            return "traceback", detail
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, old_alarm)
        text = err.getvalue()
        new = sorted(set(os.listdir(d)) - before)
        temps = [x for x in new if TEMP_NAME.match(x)]
        if code == 0:
            o = Path([a for i, a in enumerate(argv) if i and argv[i - 1] == "-o"][-1])
            if temps:
                return "left-output", f"temporaries {temps}"
            try:
                m = read_bvh(o)
            except Exception as e:
                return "bad-output", f"{type(e).__name__}: {str(e)[:150]}"
            if m.n_frames != case.body_frames and not any("body" in x for x in case.mutations[1:]):
                return "bad-output", f"{m.n_frames} frames, expected {case.body_frames}"
            return "ok", ""
        if code not in (1, 2):
            return "bad-message", f"exit {code}: {text[:150]!r}"
        lines = text.strip("\n").split("\n")
        if "out of memory" in text:
            return "memory", lines[0][:150]
        if len(lines) != 1 or not lines[0].startswith("splice: error: ") or len(lines[0]) > 500:
            return "bad-message", f"{len(lines)} lines, {len(text)} chars: {text[:150]!r}"
        left = [x for x in new if f"{d}/{x}" not in inputs]
        if left:
            return "left-output", f"{left[:3]} after {lines[0][:100]!r}"
        return "refused", lines[0][:200]
    finally:
        shutil.rmtree(d, ignore_errors=True)


def _worker(cases, start, conn):
    import splicer.cli  # noqa: F401 - the address space measured below includes the libraries
    import splicer.pipeline  # noqa: F401

    now = _address_space()
    if now:
        limit = now + MEMORY_HEADROOM
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    root = _scratch_root()
    for k in range(start, len(cases)):
        try:
            result = run_case(cases[k], root)
        except BaseException as e:  # noqa: BLE001 - anything that escapes is a finding
            result = ("traceback", f"harness: {type(e).__name__}: {str(e)[:150]}")
        conn.send((k, result))
    conn.send(None)
    conn.close()


def _address_space() -> int:
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def run_cases(cases: list[Case]) -> list[tuple[str, str]]:
    """Run every case in worker processes (restarted after a crash or a hang); (class, detail) each.

    Workers are started with "spawn", not "fork": a process that has run a splice has started
    numba's OpenMP thread pool, and a forked child using it is terminated by libgomp.
    """
    ctx = mp.get_context("spawn")
    results: list = [None] * len(cases)
    start = 0
    while start < len(cases):
        parent, child = ctx.Pipe(duplex=False)
        p = ctx.Process(target=_worker, args=(cases, start, child), daemon=True)
        p.start()
        child.close()
        k = start
        while True:
            if not parent.poll(3 * TIME_LIMIT_S + 30):
                results[k] = ("hang", "worker did not answer")
                p.kill()
                break
            try:
                msg = parent.recv()
            except EOFError:
                results[k] = ("crash", f"worker died (exit {p.exitcode})")
                break
            if msg is None:
                k = len(cases)
                break
            k, res = msg
            results[k] = res
            k += 1
        p.join(5)
        parent.close()
        start = k + 1 if k < len(cases) and results[k] is not None else k
    return results


def failures(cases, results) -> list[tuple[str, str, list]]:
    """(class, detail, mutations) of every case outside the accepted classes."""
    allowed = set(OK_CLASSES) | ({"known-geometry"} if KNOWN_GEOMETRY_ALLOWED else set())
    return [(c, d, case.mutations) for case, (c, d) in zip(cases, results) if c not in allowed]
