"""The report's JSON text (splicer.report.json_text) and its rounded per-frame lists."""

import json

import numpy as np
import pytest

from splicer.report import _round_list, json_text


def test_worked_layout():
    doc = {"sides": {"left": {"hands_frame": [0.0, 1.5, None], "low_confidence": [[3, 7], [10, 12]],
                              "joints": {}, "warnings": ["a", "b"]}}, "n": 3, "ok": True}
    assert json_text(doc) == (
        '{\n'
        ' "sides": {\n'
        '  "left": {\n'
        '   "hands_frame": [0.0, 1.5, null],\n'
        '   "low_confidence": [\n'
        '    [3, 7],\n'
        '    [10, 12]\n'
        '   ],\n'
        '   "joints": {},\n'
        '   "warnings": [\n'
        '    "a",\n'
        '    "b"\n'
        '   ]\n'
        '  }\n'
        ' },\n'
        ' "n": 3,\n'
        ' "ok": true\n'
        '}')


def test_empty_containers_and_scalars():
    assert json_text([]) == "[]"
    assert json_text({}) == "{}"
    assert json_text("x\n\"y\"") == json.dumps("x\n\"y\"")
    assert json_text(None) == "null"
    assert json_text([True, False]) == "[\n true,\n false\n]"  # booleans are not numbers: one per line
    assert json_text({1: "a", None: "b", 2.5: "c"}) == json.dumps({1: "a", None: "b", 2.5: "c"}, indent=1)


def _random_doc(rng, depth=0):
    kind = rng.integers(0, 7 if depth < 4 else 4)
    if kind == 0:
        return float(rng.normal()) if rng.random() < 0.8 else None
    if kind == 1:
        return int(rng.integers(-5, 5))
    if kind == 2:
        return "".join(rng.choice(list("ab\"\\\n é{}[],:"), size=int(rng.integers(0, 6))))
    if kind == 3:
        return [float(v) for v in rng.normal(size=int(rng.integers(0, 5)))]
    if kind == 4:
        return [_random_doc(rng, depth + 1) for _ in range(int(rng.integers(0, 4)))]
    if kind == 5:
        return {f"k{k}": _random_doc(rng, depth + 1) for k in range(int(rng.integers(0, 4)))}
    return bool(rng.integers(0, 2))


@pytest.mark.parametrize("seed", range(20))
def test_reads_back_as_json_dumps(seed):
    rng = np.random.default_rng(seed)
    doc = {f"k{k}": _random_doc(rng) for k in range(6)}
    text = json_text(doc)
    assert json.loads(text) == json.loads(json.dumps(doc))
    # a list of numbers is one line; every other container spans lines, as json.dumps(indent=1)
    assert text.count("\n") <= json.dumps(doc, indent=1).count("\n")


def test_per_frame_lists_stay_on_one_line():
    doc = {"sides": {"left": {"confidence": _round_list(np.linspace(0, 1, 10_000), 3)}}}
    assert json_text(doc).count("\n") == 6


def test_round_list_worked():
    assert _round_list([1.23456, np.nan, -np.inf, 2.0, -0.00004], 4) == [1.2346, None, None, 2.0, -0.0]
    assert _round_list(np.array([[0.5]]).ravel(), 0) == [0.0]  # half to even, as numpy and Python round
    assert _round_list([], 3) == []
    out = _round_list(np.array([1.5, 2.5]), 0)
    assert out == [2.0, 2.0] and all(type(v) is float for v in out)


def test_round_list_matches_python_round():
    """numpy's rounding (scale, round half to even, unscale) against Python's exact decimal rounding:
    the same on per-frame values but at exact-decimal near-ties, where they differ by one unit
    of the last digit."""
    rng = np.random.default_rng(0)
    a = np.concatenate([rng.uniform(0, 5000, 20_000), rng.uniform(0, 1, 20_000)])
    got = _round_list(a, 4)
    want = [round(float(v), 4) for v in a]
    diff = np.abs(np.array(got) - np.array(want))
    assert (diff == 0).mean() > 0.999
    assert diff.max() <= 1e-4 * (1 + 1e-9)


def test_the_summary_states_estimates_past_the_risk_model_as_over_its_top_rung():
    """The worst low-confidence ranges in the summary: an estimate within the risk model's rungs
    as a number, one past them (an extrapolation: a body hold once read "~54.25 s") as "over 0.4 s"."""
    from types import SimpleNamespace

    from splicer.stages.log import Log
    from splicer.stages.report import _coverage_report

    n = 40
    est = np.full(n, 0.01)
    est[5:10], est[20:30] = 0.25, 54.25
    conf = SimpleNamespace(confidence=np.ones(n), est_error_s=est, disagreement_s=None)
    side = SimpleNamespace(side="left", hands_frame=np.arange(n, dtype=float),
                           alignment=SimpleNamespace(covered=None, ends="fixed", confidence=conf),
                           markers=SimpleNamespace(spaces=SimpleNamespace(body_fps=5.0)))  # 10 frames: 2 s apart
    log = Log()
    out = _coverage_report(side, n, log)
    assert out["low_confidence"] == [[5, 9], [20, 29]]
    assert log.warnings == ["left side: low confidence in 38% of body frames; worst 20-29 (over 0.4 s), "
                            "5-9 (~0.25 s); a pin (constraints file) near frame 24 would help most"]
    assert out["est_error_s"][20] == 54.25  # the report keeps the number


def test_low_confidence_stretches_under_a_second_apart_are_one_range():
    """Worked, at 10 fps (under 1 s apart: at most 9 frames between): stretches 9 frames apart join,
    10 apart do not; an uncovered frame (NaN) is never inside a range, and a join does not cross it."""
    from splicer.stages.report import low_confidence_ranges

    est = np.zeros(60)
    est[0:5] = est[14:20] = est[30:35] = 0.3  # 9 frames between the first two, 10 between the next
    assert low_confidence_ranges(est, 10.0) == [[0, 19], [30, 34]]
    est[10] = np.nan  # an uncovered frame inside the joined stretch splits it
    assert low_confidence_ranges(est, 10.0) == [[0, 9], [11, 19], [30, 34]]
    est[:] = 0.05
    assert low_confidence_ranges(est, 10.0) == []
    assert low_confidence_ranges(np.array([0.2, 0.0, 0.2]), 0.5) == [[0, 0], [2, 2]]  # under 1 frame: no join
