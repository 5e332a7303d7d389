"""Stage 6b (splicer.stages.overlap): open ends that skipped both takes' heads or tails at once,
checked against one take's ends by the hand's motion relative to the forearm; and the partial
overlap end to end on the ground-truth protocol."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import splicer.stages.overlap as O
from splicer.align.band import full_band
from splicer.align.passes import PassResult
from splicer.options import SpliceOptions
from splicer.stages.log import Log

from test_recheck import _pair, _side


def _pass(path, n=10, m=20, ends="open", located=None):
    return PassResult(np.asarray(path, dtype=np.int64), 0.0, full_band(n, m), "pass1", ends=ends, located=located)


@pytest.mark.parametrize("path,expected", [
    ([[0, 4], [9, 13]], False),     # starts on row 0 (the hands' head skipped), ends on the last row
    ([[3, 0], [8, 19]], False),     # starts on column 0 (the body's head uncovered), ends on the last column
    ([[3, 4], [9, 13]], True),      # starts past both heads
    ([[0, 4], [7, 15]], True),      # ends before both tails
    ([[0, 0], [9, 19]], False),
])
def test_skipped_both_reads_the_path_ends(path, expected):
    assert _pass(path).skipped_both() is expected
    assert _pass(path, ends="fixed").skipped_both() is False   # fixed ends never skip
    side = SimpleNamespace(alignment=SimpleNamespace(pass1=_pass(path)))
    assert O.skipped_both({"left": side}) is expected
    # the locating pass counts too (its own band): the full-rate band may have lost the skip
    loc = _pass([[1, 1], [4, 5]], n=5, m=8)
    side = SimpleNamespace(alignment=SimpleNamespace(pass1=_pass([[0, 4], [9, 13]], located=loc)))
    assert O.skipped_both({"left": side}) is True


def test_both_skip_options_resolve_auto(monkeypatch):
    marks = {s: r.markers for s, r in _pair().items()}
    monkeypatch.setattr("splicer.align.wrist.markers_compare", lambda placed, a, b: True)
    assert O.both_skip_options(marks, SpliceOptions()).both_skip == "on"
    for fixed in ("on", "off"):
        assert O.both_skip_options(marks, SpliceOptions(both_skip=fixed)).both_skip == fixed
    one = {"left": _side(hand_only=True).markers, "right": marks["right"]}
    assert O.both_skip_options(one, SpliceOptions()).both_skip == "off"      # a hand-only file: not checkable
    optical = {"left": _side(real={"hands": "h.c3d"}).markers, "right": marks["right"]}
    assert O.both_skip_options(optical, SpliceOptions()).both_skip == "off"  # optical markers
    monkeypatch.setattr("splicer.align.wrist.markers_compare", lambda placed, a, b: False)
    assert O.both_skip_options(marks, SpliceOptions()).both_skip == "off"


@pytest.fixture
def check(monkeypatch):
    """A first pair that skipped both heads, a one-take-ends pair from ``realign``/``finish``,
    and :func:`coverage_mismatch` read from a table keyed by which pair it is given."""
    skipped = _pair()
    for r in skipped.values():
        r.alignment.pass1 = _pass([[3, 4], [9, 13]])
    other = _pair(shift=1.0)
    calls, mismatch = [], {}

    def realign(opts, log, markers=None):
        calls.append(opts.both_skip)
        log.note("one-take run")
        return "aligned"

    monkeypatch.setattr(O, "coverage_mismatch",
                        lambda pairs: np.array([mismatch["other" if p is other else "first"] for p in pairs]))
    return SimpleNamespace(skipped=skipped, other=other, calls=calls, mismatch=mismatch, realign=realign,
                           finish=lambda aligned, log: other)


@pytest.mark.parametrize("first,one,kept", [(0.3, 0.5, "both"), (0.5, 0.5, "both"), (0.6, 0.4, "one"),
                                             (np.nan, 0.4, "one"), (0.3, np.nan, "both")])
def test_the_better_matching_overlap_is_kept(check, first, one, kept):
    check.mismatch.update(first=first, other=one)
    log = Log()
    log.note("before")
    since = len(log.warnings)
    log.note("first run")
    opts = SpliceOptions(both_skip="on")
    sides, after, since_after = O.check_both_skip(check.skipped, opts, log, realign=check.realign,
                                                  finish=check.finish, since=since)
    assert check.calls == ["off"]          # aligned once more, on one take's ends
    assert log.warnings[0] == "before" and since_after == since + 1
    # the check's note comes before the kept alignment's own notes (a second opinion replaces those)
    assert "overlap partly" in log.warnings[1]
    if kept == "both":
        assert sides is check.skipped and after is opts
        assert "it is kept" in log.warnings[1]
        assert log.warnings[2:] == ["first run"]
    else:
        assert sides is check.other and after.both_skip == "off"
        assert "the other is kept" in log.warnings[1]
        assert log.warnings[2:] == ["one-take run"]   # the kept one's notes
    assert "partial-overlap check" in log.timings


def test_nothing_to_check(check):
    for r in check.skipped.values():     # the path starts on row 0 and ends on the last row: one take's ends
        r.alignment.pass1 = _pass([[0, 4], [9, 13]])
    opts = SpliceOptions(both_skip="on")
    log = Log()
    assert O.check_both_skip(check.skipped, opts, log, realign=check.realign, finish=check.finish,
                             since=0) == (check.skipped, opts, 0)
    assert check.calls == [] and log.warnings == []
    for r in check.skipped.values():
        r.alignment.pass1 = _pass([[3, 4], [9, 13]])
    off = SpliceOptions(both_skip="off")   # nothing was skipped both ways: never re-aligned
    assert O.check_both_skip(check.skipped, off, log, realign=check.realign, finish=check.finish,
                             since=0) == (check.skipped, off, 0)
    assert check.calls == []


def test_both_skip_weight_by_option():
    import splicer.defaults as D
    from splicer.stages.align import both_skip_weight
    assert both_skip_weight(SpliceOptions(both_skip="on")) == D.BOTH_SKIP_WEIGHT
    assert both_skip_weight(SpliceOptions(both_skip="off")) is None
    assert both_skip_weight(SpliceOptions()) is None    # "auto" unresolved: a stage called alone, off
    from splicer.errors import SplicerError
    from splicer.options import resolve_options
    with pytest.raises(SplicerError, match="both_skip must be one of auto, on, off"):
        resolve_options(None, {"both_skip": "sometimes"})


def test_partial_overlap_on_the_protocol():
    """Synthetic *all*, tuning seed 19: the hands take starts with 3.5 s of extra material and
    covers the body from frame 346 on.  On one take's ends the body's first covered frames got
    that extra material (up to 3 s off); skipping both heads at once, they get the genuine start."""
    from splicer import splice
    from splicer.evaluation.scenario_types import alignment_error_s, scenario
    from splicer.evaluation.scenarios import make_scenario
    from splicer.evaluation.synth import make_gesture_take

    take = make_gesture_take(60.0, 30.0, np.random.default_rng(0))
    sep = make_scenario(take, scenario("all"), rng=np.random.default_rng(19))
    errs = {}
    for mode in ("auto", "off"):
        res = splice(sep.body, sep.hands, both_skip=mode)
        e = alignment_error_s(sep, np.asarray(res.sides["left"].hands_frame, dtype=np.float64))
        errs[mode] = e[np.isfinite(e)]
        if mode == "auto":
            assert any("overlap partly" in w and "it is kept" in w for w in res.report.warnings)
            assert res.report["sides"]["left"]["uncovered"][0][0] == 0   # the body's head uncovered
    first = np.flatnonzero(sep.covered)[0]
    assert errs["off"].max() > 1.0 and np.percentile(errs["off"], 95) > 1.0
    assert errs["auto"].mean() < 0.05 and np.percentile(errs["auto"], 95) < 0.1
    assert first > 300
