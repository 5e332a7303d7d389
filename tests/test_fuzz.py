"""Issue 10, fuzzing in CI: property tests (hypothesis) of the BVH reader, the constraints
parser and the command line, and a seeded mutational fuzz of ``splice`` over the small sample
takes, the sample constraints and (when present) small cuts of the real files in
``../shared/motions``.  Every case must end in one of two classes: success with a valid output,
or exit 1/2 with one short line and nothing written (see tests/fuzzkit.py).

About 2,450 generated cases per run: 4 x 500 mutational cases through ``splicer.cli.main``
in forked workers (memory cap, time limit), 200 + 200 reader and parser cases, 50 command
lines.  benchmarks/fuzz_nightly.py runs the mutational part longer.
"""

from __future__ import annotations

import collections
import math
import warnings

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fuzzkit
from fault_helpers import small_texts
from splicer.io import limits
from splicer.io.bvh import read_bvh, write_bvh
from splicer.io.config import SpliceConfig, frame_number, parse_config
from splicer.errors import BVHError, ConstraintError, SplicerWarning

SETTINGS = dict(deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def _one_line(message: str) -> None:
    assert "\n" not in message and 0 < len(message) <= 500, message[:300]


# ---------------------------------------------------------------------------------------
# the BVH reader
# ---------------------------------------------------------------------------------------
BAD_NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64).map(repr),
    st.integers(-10**12, 10**12).map(str),
    st.sampled_from(fuzzkit.NUMBERS),
    st.text(alphabet="0123456789.eE+-_x³١ ", min_size=0, max_size=8),
)
GOOD_NUMBER = st.floats(-1000, 1000, allow_nan=False, width=32).map(lambda v: f"{v:.6g}")
BAD_NAME = st.one_of(st.sampled_from(fuzzkit.NAMES), st.text(min_size=0, max_size=6))
GOOD_NAME = st.text(alphabet="abcXYZ_:0123456789", min_size=1, max_size=12)
GOOD_CHANNELS = st.lists(st.sampled_from(["Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation",
                                          "Zrotation"]), min_size=0, max_size=6, unique=True)
BAD_CHANNELS = st.lists(st.sampled_from(["Xposition", "Zrotation", "zrotation", "Wrotation", "Xrotation"]),
                        min_size=0, max_size=7)


@st.composite
def bvh_texts(draw):
    """A BVH text from a random skeleton; each field is wrong with probability 1/15 (counts,
    numbers, names, channels, braces, frame counts, rows, line endings)."""

    def pick(good, bad):
        return draw(bad if draw(st.integers(0, 14)) == 0 else good)

    n_joints = draw(st.integers(1, 6))
    out = ["HIERARCHY"]
    n_ch = 0
    depth = 0
    names = set()
    for j in range(n_joints):
        name = pick(GOOD_NAME, BAD_NAME)
        name = name if name not in names else name + str(j)
        names.add(name)
        out.append(f"{'ROOT' if j == 0 else 'JOINT'} {name}")
        out.append("{")
        out.append("OFFSET " + " ".join(pick(GOOD_NUMBER, BAD_NUMBER) for _ in range(pick(st.just(3), st.sampled_from([2, 4])))))
        chans = pick(GOOD_CHANNELS, BAD_CHANNELS)
        count = pick(st.just(str(len(chans))), st.sampled_from(["³", "9", "0", "99999999999999"]))
        out.append(f"CHANNELS {count} " + " ".join(chans))
        n_ch += len(chans)
        depth += 1
        if draw(st.booleans()):
            out += ["End Site", "{", "OFFSET 0 1 0", "}"]
        if j < n_joints - 1 and draw(st.booleans()):  # close some joints: siblings
            close = draw(st.integers(0, depth - 1))
            out += ["}"] * close
            depth -= close
    out += ["}"] * pick(st.just(depth), st.sampled_from([depth - 1, depth + 1]))
    frames = draw(st.integers(0, 5))
    out.append("MOTION")
    out.append(f"Frames: {pick(st.just(str(frames)), st.sampled_from(['-1', '³', '1e3', '', '10000000']))}")
    out.append(f"Frame Time: {pick(st.sampled_from(['0.0333333', '0.008333', '0.0001', '10']), BAD_NUMBER)}")
    for _ in range(frames + pick(st.just(0), st.sampled_from([1, -1]))):
        cols = n_ch + pick(st.just(0), st.sampled_from([-1, 1]))
        out.append(" ".join(pick(GOOD_NUMBER, BAD_NUMBER) for _ in range(max(cols, 0))))
    sep = pick(st.sampled_from(["\n", "\r\n"]), st.sampled_from(["\r", "\n\t", "\n\n"]))
    return sep.join(out) + "\n"


def _check_reader(path) -> None:
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SplicerWarning)
            m = read_bvh(path)
    except BVHError as e:
        _one_line(str(e))
        return
    for w in caught:
        assert issubclass(w.category, SplicerWarning)
        _one_line(str(w.message))
    assert m.channels.shape == (m.n_frames, m.skeleton.n_channels)
    assert m.n_frames <= limits.MAX_FRAMES
    assert np.all(np.abs(m.channels) <= limits.MAX_ABS_VALUE)
    assert np.all(np.abs(m.skeleton.offsets) <= limits.MAX_ABS_VALUE)
    lo, hi = limits.FRAME_TIME_RANGE
    assert lo <= m.frame_time <= hi
    assert all(0 < len(n) <= limits.MAX_NAME and n.isprintable() for n in m.skeleton.names)
    return m


@settings(max_examples=150, **SETTINGS)
@given(text=bvh_texts())
def test_reader_on_generated_bvh(tmp_path_factory, text):
    p = tmp_path_factory.mktemp("h") / "g.bvh"
    p.write_text(text, encoding="utf-8", errors="surrogateescape")
    m = _check_reader(p)
    if m is not None:  # what was read is written back and reads back the same
        try:
            write_bvh(m, p.with_name("w.bvh"))
        except BVHError as e:  # names BVH cannot hold (e.g. double spaces)
            _one_line(str(e))
            return
        m2 = read_bvh(p.with_name("w.bvh"))
        # the writer keeps 12 significant digits (README: round trip within 1e-4)
        np.testing.assert_allclose(m2.channels, m.channels, rtol=1e-11, atol=1e-9)
        assert m2.skeleton.names == m.skeleton.names


@settings(max_examples=50, **SETTINGS)
@given(data=st.data())
def test_reader_on_mutated_sample(tmp_path_factory, data):
    import random

    body = small_texts()[0]
    rng = random.Random(data.draw(st.integers(0, 2**32 - 1)))
    for _ in range(data.draw(st.integers(1, 3))):
        body, _ = fuzzkit.mutate_bvh(body, rng)
    p = tmp_path_factory.mktemp("m") / "m.bvh"
    p.write_text(body, encoding="utf-8", errors="surrogateescape")
    _check_reader(p)


# ---------------------------------------------------------------------------------------
# the constraints parser
# ---------------------------------------------------------------------------------------
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30), st.floats(), st.text(max_size=20),
                    st.sampled_from(["4.2s", "1e308s", "0.05s", "-1s", "2001-13-45", "left", "right", "both", "y"]))
def _containers(inner):
    return st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4))


VALUES = st.recursive(SCALARS, _containers, max_leaves=20)
DOCS = st.dictionaries(st.sampled_from(["tolerance", "side", "pairs", "joints", "up", "hands_side", "extra"]),
                       st.one_of(VALUES, st.lists(st.fixed_dictionaries(
                           {"body": SCALARS, "hands": SCALARS},
                           optional={"tolerance": SCALARS, "side": SCALARS}), max_size=4)), max_size=5)


def _check_config(text: str) -> None:
    try:
        cfg = parse_config(text, "f.yaml")
    except ConstraintError as e:
        _one_line(str(e))
        return
    assert isinstance(cfg, SpliceConfig)
    for p in cfg.pairs:
        for v in (p.body, p.hands):
            assert abs(frame_number(v, 120.0, what="x")) <= limits.MAX_FRAME_NUMBER


@settings(max_examples=120, **SETTINGS)
@given(doc=DOCS)
def test_parser_on_generated_documents(doc):
    _check_config(yaml.safe_dump(doc, allow_unicode=True))


@settings(max_examples=60, **SETTINGS)
@given(text=st.one_of(st.text(max_size=200), st.text(alphabet="[]{}&*!:-,|>'\"#? \n\tab12.se", max_size=200)))
def test_parser_on_arbitrary_text(text):
    _check_config(text)


@settings(max_examples=40, **SETTINGS)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 4))
def test_parser_on_mutated_sample(seed, n):
    import random

    rng = random.Random(seed)
    text = fuzzkit.SAMPLE_BODY.parent.joinpath("sample_sync.yaml").read_text()
    for _ in range(n):
        text, _ = fuzzkit.mutate_yaml(text, rng)
    _check_config(text)


@settings(max_examples=100, **SETTINGS)
@given(value=st.one_of(SCALARS, st.floats(allow_nan=True, allow_infinity=True)), fps=st.sampled_from([0.1, 30.0, 1e4]))
def test_frame_number_is_bounded_or_refused(value, fps):
    try:
        f = frame_number(value, fps, what="x")
    except ConstraintError as e:
        _one_line(str(e))
        return
    assert isinstance(f, int) and abs(f) <= limits.MAX_FRAME_NUMBER
    if isinstance(value, float):
        assert math.isfinite(value)


# ---------------------------------------------------------------------------------------
# the command line
# ---------------------------------------------------------------------------------------
@settings(max_examples=50, **SETTINGS)
@given(opts=st.lists(st.sampled_from(sorted(fuzzkit.OPTIONS)).flatmap(
    lambda o: st.tuples(st.just(o), st.one_of(st.sampled_from(fuzzkit.OPTIONS[o]), st.text(max_size=10)))),
    max_size=3), report=st.booleans())
def test_command_line_options(opts, report):
    body, hands = small_texts()
    argv = ["{body}", "{hands}", "-o", "{out}", "-q", "--side", "right", "--passes", "pass1"]
    argv += [x for o, v in opts for x in (o, v.replace("{", "(").replace("}", ")"))]
    argv += ["--report", "{r}"] if report else []
    case = fuzzkit.Case({"body": body.encode(), "hands": hands.encode()}, argv, 40, ["cli"])
    cls, detail = fuzzkit.run_case(case, fuzzkit._scratch_root())
    assert cls in fuzzkit.OK_CLASSES, (cls, detail, argv)


# ---------------------------------------------------------------------------------------
# the classifier itself (each failure class is recognised)
# ---------------------------------------------------------------------------------------
def _sample_case():
    body, hands = small_texts()
    argv = ["{body}", "{hands}", "-o", "{out}", "-q", "--side", "right", "--passes", "pass1"]
    return fuzzkit.Case({"body": body.encode(), "hands": hands.encode()}, argv, 40, ["sample"])


def _broken_splice(kind):
    def splice(*args, **kwargs):
        import sys
        import time

        from splicer.errors import SplicerError

        if kind == "traceback":
            raise RuntimeError("boom")
        if kind == "memory":
            raise MemoryError
        if kind == "hang":
            time.sleep(5)
        if kind == "bad-message":
            print("extra line", file=sys.stderr)
            raise SplicerError("bad")
        raise AssertionError(kind)

    return splice


@pytest.mark.parametrize("kind", ["traceback", "memory", "hang", "bad-message"])
def test_classifier_recognises_failures(monkeypatch, tmp_path, kind):
    import splicer.pipeline

    monkeypatch.setattr(splicer.pipeline, "splice", _broken_splice(kind))
    monkeypatch.setattr(fuzzkit, "TIME_LIMIT_S", 1)
    cls, detail = fuzzkit.run_case(_sample_case(), str(tmp_path))
    assert cls == kind, detail
    assert fuzzkit.failures([_sample_case()], [(cls, detail)]) != []


def test_classifier_recognises_left_output(monkeypatch, tmp_path):
    from splicer import cli

    def fail_after_writing(result, out, elapsed, after=None, before=None):  # an output exists, then exit 1
        from splicer.errors import SplicerError

        raise SplicerError("late failure")

    monkeypatch.setattr(cli, "_summary", fail_after_writing)
    case = _sample_case()
    case.argv.remove("-q")
    cls, detail = fuzzkit.run_case(case, str(tmp_path))
    assert cls == "left-output", detail


def test_classifier_accepts_success_and_refusal(tmp_path):
    assert fuzzkit.run_case(_sample_case(), str(tmp_path)) == ("ok", "")
    case = _sample_case()
    case.files["body"] = b"HIERARCHY\n"
    cls, detail = fuzzkit.run_case(case, str(tmp_path))
    assert cls == "refused" and "body.bvh" in detail, detail


# ---------------------------------------------------------------------------------------
# the seeded mutational campaign
# ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pairs():
    return fuzzkit.base_pairs()


@pytest.mark.fuzz
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_mutational_fuzz(seed, pairs):
    cases = fuzzkit.make_cases(seed, 500, pairs)
    results = fuzzkit.run_cases(cases)
    counts = collections.Counter(c for c, _ in results)
    bad = fuzzkit.failures(cases, results)
    assert bad == [], f"{counts}: {bad[:5]}"
    assert sum(counts.values()) == 500
    assert counts["ok"] >= 25 and counts["refused"] >= 250, counts  # both paths are exercised
